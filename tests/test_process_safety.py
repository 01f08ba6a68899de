"""armcal runs no code a spec's repository or a shared cache could plant.

git_info reads real throwaway repositories (made with git in tmp_path) without starting
any program their configuration names; the compiled-function cache is private, and a
library that is corrupt, replaced or writable by others is rebuilt, never loaded.
"""

import os
import pwd
import subprocess
import sys

import casadi as ca
import numpy as np
import pytest

from armcal.support import compiled as cache
from armcal.results.provenance import git_info

GIT_ENV = {
    **{k: v for k, v in os.environ.items() if not k.startswith("GIT_")},
    "GIT_CONFIG_NOSYSTEM": "1",
    "GIT_CONFIG_GLOBAL": os.devnull,
    "GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@example.com",
    "GIT_COMMITTER_NAME": "t", "GIT_COMMITTER_EMAIL": "t@example.com",
}
as_root = pytest.mark.skipif(os.geteuid() != 0, reason="changing a file's owner needs root")


def git(repo, *args):
    return subprocess.run(["git", "-C", str(repo), *args], check=True, capture_output=True, text=True, env=GIT_ENV).stdout.strip()


def make_repo(folder, *init_options):
    """A repository with one commit holding specs/spec.yaml and notes.txt."""
    folder.mkdir(parents=True)
    git(folder, "init", "-q", "-b", "main", *init_options)
    (folder / "specs").mkdir()
    (folder / "specs" / "spec.yaml").write_text("robot: {name: r}\n")
    (folder / "notes.txt").write_text("notes\n")
    git(folder, "add", "-A")
    git(folder, "commit", "-qm", "first")
    return folder


# -- git_info -------------------------------------------------------------------------------


def test_clean_and_dirty_mean_the_spec_file_against_its_committed_version(tmp_path):
    repo = make_repo(tmp_path / "repo")
    spec = repo / "specs" / "spec.yaml"
    head = git(repo, "rev-parse", "HEAD")
    assert git_info(spec) == {"commit": head, "dirty": False}
    (repo / "notes.txt").write_text("other files do not count\n")
    (repo / "untracked.txt").write_text("x\n")
    assert git_info(spec) == {"commit": head, "dirty": False}
    spec.write_text("robot: {name: changed}\n")
    assert git_info(spec) == {"commit": head, "dirty": True}
    git(repo, "add", "specs/spec.yaml")  # staged but not committed
    assert git_info(spec)["dirty"] is True
    git(repo, "commit", "-qm", "second")
    assert git_info(spec) == {"commit": git(repo, "rev-parse", "HEAD"), "dirty": False}
    (repo / "specs" / "new.yaml").write_text("robot: {}\n")
    assert git_info(repo / "specs" / "new.yaml")["dirty"] is True  # not in the commit at all


def test_packed_objects_deltas_refs_and_a_detached_head(tmp_path):
    repo = make_repo(tmp_path / "repo")
    spec = repo / "specs" / "spec.yaml"
    for i in range(12):
        spec.write_text("".join(f"line {j}\n" for j in range(100 + i)))
        (repo / f"file{i % 4}.txt").write_text(f"{i}\n" * 50)
        git(repo, "commit", "-qam", f"c{i}")
    git(repo, "gc", "-q", "--aggressive")
    assert not list((repo / ".git" / "refs" / "heads").iterdir())  # the branch lives in packed-refs
    assert "delta" in git(repo, "verify-pack", "-v", *map(str, (repo / ".git" / "objects" / "pack").glob("*.idx")))
    assert git_info(spec) == {"commit": git(repo, "rev-parse", "HEAD"), "dirty": False}
    git(repo, "checkout", "-q", "--detach", "HEAD~5")
    assert git_info(spec) == {"commit": git(repo, "rev-parse", "HEAD"), "dirty": False}
    spec.write_text(spec.read_text() + "more\n")
    assert git_info(spec)["dirty"] is True


def test_gitfiles_of_worktrees_and_separate_git_folders(tmp_path):
    repo = make_repo(tmp_path / "repo")
    git(repo, "worktree", "add", "-q", str(tmp_path / "wt"))
    separate = make_repo(tmp_path / "separate", "--separate-git-dir", str(tmp_path / "store.git"))
    for tree in (tmp_path / "wt", separate):
        assert (tree / ".git").is_file()
        spec = tree / "specs" / "spec.yaml"
        assert git_info(spec) == {"commit": git(tree, "rev-parse", "HEAD"), "dirty": False}
        spec.write_text("changed\n")
        assert git_info(spec)["dirty"] is True


def test_a_sha256_repository(tmp_path):
    repo = make_repo(tmp_path / "repo", "--object-format=sha256")
    head = git(repo, "rev-parse", "HEAD")
    assert len(head) == 64 and git_info(repo / "specs" / "spec.yaml") == {"commit": head, "dirty": False}


