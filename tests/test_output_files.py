"""Every file a command writes with --out is a regular file written whole, and a failure to write is one user error
(issue 30 class 1): a pipe or device in its place is refused with --force too and stays what it was; a parent that is
a file, a name too long and a read-only folder end in one message naming the file, exit 1, no traceback."""

import os
import stat
import subprocess
import sys

import pytest
from conftest import ROOT, armcal_cli, armcal_process

URDF = ROOT / "tests" / "data" / "urdf" / "ros_industrial.urdf"


def _writers(out):
    """Commands that write one file at --out, with what they need."""
    return {
        "new": ("new", "--robot", "ur5e", "--device", "tracker", "--out", out, "--force"),
        "import-urdf": ("import-urdf", URDF, "--base", "base_link", "--tip", "tool0", "--out", out, "--force"),
    }


@pytest.mark.parametrize("command", ["new", "import-urdf"])
def test_a_pipe_at_out_is_refused_with_force_and_stays_a_pipe(tmp_path, command):
    pipe = tmp_path / "pipe.yaml"
    os.mkfifo(pipe)
    done = armcal_cli(*_writers(pipe)[command])
    assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr
    assert "is not a regular file" in done.stderr and str(pipe) in done.stderr
    assert stat.S_ISFIFO(os.lstat(pipe).st_mode)


@pytest.mark.parametrize("command", ["new", "import-urdf"])
@pytest.mark.parametrize("where", ["parent is a file", "name too long"])
def test_an_output_that_cannot_be_written_is_one_message(tmp_path, command, where):
    (tmp_path / "file").write_text("x")
    out = tmp_path / "file" / "spec.yaml" if where == "parent is a file" else tmp_path / ("x" * 300 + ".yaml")
    done = armcal_cli(*_writers(out)[command])
    assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr
    assert done.stderr.startswith("error: cannot write ") and done.stderr.count("\n") == 1, done.stderr


@pytest.mark.skipif(os.geteuid() != 0, reason="needs root to mount a read-only tmpfs")
def test_a_read_only_file_system_is_one_message(tmp_path):
    mount = tmp_path / "ro"
    mount.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m,ro", "tmpfs", str(mount)], capture_output=True).returncode != 0:
        pytest.skip("mounting a tmpfs is not allowed here")
    try:
        done = armcal_cli(*_writers(mount / "spec.yaml")["new"])
        assert done.returncode == 1 and "Read-only file system" in done.stderr and "Traceback" not in done.stderr, done.stderr
    finally:
        subprocess.run(["umount", str(mount)], capture_output=True)


def test_a_replaced_file_keeps_its_mode(tmp_path):
    out = tmp_path / "spec.yaml"
    out.write_text("old\n")
    out.chmod(0o640)
    done = armcal_cli(*_writers(out)["new"])
    assert done.returncode == 0, done.stderr
    assert out.read_text() != "old\n" and stat.S_IMODE(out.stat().st_mode) == 0o640


@pytest.mark.parametrize("name", ["=cmd|' /C calc'!A0", "+1+1", "-2+3", "@SUM(A1)", "\tx"])
def test_a_target_named_like_a_formula_is_written_as_text(name):
    """compensate's commands.csv: a spreadsheet must show the target's name, not run it (issue 30 class 9)."""
    import csv

    import numpy as np

    from armcal.export.compensation import compensate
    from armcal.kinematics.compiler import compile_robot
    from armcal.kinematics.transforms import pose_from_matrix
    from armcal.spec import load_spec

    loaded = load_spec(ROOT / "specs" / "puma560_dh.yaml")
    x, y, z, rz, ry, rx = pose_from_matrix(compile_robot(loaded.spec.robot.chain()).tool_poses(np.radians([[10, -40, 150, 5, 30, 20]]))[0])
    row = [name.replace('"', '""'), *(f"{v:.9g}" for v in (x / 10, y / 10, z / 10, *np.degrees([rx, ry, rz])))]  # cm, deg
    text, _, _, _ = compensate(loaded, None, "name,x,y,z,rx,ry,rz\n" + ",".join(f'"{c}"' for c in row) + "\n", "targets")
    written = next(csv.DictReader(text.splitlines()))["name"]
    assert written == "'" + name


