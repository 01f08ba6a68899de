"""The calibrated spec reproduces the fit: its model predicts every reading as the fitted one, a run of it starts there."""

import numpy as np
import pytest
from ruamel.yaml import YAML

from armcal.dataio.reader import read_measurements
from armcal.diagnose.calibration import calibration_problem, identify_and_diagnose
from armcal.kinematics.compiler import compile_robot
from armcal.pipeline import fitted_device, run
from armcal.spec import load_spec


def _stages(spec_path):
    """What `armcal run` builds before it fits: the spec, the compiled models and the prepared data."""
    spec = load_spec(spec_path).spec
    folder = spec_path.parent
    kinematics = compile_robot(spec.robot)
    raw = read_measurements(folder / spec.data.calibration, spec)
    device = fitted_device(spec, raw)
    validation = device.prepare(read_measurements(folder / spec.data.validation, spec)) if spec.data.validation else None
    return spec, kinematics, device, raw, validation


def fitted_residuals(spec_path) -> np.ndarray:
    """Weighted residuals of the calibration data under the model `armcal run` fits (diagnosis included)."""
    spec, kinematics, device, raw, validation = _stages(spec_path)
    calibrated = identify_and_diagnose(spec, kinematics, device, raw, device.prepare(raw), validation)
    return calibrated.problem.evaluate(calibrated.identified.theta)[0]


def starting_residuals(spec_path) -> np.ndarray:
    """Weighted residuals of the calibration data where a run of the spec starts (its values, its effects)."""
    spec, kinematics, device, raw, _ = _stages(spec_path)
    problem, start = calibration_problem(spec, kinematics, device, device.prepare(raw))
    return problem.evaluate(start)[0]


def _without_diagnosis(source, target) -> None:
    yaml = YAML(typ="rt")
    root = yaml.load(source.read_text())
    root["diagnose"] = {"enabled": False}
    with open(target, "w") as handle:
        yaml.dump(root, handle)


def round_trip(spec_path, out, first=None):
    """calibrated.yaml predicts every reading as the fitted model does (residuals in noise sigmas, to 1e-6),
    and a run of it with the diagnosis off starts at the fitted RMS and stays there (``first``: the results of
    the run of ``spec_path`` into ``out`` when it has been made already)."""
    first = first or run(spec_path, out, pdf=False).results
    calibrated = out / "calibrated.yaml"
    assert np.max(np.abs(starting_residuals(calibrated) - fitted_residuals(spec_path))) < 1e-6
    _without_diagnosis(calibrated, out / "rerun.yaml")
    second = run(out / "rerun.yaml", out / "rerun", pdf=False).results
    rms = first.residuals.calibration.after.rms
    assert second.residuals.calibration.before.rms == pytest.approx(rms, rel=1e-6)
    assert second.status == "converged" and second.residuals.calibration.after.rms <= rms * (1 + 1e-9)
    return first, second
