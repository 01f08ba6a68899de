"""Implausible identified values are said (issue 29 item 3): oracle, a spec whose nominal length is 30 mm from the
truth that simulated its data (the fit moves it back; the deviation is known), and direct cases of the rule."""

from pathlib import Path

import numpy as np
import pytest
from conftest import armcal_cli, copy_example

from armcal.kinematics.params import parameter_set
from armcal.results.plausibility import plausibility
from armcal.spec import load_spec

ROOT = Path(__file__).resolve().parents[2]


def _spec(tmp_path, old, new):
    copy_example("hidden_harmonic", tmp_path)
    spec = tmp_path / "spec.yaml"
    text = spec.read_text()
    assert old in text
    spec.write_text(text.replace(old, new, 1))
    return spec


def test_a_nominal_value_30_mm_off_is_said_on_the_terminal_in_results_and_on_the_certificate(tmp_path):
    import json

    spec = _spec(tmp_path, "x: 43.18, y: 0, z: 14.909", "x: 46.18, y: 0, z: 14.909")  # cm: the truth is near 43.18
    done = armcal_cli("run", spec, "--no-pdf")
    assert done.returncode == 0, done.stderr
    results = json.loads((tmp_path / "out" / "spec" / "results.json").read_text())
    p = results["plausibility"]
    assert (p["length"], p["length_unit"], p["angle"], p["angle_unit"], p["from_spec"]) == (1.0, "cm", 2.0, "deg", False)
    flagged = {v["name"]: v for v in p["implausible"]}
    assert "L3.x" in flagged and flagged["L3.x"]["deviation"] == pytest.approx(-3.0, abs=0.05)
    assert flagged["L3.x"]["why"] == "nominal" and flagged["L3.x"]["std"] < 0.05  # the data put it there
    assert results["status"] == "converged"  # the contract's status; the words add the finding
    assert "converged; implausible values" in done.stdout and "set robot.tolerance" in done.stdout
    assert "L3.x: " in done.stdout and "check the nominal value" in done.stdout
    html = (tmp_path / "out" / "spec" / "certificate.html").read_text()
    assert "converged; implausible values" in html and "L3.x = " in html and "default tolerance, the spec gives none" in html


def test_a_tolerance_from_the_spec_is_used_and_said():
    loaded = load_spec(ROOT / "examples" / "hidden_harmonic" / "spec.yaml")
    spec = loaded.spec.model_copy(update={"robot": loaded.spec.robot.model_copy(update={"tolerance": None})})
    entries = parameter_set(spec.robot.chain()).entries
    names = [e.name for e in entries]
    values = np.array([e.nominal for e in entries])
    values[names.index("L3.x")] += 30.0  # mm
    values[names.index("L4.gamma")] += np.radians(358.5)  # 1.5 deg the short way round: plausible
    values[names.index("j2.theta0")] += np.radians(2.5)
    values[names.index("j3.k")] += 0.02  # an encoder scale 2 % off: beyond the default 0.01
    values[names.index("j4.k")] -= 0.005  # within it
    std = np.full(len(values), np.nan)
    found = plausibility(spec, entries, values, std, set(names))
    flagged = {v["name"]: v for v in found["implausible"]}
    assert set(flagged) == {"L3.x", "j2.theta0", "j3.k"}
    assert (flagged["j3.k"]["deviation"], flagged["j3.k"]["tolerance"], flagged["j3.k"]["unit"]) == pytest.approx((0.02, 0.01, "1"))
    assert found["scale"] == 0.01
    assert flagged["j2.theta0"]["deviation"] == pytest.approx(2.5) and flagged["j2.theta0"]["std"] is None
    assert flagged["j2.theta0"]["why"] == "undetermined"  # no std: nothing says the data determined it
    std[names.index("L3.x")] = 10.0  # mm: a third of the deviation, the tolerance's size: a flat direction's doing
    assert {v["name"]: v["why"] for v in plausibility(spec, entries, values, std, set(names))["implausible"]}["L3.x"] == "undetermined"
    std[names.index("L3.x")] = 1.0  # 30 stds
    assert {v["name"]: v["why"] for v in plausibility(spec, entries, values, std, set(names))["implausible"]}["L3.x"] == "nominal"
    assert flagged["L3.x"]["deviation"] == pytest.approx(3.0) and flagged["L3.x"]["tolerance"] == pytest.approx(1.0)  # cm
    assert plausibility(spec, entries, values, std, set(names) - {"L3.x", "j2.theta0", "j3.k"})["implausible"] == []  # held: not judged
    from armcal.spec_parts.robot import Tolerance

    wide = spec.model_copy(update={"robot": spec.robot.model_copy(update={"tolerance": Tolerance(length="40 mm", angle="3 deg", scale=0.03)})})
    judged = plausibility(wide, parameter_set(wide.robot.chain()).entries, values, std, set(names))
    assert judged["implausible"] == [] and judged["from_spec"] and judged["length"] == pytest.approx(4.0) and judged["scale"] == 0.03  # cm