def test_nothing_a_repository_configures_is_run(tmp_path, monkeypatch):
    repo = make_repo(tmp_path / "repo")
    marker = tmp_path / "ran"
    script = tmp_path / "trap.sh"
    script.write_text(f"#!/bin/sh\necho \"$0 $*\" >> {marker}\ncat\n")
    script.chmod(0o755)
    hooks = tmp_path / "hooks"
    hooks.mkdir()
    for hook in ("pre-commit", "post-checkout", "post-index-change", "reference-transaction", "fsmonitor-watchman"):
        (hooks / hook).symlink_to(script)
    (repo / ".git" / "config").open("a").write(
        f"[core]\n\tfsmonitor = {script}\n\thooksPath = {hooks}\n\tsshCommand = {script}\n\tpager = {script}\n"
        f"\teditor = {script}\n\taskPass = {script}\n"
        f'[filter "trap"]\n\tclean = {script}\n\tsmudge = {script}\n\tprocess = {script}\n\trequired = true\n'
        f'[diff]\n\texternal = {script}\n[diff "trap"]\n\ttextconv = {script}\n'
        f"[gpg]\n\tprogram = {script}\n[credential]\n\thelper = !{script}\n"
    )
    (repo / ".gitattributes").write_text("* filter=trap diff=trap\n")
    subprocess.run(["git", "-C", str(repo), "status"], capture_output=True, env=GIT_ENV)
    assert marker.exists()  # the trap is armed: an ordinary git status springs it
    marker.unlink()

    def no_processes(*args, **kwargs):
        raise AssertionError(f"git_info started a process: {args}")

    monkeypatch.setattr(subprocess, "Popen", no_processes)
    monkeypatch.setattr(os, "posix_spawn", no_processes)
    spec = repo / "specs" / "spec.yaml"
    assert git_info(spec)["dirty"] is False
    spec.write_text("changed\n")
    assert git_info(spec)["dirty"] is True
    assert not marker.exists()


def test_outside_git_unborn_and_unreadable_repositories(tmp_path):
    (tmp_path / "plain").mkdir()
    (tmp_path / "plain" / "spec.yaml").write_text("robot: {}\n")
    assert git_info(tmp_path / "plain" / "spec.yaml") is None
    unborn = tmp_path / "unborn"
    unborn.mkdir()
    git(unborn, "init", "-q")
    (unborn / "spec.yaml").write_text("robot: {}\n")
    assert git_info(unborn / "spec.yaml") is None
    fifo = make_repo(tmp_path / "fifo")
    (fifo / ".git" / "HEAD").unlink()
    os.mkfifo(fifo / ".git" / "HEAD")  # read, it would block forever
    assert git_info(fifo / "specs" / "spec.yaml") is None


def test_a_committed_version_that_cannot_be_read_counts_as_dirty(tmp_path):
    repo = make_repo(tmp_path / "repo")
    head = git(repo, "rev-parse", "HEAD")
    for loose in (repo / ".git" / "objects").glob("??/*"):
        loose.chmod(0o644)
        loose.write_bytes(b"not zlib")
    assert git_info(repo / "specs" / "spec.yaml") == {"commit": head, "dirty": True}


@as_root
def test_a_repository_of_another_user_is_read_without_trusting_it(tmp_path):
    repo = make_repo(tmp_path / "repo")
    head = git(repo, "rev-parse", "HEAD")
    nobody = pwd.getpwnam("nobody")
    for folder, _, files in os.walk(repo):
        for name in [folder, *(os.path.join(folder, f) for f in files)]:
            os.chown(name, nobody.pw_uid, nobody.pw_gid)
    assert subprocess.run(["git", "-C", str(repo), "rev-parse", "HEAD"], capture_output=True, env=GIT_ENV).returncode != 0
    assert git_info(repo / "specs" / "spec.yaml") == {"commit": head, "dirty": False}


# -- the compiled-function cache ------------------------------------------------------------

POINTS = [(-1.3, [0.2, -0.7]), (0.0, [1.0, 0.5]), (2.1, [-3.0, 0.25])]


def functions(scale=2.0):
    """Two small CasADi functions; ``scale`` makes a look-alike whose library must never be loaded."""
    x, y = ca.SX.sym("x"), ca.SX.sym("y", 2)
    return [ca.Function("f", [x], [ca.sin(x) * scale]), ca.Function("g", [x, y], [x * y[0], ca.exp(y[1]) + scale])]


def assert_compiled_like_reference(got):
    """Compiled (External) functions giving the uncompiled reference's numbers."""
    reference = functions()
    assert [f.class_name() for f in got] == ["External", "External"]
    for x, y in POINTS:
        assert float(got[0](x)) == pytest.approx(float(reference[0](x)), abs=1e-14)
        for a, b in zip(got[1].call([x, y]), reference[1].call([x, y])):
            assert float(a) == pytest.approx(float(b), abs=1e-14)