def test_a_file_that_is_no_data_file_is_not_echoed(tmp_path):
    """A system file given as data (issue 30 class 2): its header is no column name, so the message names the column's
    position and length, never its text; a cell that is no value is described by its length too."""
    from conftest import copy_example

    secret = "root:x:0:0:armcal-secret-" + "z" * 30 + ":/root:/bin/bash"
    copy_example("hidden_harmonic", tmp_path)
    data = tmp_path / "calibration.csv"
    original = data.read_text()
    data.write_text(secret + "\ndaemon:x:1:1\n")
    done = armcal_cli("run", tmp_path / "spec.yaml", "--no-pdf")
    assert done.returncode == 1 and "armcal-secret" not in done.stdout + done.stderr, done.stderr
    assert "unknown column 1 (a header of" in done.stderr
    lines = original.splitlines()
    cells = lines[1].split(",")
    cells[2] = "=" + secret  # q1
    data.write_text("\n".join([lines[0], ",".join(cells), *lines[2:]]) + "\n")
    done = armcal_cli("run", tmp_path / "spec.yaml", "--no-pdf")
    assert done.returncode == 1 and "armcal-secret" not in done.stdout + done.stderr, done.stderr
    assert ":2:3: q1: not a number" in done.stderr


# -- issue 30 class 3: one command's outputs, links to nothing, modes under --force ---------------------------------


def test_a_dangling_link_at_out_is_kept_without_force_and_replaced_not_followed_with_it(tmp_path):
    """A link to nothing in a subfolder counts as an existing file: refused without --force; with it the link itself
    becomes the file and nothing is created where it pointed."""
    (tmp_path / "sub").mkdir()
    out = tmp_path / "sub" / "spec.yaml"
    out.symlink_to(tmp_path / "elsewhere" / "planted.yaml")
    refused = armcal_cli(*_writers(out)["new"][:-1])
    assert refused.returncode == 1 and "Traceback" not in refused.stderr, refused.stderr
    assert f"{out} is a link to" in refused.stderr and "does not exist" in refused.stderr and "--force" in refused.stderr
    assert out.is_symlink() and not (tmp_path / "elsewhere").exists()
    forced = armcal_cli(*_writers(out)["new"])
    assert forced.returncode == 0, forced.stderr
    assert not out.is_symlink() and out.is_file() and not (tmp_path / "elsewhere").exists()


def test_a_dangling_link_on_the_way_to_out_is_refused_with_force(tmp_path):
    (tmp_path / "gone").symlink_to(tmp_path / "nowhere")
    done = armcal_cli(*_writers(tmp_path / "gone" / "spec.yaml")["new"])
    assert done.returncode == 1 and "Traceback" not in done.stderr and done.stderr.count("\n") == 1, done.stderr
    assert f"{tmp_path / 'gone'} is a link to" in done.stderr and not (tmp_path / "nowhere").exists()


def test_the_writer_keeps_modes_under_any_umask_and_never_follows_a_dangling_link(tmp_path):
    from armcal.support.errors import UserError
    from armcal.support.fileio import distinct_outputs, refuse_replacing, write_bytes_atomic

    previous = os.umask(0)
    try:
        kept = tmp_path / "kept.csv"
        kept.write_text("old\n")
        kept.chmod(0o600)
        write_bytes_atomic(kept, b"new\n")
        fresh = tmp_path / "fresh.csv"
        write_bytes_atomic(fresh, b"new\n")
        assert (stat.S_IMODE(kept.stat().st_mode), stat.S_IMODE(fresh.stat().st_mode)) == (0o600, 0o666)  # umask 0: 0o666
    finally:
        os.umask(previous)
    link = tmp_path / "link.csv"
    link.symlink_to(tmp_path / "target.csv")
    with pytest.raises(UserError, match="does not exist"):
        refuse_replacing([link], [], force=False)
    refuse_replacing([link], [], force=True)
    write_bytes_atomic(link, b"x\n")
    assert not link.is_symlink() and not (tmp_path / "target.csv").exists()
    os.link(kept, tmp_path / "hard.csv")
    for pair in ([kept, tmp_path / "." / "kept.csv"], [kept, tmp_path / "hard.csv"], [tmp_path / "a.JSON", tmp_path / "a.json"]):
        with pytest.raises(UserError, match="are one file"):
            distinct_outputs(pair)
    distinct_outputs([tmp_path / "a.csv", tmp_path / "a.json"])


