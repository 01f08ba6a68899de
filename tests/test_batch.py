"""Fleets: `armcal batch` on the local process pool and on a Dask cluster (loopback) give the same results."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

from armcal.batch import batch, exit_code
from armcal.montecarlo import montecarlo

FLEET = [ROOT / "examples" / "goswami_ballbar" / "spec.yaml", ROOT / "examples" / "theodolite" / "spec.yaml"]


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None) as local:
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
    assert outcomes[0]["status"] == "converged" and (tmp_path / "out" / "spec" / "results.json").exists()
    assert outcomes[1]["status"] == "error" and "broken.yaml" in outcomes[1]["error"]
    assert exit_code(outcomes) == 1


def test_batch_command_line(tmp_path):
    command = [sys.executable, "-m", "armcal", "batch", *map(str, FLEET), "--out", str(tmp_path), "--no-pdf", "--workers", "2"]
    result = subprocess.run(command, capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    assert "2 specs: 2 converged" in result.stdout
    assert {p.name for p in tmp_path.iterdir()} == {"goswami_ballbar-spec", "theodolite-spec", "fleet.json", "fleet.txt"}  # both specs are spec.yaml; the fleet summary


def test_an_unreachable_scheduler_is_a_user_error(tmp_path):
    command = [sys.executable, "-m", "armcal", "batch", str(FLEET[0]), "--out", str(tmp_path), "--scheduler", "tcp://127.0.0.1:9"]
    result = subprocess.run(command, capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 1 and "cannot reach the Dask scheduler" in result.stderr and "Traceback" not in result.stderr


def test_two_jobs_never_share_an_output_folder(tmp_path):
    from armcal.errors import UserError

    with pytest.raises(UserError, match="two specs would write to"):
        batch([FLEET[0], Path(str(FLEET[0]).replace("/examples/", "/examples/../examples/"))], pdf=False, workers=1)
