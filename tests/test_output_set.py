"""The output folder is one unit (one run's set or the previous one), nothing existing is replaced without
--force, an input never is, concurrent and killed runs leave no mix, and a fleet reports every robot."""

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import pytest
from conftest import EXAMPLE_DATA, HANG, ROOT, armcal_cli, copy_example

from armcal.support.output_set import MANIFEST
from armcal.commands.run import run

EXAMPLE = ROOT / "examples" / "theodolite"


@pytest.fixture()
def workspace(tmp_path):
    return copy_example("theodolite", tmp_path, (*EXAMPLE_DATA, "truth.json"))


armcal = armcal_cli


def other_input(folder) -> None:
    """Other input bytes, the same calibration: another run."""
    with open(folder / "spec.yaml", "a") as spec:
        spec.write("# edited\n")


def one_complete_set(folder) -> str:
    """The folder's files are exactly those its manifest lists, each as written: returns the run id."""
    manifest = json.loads((folder / MANIFEST).read_text())
    names = {p.name for p in folder.iterdir()} - {MANIFEST}
    assert names == set(manifest["files"]), names ^ set(manifest["files"])
    for name, digest in manifest["files"].items():
        assert hashlib.sha256((folder / name).read_bytes()).hexdigest() == digest, name
    return manifest["run_id"]


def test_a_forced_run_without_pdf_leaves_no_stale_certificate(workspace):
    out = workspace / "out"
    assert armcal("run", workspace / "spec.yaml", "--out", out).returncode == 0
    assert (out / "certificate.pdf").exists()
    assert armcal("run", workspace / "spec.yaml", "--out", out, "--no-pdf", "--force").returncode == 0
    assert not (out / "certificate.pdf").exists()
    one_complete_set(out)


def test_every_artifact_carries_the_runs_id(workspace):
    out = workspace / "out"
    assert armcal("run", workspace / "spec.yaml", "--out", out, "--no-pdf").returncode == 0
    identifier = one_complete_set(out)
    assert json.loads((out / "results.json").read_text())["run_id"] == identifier
    assert f"run {identifier}" in (out / "calibrated.yaml").read_text().splitlines()[0]
    for svg in out.glob("*.svg"):
        assert f"armcal run {identifier}" in svg.read_text()
    assert f'<meta name="armcal-run" content="{identifier}">' in (out / "certificate.html").read_text()
    other_input(workspace)
    assert armcal("run", workspace / "spec.yaml", "--out", out, "--no-pdf", "--force").returncode == 0
    assert one_complete_set(out) != identifier


def test_report_refuses_a_mixed_set_and_asks_before_replacing(workspace):
    first, second = workspace / "first", workspace / "second"
    assert armcal("run", workspace / "spec.yaml", "--out", first, "--no-pdf").returncode == 0
    other_input(workspace)
    assert armcal("run", workspace / "spec.yaml", "--out", second, "--no-pdf").returncode == 0
    unforced = armcal("report", first / "results.json", "--no-pdf")
    assert unforced.returncode == 1 and "use --force" in unforced.stderr and "Traceback" not in unforced.stderr
    assert armcal("report", first / "results.json", "--no-pdf", "--force").returncode == 0
    one_complete_set(first)
    plot = next(first.glob("*.svg"))
    shutil.copy(second / plot.name, plot)  # a plot of the other run
    mixed = armcal("report", first / "results.json", "--no-pdf", "--force")
    assert mixed.returncode == 1 and "mixes two runs" in mixed.stderr and "Traceback" not in mixed.stderr


@pytest.mark.parametrize("where", ["spec folder", "the input's own output folder"])
def test_an_input_is_never_replaced_even_with_force(workspace, where):
    if where == "spec folder":
        spec, out = workspace / "spec.yaml", workspace
    else:
        assert armcal("run", workspace / "spec.yaml", "--out", workspace / "out", "--no-pdf").returncode == 0
        spec, out = workspace / "out" / "calibrated.yaml", workspace / "out"
    before = spec.read_bytes()
    result = armcal("run", spec, "--out", out, "--force", "--no-pdf")
    assert result.returncode == 1 and "an input of this run" in result.stderr, result.stderr
    assert spec.read_bytes() == before


def test_a_folder_of_other_files_is_not_taken_over(workspace):
    out = workspace / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    result = armcal("run", workspace / "spec.yaml", "--out", out, "--force", "--no-pdf")
    assert result.returncode == 1 and "not an armcal output set" in result.stderr
    assert (out / "notes.txt").read_text() == "mine"


