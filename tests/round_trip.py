"""The calibrated spec reproduces the fit: its model predicts every reading as the fitted one, a run of it starts there."""

from contextlib import contextmanager

import numpy as np
import pytest
from ruamel.yaml import YAML

from armcal.commands import run as pipeline
from armcal.dataio.reader import read_measurements
from armcal.diagnose.calibration import calibration_problem, identify_and_diagnose
from armcal.kinematics.compiler import compile_robot
from armcal.commands.run import fitted_device, run
from armcal.spec import load_spec


def _stages(spec_path):
    """What `armcal run` builds before it fits: the spec, the compiled models and the prepared data."""
    spec = load_spec(spec_path).spec
    folder = spec_path.parent
    kinematics = compile_robot(spec.robot.chain())
    raw = read_measurements(folder / spec.data.calibration, spec)
    device = fitted_device(spec, raw)
    validation = device.prepare(read_measurements(folder / spec.data.validation, spec)) if spec.data.validation else None
    return spec, kinematics, device, raw, validation


def fitted_residuals(spec_path) -> np.ndarray:
    """Weighted residuals of the calibration data under the model `armcal run` fits (diagnosis included)."""
    spec, kinematics, device, raw, validation = _stages(spec_path)
    return weighted_residuals(identify_and_diagnose(spec, kinematics, device, raw, device.prepare(raw), validation))


def weighted_residuals(calibrated) -> np.ndarray:
    """Weighted residuals of the calibration data under a fitted model (what identify_and_diagnose returns)."""
    return calibrated.problem.evaluate(calibrated.identified.theta)[0]


@contextmanager
def recorded_fits():
    """A list that gets each fitted model (identify_and_diagnose's result) `armcal run` makes inside the block:
    the run's own fit, without fitting it a second time."""
    fits = []

    def recording(*args, **kwargs):
        fits.append(identify_and_diagnose(*args, **kwargs))
        return fits[-1]

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(pipeline, "identify_and_diagnose", recording)
        yield fits


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


def round_trip(spec_path, out, first=None, fitted=None):
    """calibrated.yaml predicts every reading as the fitted model does (residuals in noise sigmas, to 1e-6),
    and a run of it with the diagnosis off starts at the fitted RMS and stays there (``first``: the results of
    the run of ``spec_path`` into ``out`` when it has been made already, ``fitted`` its fitted model (recorded_fits);
    without it the model is fitted again)."""
    if first is None:
        with recorded_fits() as fits:
            first = run(spec_path, out, pdf=False).results
        fitted = fits[-1]
    fitted_values = weighted_residuals(fitted) if fitted is not None else fitted_residuals(spec_path)
    calibrated = out / "calibrated.yaml"
    assert np.max(np.abs(starting_residuals(calibrated) - fitted_values)) < 1e-6
    _without_diagnosis(calibrated, out / "rerun.yaml")
    second = run(out / "rerun.yaml", out / "rerun", pdf=False).results
    rms = first.residuals.calibration.after.rms
    assert second.residuals.calibration.before.rms == pytest.approx(rms, rel=1e-6)
    assert second.status == "converged" and second.residuals.calibration.after.rms <= rms * (1 + 1e-9)
    return first, second
