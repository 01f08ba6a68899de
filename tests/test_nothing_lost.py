"""Nothing lost: earlier artifacts survive a failing run, certificates need --force, re-runs are reproducible."""

import json

import pytest
from conftest import ROOT, armcal_cli, copy_example

from armcal.commands.run import run

EXAMPLE = ROOT / "examples" / "theodolite"


@pytest.fixture()
def workspace(tmp_path):
    return copy_example("theodolite", tmp_path)


def _snapshot(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def test_a_run_failing_at_the_certificate_leaves_the_earlier_artifacts_intact(workspace):
    out = workspace / "out"
    run(workspace / "spec.yaml", out)
    before = _snapshot(out)
    templates = workspace / "templates"
    templates.mkdir()
    (templates / "certificate.html.j2").write_text("{{ no_such_value }}")  # fails the strict render
    text = (workspace / "spec.yaml").read_text().replace("simulate:", "report: {template: templates}\nsimulate:")
    (workspace / "spec.yaml").write_text(text)
    result = armcal_cli("run", workspace / "spec.yaml", "--out", out, "--force")
    assert result.returncode != 0
    assert _snapshot(out) == before  # results.json, plots, certificate: all as they were
    assert not list(out.glob(".*.tmp"))


def test_an_existing_certificate_is_not_replaced_without_force(workspace):
    out = workspace / "out"
    run(workspace / "spec.yaml", out)
    before = _snapshot(out)
    result = armcal_cli("run", workspace / "spec.yaml", "--out", out)
    assert result.returncode == 1 and "use --force to replace the certificate" in result.stderr
    assert "Traceback" not in result.stderr
    assert _snapshot(out) == before


def test_rerunning_gives_the_same_results_apart_from_the_timestamp(workspace):
    first = json.loads((run(workspace / "spec.yaml", workspace / "a").out_dir / "results.json").read_text())
    second = json.loads((run(workspace / "spec.yaml", workspace / "b").out_dir / "results.json").read_text())
    for data in (first, second):
        data.pop("created")
    assert json.dumps(first, sort_keys=True) == json.dumps(second, sort_keys=True)