def test_simulate_and_import_replace_nothing_without_force(workspace):
    before = (workspace / "calibration.csv").read_bytes()
    refused = armcal("simulate", workspace / "spec.yaml", "--out", workspace)
    assert refused.returncode == 1 and "use --force" in refused.stderr
    assert (workspace / "calibration.csv").read_bytes() == before
    assert armcal("simulate", workspace / "spec.yaml", "--out", workspace, "--force").returncode == 0
    series = workspace / "series.csv"
    series.write_text("x")
    for target in (workspace / "spec.yaml", series):  # its own inputs, --force or not
        result = armcal("import-ipa", workspace / "spec.yaml", series, "--out", target, "--force")
        assert result.returncode == 1 and "is an input of this command" in result.stderr
    assert series.read_text() == "x"
    existing = armcal("import-ipa", workspace / "spec.yaml", series, "--out", workspace / "calibration.csv")
    assert existing.returncode == 1 and "use --force" in existing.stderr


def test_two_concurrent_runs_into_one_folder(workspace):
    """While one run holds the folder (its lock taken here, as a run takes it), another stops at once with a clear
    message and writes nothing; once it is free, a run writes its set. No start-up race decides who comes first."""
    from armcal.support.output_set import _locked

    out = workspace / "out"
    with _locked(out):
        blocked = armcal("run", workspace / "spec.yaml", "--out", out, "--no-pdf")
    assert blocked.returncode == 1 and "another armcal run is writing" in blocked.stderr, blocked.stderr
    assert not out.exists() or not any(out.iterdir())
    assert armcal("run", workspace / "spec.yaml", "--out", out, "--no-pdf").returncode == 0
    one_complete_set(out)


def _kill_when(job: subprocess.Popen, moment) -> None:
    """SIGKILL ``job`` as soon as ``moment()`` holds (polled every 5 ms), or once it has ended; HANG at most."""
    deadline = time.perf_counter() + HANG
    while job.poll() is None and time.perf_counter() < deadline:
        try:
            if moment():
                break
        except (OSError, ValueError, AssertionError):  # a set being exchanged under the poll: not yet
            pass
        time.sleep(0.005)
    job.send_signal(signal.SIGKILL)
    job.wait()


def test_a_run_killed_at_any_moment_leaves_one_complete_set(workspace):
    """The killed runs are `armcal run` processes; the runs before and after them are made in this process
    (pipeline.run, what `armcal run` calls: the same output set, lock and staging, without importing armcal anew)."""
    out = workspace / "out"
    run(workspace / "spec.yaml", out, pdf=False)
    one_complete_set(out)
    other_input(workspace)
    staging = lambda: [p for p in workspace.glob(".out.new-*") if p.is_dir() and p not in left]  # noqa: E731 - this run's
    moments = (  # by what the run has done, not by a clock: a loaded machine reaches each later, not never
        lambda: (workspace / ".out.lock").exists(),  # started, the folder locked (a killed run leaves the file: first)
        lambda: bool(staging()),  # writing its set beside the folder
        lambda: any(len(list(p.iterdir())) >= 3 for p in staging()),  # half of it written
        lambda: one_complete_set(out) != before,  # its set just exchanged in
    )
    for moment in moments:
        before, left = one_complete_set(out), set(workspace.glob(".out.new-*"))  # what killed runs left stays out
        job = subprocess.Popen([sys.executable, "-m", "armcal", "run", str(workspace / "spec.yaml"), "--out", str(out), "--no-pdf", "--force"],
                               cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        _kill_when(job, moment)
        assert one_complete_set(out)  # the previous set or the new one, whole
        other_input(workspace)
    run(workspace / "spec.yaml", out, force=True, pdf=False)  # raises when a killed run left it unable to write
    one_complete_set(out)
    assert not [p for p in workspace.iterdir() if p.name.startswith(".out.")]  # no half-written set, no lock left


@pytest.mark.skipif(os.geteuid() != 0 or not shutil.which("mount"), reason="needs root to mount a small tmpfs")
def test_a_full_disk_keeps_the_previous_set(workspace, tmp_path_factory):
    disk = tmp_path_factory.mktemp("disk")
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(disk)], capture_output=True).returncode != 0:
        pytest.skip("mounting a tmpfs is not allowed here")
    try:
        out = disk / "out"
        assert armcal("run", workspace / "spec.yaml", "--out", out, "--no-pdf").returncode == 0
        previous = one_complete_set(out)
        with open(disk / "filler", "wb", buffering=0) as filler:  # fill what is left
            try:
                while True:
                    filler.write(b"\0" * 4096)
            except OSError:
                pass
        result = armcal("run", workspace / "spec.yaml", "--out", out, "--force")
        assert result.returncode == 1 and "Traceback" not in result.stderr, result.stderr
        assert "previous set is unchanged" in result.stderr
        assert one_complete_set(out) == previous
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)