def plant(folder, identity, scale):
    """Build (without loading) the library ``compiled`` looks for, from look-alike functions."""
    library = library_path(folder, identity)
    folder.mkdir(mode=0o700, exist_ok=True)
    cache._build(functions(scale), ["f0", "f1"], library, "cc")
    return library


def library_path(folder, identity):
    compiler = cache.shutil.which(cache.os.environ.get("CC", "cc")) or cache.shutil.which("gcc")
    digest = cache.hashlib.sha256(f"{identity}|armcal {cache.__version__}|casadi {ca.__version__}|{cache.builder.flavour(compiler)}".encode()).hexdigest()[:32]
    return folder / f"armcal_{digest}.so"


def replace_bytes(path, data):
    """New content in a new inode (the old one may be mapped by a loaded library)."""
    path.unlink()
    path.write_bytes(data)


@pytest.fixture
def folder(tmp_path, monkeypatch):
    monkeypatch.setenv("ARMCAL_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("ARMCAL_COMPILE", "now")  # tests of the compiled cache, whatever mode the suite runs in
    return tmp_path / "cache"


def test_umask_000_still_gives_a_private_cache(tmp_path, monkeypatch):
    folder = tmp_path / "deep" / "cache"
    monkeypatch.setenv("ARMCAL_CACHE", str(folder))
    monkeypatch.setenv("ARMCAL_COMPILE", "now")
    previous = os.umask(0)
    try:
        assert_compiled_like_reference(cache.compiled(functions(), "umask"))
    finally:
        os.umask(previous)
    assert (folder.stat().st_mode & 0o777, folder.parent.stat().st_mode & 0o777) == (0o700, 0o700)
    entries = list(folder.iterdir())
    assert sorted(p.suffix for p in entries) == [".sha256", ".so"]
    assert all(p.stat().st_mode & 0o777 in (0o600, 0o700) for p in entries)


def test_a_garbage_library_is_rebuilt(folder):
    library = plant(folder, "garbage", 2.0)
    replace_bytes(library, np.random.default_rng(0).bytes(library.stat().st_size))
    assert_compiled_like_reference(cache.compiled(functions(), "garbage"))
    assert library.read_bytes()[:4] == b"\x7fELF"


def test_a_library_whose_hash_does_not_match_its_record_is_rebuilt(folder):
    library = plant(folder, "mismatch", 3.0)
    (folder / (library.name + ".sha256")).write_text("0" * 64 + "\n")
    assert_compiled_like_reference(cache.compiled(functions(), "mismatch"))
    plant(folder, "missing", 3.0)
    (folder / (library_path(folder, "missing").name + ".sha256")).unlink()
    assert_compiled_like_reference(cache.compiled(functions(), "missing"))


@as_root
def test_a_library_of_another_user_is_rebuilt(folder):
    library = plant(folder, "owner", 3.0)
    nobody = pwd.getpwnam("nobody").pw_uid
    for path in (library, folder / (library.name + ".sha256")):
        os.chown(path, nobody, -1)
    assert_compiled_like_reference(cache.compiled(functions(), "owner"))
    assert library.stat().st_uid == os.geteuid()


def test_a_world_writable_cache_is_not_loaded_from(folder, capsys):
    library = plant(folder, "shared", 3.0)
    folder.chmod(0o777)
    assert_compiled_like_reference(cache.compiled(functions(), "shared"))
    assert "is writable by group or others" in capsys.readouterr().err
    assert cache._intact(library)  # the planted library was intact, and still not used


@as_root
def test_a_cache_of_another_user_is_not_loaded_from(folder, capsys):
    plant(folder, "theirs", 3.0)
    nobody = pwd.getpwnam("nobody").pw_uid
    for path in (folder, *folder.iterdir()):
        os.chown(path, nobody, -1)
    assert_compiled_like_reference(cache.compiled(functions(), "theirs"))
    assert f"belongs to user id {nobody}" in capsys.readouterr().err


CHILD = """
import casadi as ca, sys
sys.path.insert(0, sys.argv[1])
from test_process_safety import functions, assert_compiled_like_reference
from armcal.support.compiled import compiled
assert_compiled_like_reference(compiled(functions(), "truncated"))
"""


def test_a_truncated_library_is_rebuilt_by_the_next_run(folder):
    """Two runs in their own processes: the second finds the first's library cut short (once: SIGBUS)."""
    run = lambda: subprocess.run([sys.executable, "-c", CHILD, os.path.dirname(__file__)], capture_output=True, text=True)  # noqa: E731
    first = run()
    assert first.returncode == 0, first.stderr
    library = library_path(folder, "truncated")
    size = library.stat().st_size
    with library.open("r+b") as stream:
        stream.truncate(size // 3)
    second = run()
    assert second.returncode == 0, second.stderr
    assert library.stat().st_size == size


def test_without_a_compiler_the_functions_are_returned_as_given(folder, monkeypatch):
    monkeypatch.setenv("CC", "no-such-compiler")
    monkeypatch.setenv("PATH", "")
    given = functions()
    assert cache.compiled(given, "none") is given