# -- hostile report 30, items 3 and 4: no output under /dev, /proc, /sys; an input by any name is never replaced -----


def _run_with_stdout_in(path, *args):
    """`python -m armcal ARGS` with standard output redirected to the regular file ``path`` (as `> path` does), so
    that /proc/self/fd/1 leads to a regular file."""
    with open(path, "w") as stdout:
        return subprocess.run([sys.executable, "-m", "armcal", *map(str, args)], stdout=stdout, stderr=subprocess.PIPE,
                              text=True, cwd=ROOT, timeout=300)


def test_no_output_is_written_under_dev_proc_or_sys_through_any_link(tmp_path):
    """A chain of links ending in /proc/self/fd/1 while standard output is a file, a linked folder leading into
    /proc or /sys: refused with --force, exit 1, one message, the links and the file behind them as they were."""
    captured = tmp_path / "captured.txt"
    chain = tmp_path / "spec.yaml"
    (tmp_path / "hop.yaml").symlink_to("/proc/self/fd/1")
    chain.symlink_to(tmp_path / "hop.yaml")
    (tmp_path / "proc_self").symlink_to("/proc/self")
    (tmp_path / "sys_kernel").symlink_to("/sys/kernel")
    cases = {
        chain: ("/proc", "new", "--robot", "ur5e", "--device", "tracker", "--out", chain, "--force"),
        tmp_path / "proc_self" / "x.urdf": ("/proc", "export", ROOT / "specs" / "puma560_dh.yaml", "--format", "urdf",
                                            "--out", tmp_path / "proc_self" / "x.urdf", "--force"),
        tmp_path / "sys_kernel" / "spec.yaml": ("/sys", *_writers(tmp_path / "sys_kernel" / "spec.yaml")["import-urdf"]),
    }
    for out, (root, *args) in cases.items():
        done = _run_with_stdout_in(captured, *args)
        assert done.returncode == 1 and "Traceback" not in done.stderr and done.stderr.count("\n") == 1, done.stderr
        assert f"{out} lies under {root}" in done.stderr and "--force or not" in done.stderr, done.stderr
        assert captured.read_text() == "", "nothing is written to the file standard output leads to"
    assert os.readlink(chain) == str(tmp_path / "hop.yaml") and os.readlink(tmp_path / "hop.yaml") == "/proc/self/fd/1"
    assert os.readlink("/dev/stdout") == "/proc/self/fd/1"


def test_a_hard_link_to_an_input_is_refused_like_the_input(tmp_path):
    """import-urdf --out a hard link of its URDF, --force: the same device and inode is the input itself."""
    urdf = tmp_path / "robot.urdf"
    urdf.write_bytes(URDF.read_bytes())
    out = tmp_path / "spec.yaml"
    os.link(urdf, out)
    done = armcal_cli("import-urdf", urdf, "--base", "base_link", "--tip", "tool0", "--out", out, "--force")
    assert done.returncode == 1 and "Traceback" not in done.stderr and done.stderr.count("\n") == 1, done.stderr
    assert f"{out} is an input of this command" in done.stderr and "hard link" in done.stderr
    assert out.read_bytes() == URDF.read_bytes() and os.stat(out).st_ino == os.stat(urdf).st_ino and os.stat(urdf).st_nlink == 2


@pytest.mark.parametrize("command", [
    ("export", "examples/goswami_ballbar/spec.yaml", "--format", "json"),
    ("new", "puma560", "--device", "tracker"),
    ("import-urdf", "tests/data/urdf/missing.urdf", "--base", "a", "--tip", "b"),
], ids=["export", "new", "import-urdf"])
def test_an_output_name_ending_in_a_slash_names_a_folder_and_nothing_is_written(tmp_path, command):
    """`--out name/` is a folder's name: refused before anything runs (pathlib would drop the slash and write a file)."""
    out = tmp_path / "nodir"
    done = armcal_process(*command, "--out", f"{out}/")
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert "ends in '/', which names a folder" in done.stderr and not out.exists()