def test_a_fleet_reports_every_robot_even_after_an_internal_error(workspace, monkeypatch):
    import armcal.commands.batch as fleet

    other = workspace / "other"
    other.mkdir()
    copy_example("theodolite", other)
    real_run = fleet.run

    def failing(spec, *args):
        if spec.parent == other:
            raise ZeroDivisionError("a bug")
        return real_run(spec, *args)

    monkeypatch.setattr(fleet, "run", failing)
    outcomes = fleet.batch([workspace / "spec.yaml", other / "spec.yaml"], workspace / "fleet", pdf=False, workers=1)
    statuses = [o["status"] for o in outcomes]
    assert statuses == ["converged", "internal_error"]
    assert "ZeroDivisionError: a bug" in outcomes[1]["log"] and fleet.exit_code(outcomes) == fleet.INTERNAL
    files = fleet.summary_files(workspace / "fleet")
    fleet.write_summary(files, outcomes, "table")
    assert json.loads(files[0].read_text())["outcomes"][1]["status"] == "internal_error"


def test_a_blocked_or_read_only_output_folder_is_a_user_error(workspace, tmp_path_factory):
    (workspace / "blocker").write_text("a file where a folder should be")
    blocked = armcal("run", workspace / "spec.yaml", "--out", workspace / "blocker" / "out", "--no-pdf")
    assert blocked.returncode == 1 and "is a file; the output needs a folder there" in blocked.stderr and "Traceback" not in blocked.stderr
    if os.geteuid() != 0:
        pytest.skip("a read-only mount needs root (permission bits do not stop root)")
    disk = tmp_path_factory.mktemp("readonly")
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=1m", "tmpfs", str(disk)], capture_output=True).returncode != 0:
        pytest.skip("mounting a tmpfs is not allowed here")
    try:
        result = armcal("run", workspace / "spec.yaml", "--out", disk / "out", "--no-pdf")
        assert result.returncode == 1 and "Traceback" not in result.stderr and "Read-only file system" in result.stderr, result.stderr
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)


def test_a_replaced_set_keeps_its_files_and_folders_modes(tmp_path):
    """--force replaces the content, not who may read it (issue 30 class 3), whatever the umask."""
    import stat

    from armcal.support.errors import UserError
    from armcal.support.output_set import output_set

    spec = tmp_path / "spec.yaml"
    spec.write_text("x\n")
    folder = tmp_path / "out"
    with output_set(folder, [spec], force=False) as publish:
        publish({"results.json": "{}\n", "plot.svg": "<svg/>\n"}, "a")
    (folder / "results.json").chmod(0o600)
    folder.chmod(0o750)
    previous = os.umask(0)
    try:
        with pytest.raises(UserError, match="use --force"):
            with output_set(folder, [spec], force=False):
                pass
        with output_set(folder, [spec], force=True) as publish:
            publish({"results.json": "{\"b\": 1}\n", "plot.svg": "<svg/>\n", "new.svg": "<svg/>\n"}, "b")
    finally:
        os.umask(previous)
    modes = {p.name: stat.S_IMODE(p.stat().st_mode) for p in folder.iterdir()}
    assert (folder / "results.json").read_text() == '{"b": 1}\n'
    assert stat.S_IMODE(folder.stat().st_mode) == 0o750 and modes["results.json"] == 0o600
    assert modes["new.svg"] == 0o666  # a new file: the usual mode less the umask (0 here)


def test_a_dangling_link_as_the_output_folder_is_refused_with_force(tmp_path):
    from armcal.support.errors import UserError
    from armcal.support.output_set import output_set

    (tmp_path / "out").symlink_to(tmp_path / "nowhere")
    with pytest.raises(UserError, match="is a link to .*which does not exist"):
        with output_set(tmp_path / "out", [], force=True):
            pass
    assert (tmp_path / "out").is_symlink() and not (tmp_path / "nowhere").exists()
