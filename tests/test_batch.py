"""Fleets: `armcal batch` on the local process pool and on a Dask cluster (loopback) give the same results."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT, SPECS, armcal_cli

from armcal.commands.batch import batch, exit_code, jobs
from armcal.commands.terminal import batch_summary
from armcal.commands.montecarlo import montecarlo

FLEET = [ROOT / "examples" / "goswami_ballbar" / "spec.yaml", ROOT / "examples" / "theodolite" / "spec.yaml"]


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=":0") as local:
        yield local


def _results(folder):
    data = json.loads((folder / "results.json").read_text())
    data.pop("created")
    return data


def test_batch_on_dask_equals_the_process_pool(tmp_path, cluster):
    pooled = batch(FLEET, tmp_path / "pool", pdf=False, workers=2)
    on_dask = batch(FLEET, tmp_path / "dask", pdf=False, scheduler=cluster.scheduler_address)
    assert [o["status"] for o in pooled] == [o["status"] for o in on_dask] == ["converged", "converged"]
    for a, b in zip(pooled, on_dask):
        assert _results(Path(a["out_dir"])) == _results(Path(b["out_dir"]))
        assert (Path(b["out_dir"]) / "certificate.html").exists()


def test_montecarlo_on_dask_equals_the_process_pool(tmp_path, cluster):
    sonic = ROOT / "examples" / "puma560_sonic" / "spec.yaml"
    pooled = montecarlo(sonic, 4, out_dir=tmp_path / "pool", workers=2).summary
    on_dask = montecarlo(sonic, 4, out_dir=tmp_path / "dask", scheduler=cluster.scheduler_address).summary
    assert pooled["points"] == on_dask["points"]


def test_a_bad_spec_in_a_fleet_is_reported_and_the_others_go_on(tmp_path):
    broken = tmp_path / "broken.yaml"
    broken.write_text("armcal: 1\nrobot: {name: x\n")
    outcomes = batch([FLEET[0], broken], tmp_path / "out", pdf=False, workers=1)
    assert outcomes[0]["status"] == "converged" and (tmp_path / "out" / "goswami_ballbar-spec" / "results.json").exists()
    assert outcomes[1]["status"] == "error" and "broken.yaml" in outcomes[1]["error"]
    assert exit_code(outcomes) == 1


def test_batch_command_line(tmp_path):
    result = armcal_cli("batch", *FLEET, "--out", tmp_path, "--no-pdf", "--workers", "2")
    assert result.returncode == 0, result.stderr
    assert "2 specs: 2 converged" in result.stdout
    assert {p.name for p in tmp_path.iterdir()} == {"goswami_ballbar-spec", "theodolite-spec", "fleet.json", "fleet.txt"}  # both specs are spec.yaml; the fleet summary
    table = (tmp_path / "fleet.txt").read_text()
    assert table.startswith("2 specs: 2 converged") and table in result.stdout
    fleet = json.loads((tmp_path / "fleet.json").read_text())
    assert fleet["specs"] == 2 and fleet["exit_code"] == 0
    assert [o["out_dir"] for o in fleet["outcomes"]] == [str(tmp_path / "goswami_ballbar-spec"), str(tmp_path / "theodolite-spec")]


def test_a_folder_name_depends_only_on_its_own_spec(tmp_path):
    alone = jobs([FLEET[0]], tmp_path, False, False)
    with_others = jobs([FLEET[1], SPECS / "puma560_dh.yaml", FLEET[0]], tmp_path, False, False)
    assert alone[0].out_dir == with_others[2].out_dir == (tmp_path / "goswami_ballbar-spec").resolve()
    assert with_others[1].out_dir == (tmp_path / "specs-puma560_dh").resolve()


def _outcome(spec: str, unexplained: bool) -> dict:
    """An outcome as run_job returns it for a converged spec."""
    numbers = {"unit": "mm", "calibration_rms": [1.0, 0.1], "validation_rms": None, "noise_verdict": "consistent"}
    return {"spec": spec, "status": "converged", "exit_code": 0, "robot": "arm (SN-1)", **numbers, "unexplained": unexplained, "out_dir": f"out/{spec}"}


def test_the_fleet_summary_counts_in_words_and_flags_unexplained_residuals():
    one = batch_summary([_outcome("a.yaml", False)]).splitlines()
    assert one[0] == "1 spec: 1 converged" and "unexplained" not in one[1]
    two = batch_summary([_outcome("a.yaml", False), _outcome("b.yaml", True)]).splitlines()
    assert two[0] == "2 specs: 2 converged, 1 with residuals unexplained"
    assert "unexplained" not in two[1] and two[2].startswith("  b.yaml: arm (SN-1) converged, residuals unexplained, ")


def test_an_unreachable_scheduler_is_a_user_error(tmp_path):
    command = [sys.executable, "-m", "armcal", "batch", str(FLEET[0]), "--out", str(tmp_path), "--scheduler", "tcp://127.0.0.1:9"]
    result = subprocess.run(command, capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 1 and "cannot reach the Dask scheduler" in result.stderr and "Traceback" not in result.stderr


def test_two_jobs_never_share_an_output_folder(tmp_path):
    from armcal.support.errors import UserError

    with pytest.raises(UserError, match="two specs would write to"):
        batch([FLEET[0], Path(str(FLEET[0]).replace("/examples/", "/examples/../examples/"))], pdf=False, workers=1)


@pytest.mark.parametrize("kind, why", [("fifo", "it is not a regular file"), ("folder", "it is a folder"), ("missing", "there is no such file")])
def test_a_spec_that_is_no_file_says_what_it_is(tmp_path, kind, why):
    """batch names what stands where a spec belongs (issue 30 class 10: a FIFO or a folder was 'no such spec file')."""
    import os

    spec = tmp_path / "spec.yaml"
    if kind == "fifo":
        os.mkfifo(spec)
    elif kind == "folder":
        spec.mkdir()
    done = armcal_cli("batch", spec, "--out", tmp_path / "fleet", "--no-pdf")
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert f"{spec}: cannot read the spec file: {why}" in done.stderr, done.stderr
