"""Every good fit converges: 100 simulated campaigns with one hidden effect each (issue 13).

The full sweep (25 campaigns per robot and device) is a slow study (`pytest -m slow`);
the default run fits the first 4 of each (DEFAULT), the same campaigns with the same seeds.

The campaigns come from tests/independent_sim.py, a simulator written from the docs
alone (numpy, no armcal code): a plain-dh PUMA 560 (axes 2-3 parallel) and a UR-like
arm (axes 2-4 parallel), each with a laser tracker and with a ball-bar; the true
robots have manufacturing errors, tilts between the parallel axes, and one hidden
effect of 2-5 noise sigmas. armcal fits and diagnoses each one as `armcal run` does.
Oracle for the fit: scipy's least_squares on the same free set from the same start
reaches the same cost (to 1e-6 relative); held parameters never move; the
calibrated.yaml written from the fit predicts every reading as the fit does.

The ball-bar campaigns run with ARMCAL_COMPILE=off (CasADi's virtual machine, as tests/test_zoo.py):
each candidate effect is a problem of another structure, whose C (0.5-1 MB) gcc compiles in 4-9 s on
a cold cache, more than the virtual machine spends evaluating it here; what is compiled and cached is
tested in tests/identify/test_first_run.py and tests/test_process_safety.py.
"""

import math

import numpy as np
import pytest
import scipy.optimize
from independent_sim import write_campaign
from round_trip import starting_residuals

from armcal.dataio.reader import read_measurements
from armcal.devices import device_model
from armcal.diagnose.calibration import identify_and_diagnose
from armcal.evaluate.run_figures import run_figures
from armcal.results.build import build_results
from armcal.kinematics.compiler import compile_robot
from armcal.results.calibrated import calibrated_text
from armcal.results.campaign_block import campaign
from armcal.spec import load_spec

PER_PAIR = 25  # campaigns per robot and device in the full study
DEFAULT = 4  # of them in the default suite: each ball-bar campaign costs about 12 s of its 10 minutes
MISSED, MISORDERED = 2, 5  # of PER_PAIR campaigns: hidden effect not found; found without its harmonic's order
EFFECTS = {"tracker": ("gear_harmonic", "encoder_scale", "joint_compliance"), "ballbar": ("gear_harmonic",)}


def calibrate(spec_path):
    """The stages of `armcal run` up to the diagnosis' final fit, and the calibrated.yaml it writes."""
    loaded = load_spec(spec_path)
    spec = loaded.spec
    kinematics = compile_robot(spec.robot.chain())
    device = device_model(spec)
    raw = read_measurements(spec_path.parent / spec.data.calibration, spec)
    calibration = device.prepare(raw)
    validation = device.prepare(read_measurements(spec_path.parent / spec.data.validation, spec))
    calibrated = identify_and_diagnose(spec, kinematics, device, raw, calibration, validation)
    results = build_results(loaded, run_figures(loaded, calibrated, device, calibration.rows, {}, None, [], campaign(loaded, calibration, validation, (False, False))))
    out = spec_path.parent / "out"
    out.mkdir()
    (out / "calibrated.yaml").write_text(calibrated_text(loaded, results, calibrated, out)[0])
    return calibrated, out / "calibrated.yaml"


def scipy_cost(problem, start, base) -> float:
    """1/2 sum r^2 at scipy's least-squares minimum over the parameters ``base``, the others at ``start``."""

    def theta(x):
        out = start.copy()
        out[base] = x
        return out

    fitted = scipy.optimize.least_squares(
        lambda x: problem.evaluate(theta(x))[0],
        start[base],
        jac=lambda x: problem.evaluate(theta(x))[1][:, base],
        method="trf",
        x_scale="jac",
        xtol=1e-15,
        ftol=1e-15,
        gtol=1e-15,
        max_nfev=2000,
    )
    return float(fitted.cost)


def found(diagnosis, effect: dict, order: bool) -> bool:
    """The hidden effect's type on its joint is among the added ones (``order``: a harmonic's order too)."""
    return any(
        e.type == effect["type"] and e.joint == effect["joint"] and (not order or effect["order"] is None or e.order == effect["order"])
        for e in diagnosis.added
    )


def campaign_outcome(folder, robot: str, device: str, k: int) -> dict:
    effect = EFFECTS[device][k % len(EFFECTS[device])]
    sigmas = 2.0 + 3.0 * ((0.618034 * (k + 1)) % 1.0)
    # a ball-bar's refit geometry absorbs 65-97 % of a harmonic's signature: there the part it cannot absorb is scaled
    info = write_campaign(folder, robot, device, effect, seed=1000 + k, sigmas=sigmas, visible=device == "ballbar")
    calibrated, written = calibrate(info["spec"])
    result = calibrated.identified.least_squares
    start = calibrated.start
    held = np.setdiff1d(np.arange(len(start)), result.base)
    fitted = calibrated.problem.evaluate(result.theta)[0]
    return {
        "converged": result.solver.converged,
        "reason": result.solver.reason,
        "iterations": result.solver.iterations,
        "condition": result.conditioning.condition_number,
        "cost": result.solver.cost,
        "scipy": scipy_cost(calibrated.problem, start, result.base),
        "held_moved": bool(np.any(result.theta[held] != start[held])),
        "round_trip": float(np.max(np.abs(starting_residuals(written) - fitted))),  # noise sigmas
        "added": len(calibrated.diagnosis.added),
        "found": found(calibrated.diagnosis, info["effect"], order=False),
        "exact": found(calibrated.diagnosis, info["effect"], order=True),
        "effect": info["effect"]["type"],
    }


@pytest.mark.parametrize("count", [DEFAULT, pytest.param(PER_PAIR, marks=pytest.mark.slow)])
@pytest.mark.parametrize("robot", ["puma560", "ur_like"])
@pytest.mark.parametrize("device", ["tracker", "ballbar"])
def test_every_campaign_converges_to_scipys_minimum(tmp_path, monkeypatch, robot, device, count):
    if device == "ballbar":
        monkeypatch.setenv("ARMCAL_COMPILE", "off")
    outcomes = [campaign_outcome(tmp_path / f"c{k}", robot, device, k) for k in range(count)]
    failed = [(k, o["reason"]) for k, o in enumerate(outcomes) if not o["converged"]]
    assert not failed
    for k, o in enumerate(outcomes):
        assert o["cost"] == pytest.approx(o["scipy"], rel=1e-6), (k, o)
        assert not o["held_moved"], k
        assert o["round_trip"] < 1e-6, (k, o)  # calibrated.yaml predicts every reading as the fit does
    hits, exact = sum(o["found"] for o in outcomes), sum(o["exact"] for o in outcomes)
    assert hits >= count - math.ceil(MISSED * count / PER_PAIR), [(k, o["effect"]) for k, o in enumerate(outcomes) if not o["found"]]
    assert exact >= count - math.ceil(MISORDERED * count / PER_PAIR)  # on ball-bar shells harmonics of one joint's neighbouring orders look alike
    print(
        f"{robot}/{device}: {count - len(failed)}/{count} converged, effect on its joint found {hits}/{count}"
        f" ({exact} with the harmonic's order), iterations "
        f"median {np.median([o['iterations'] for o in outcomes]):.0f} max {max(o['iterations'] for o in outcomes)}, "
        f"condition median {np.median([o['condition'] for o in outcomes]):.3g} max {max(o['condition'] for o in outcomes):.3g}"
    )
