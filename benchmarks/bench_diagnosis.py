"""Benchmark: one residual diagnosis with all candidate effects, against the naive way, on identical model and data.

Case (e) of issue 7: examples/hidden_harmonic (a PUMA 560 on a laser tracker whose joint 2 gear hides a
first-order harmonic). armcal: identify_and_diagnose as a run calls it - fit, score tests of every
candidate, refit with the strongest, held-out check, round after round (goal: under 2 s). Baseline,
without a score test: fit the model, then add each candidate in turn and refit it with scipy LM and
finite differences on the numpy model (benchmarks/_common.py, effects included), pick the lowest cost.
Both start from armcal's registration of the tracker; the numpy model is asserted equal to armcal's
with every candidate at a random nonzero amplitude before anything is timed.

Run: .venv/bin/python benchmarks/bench_diagnosis.py   (prints one table; times are medians)
"""

from __future__ import annotations

from dataclasses import replace

from _common import ROOT, NumpyCampaign, assert_same_model, cost, median_time, numpy_device, print_table, rms, row, scipy_lm_fd

import numpy as np

from armcal.dataio.reader import read_measurements
from armcal.devices import device_model
from armcal.diagnose.candidates import candidates
from armcal.diagnose.calibration import identify_and_diagnose
from armcal.effects.measurement import EffectSet
from armcal.identify.identifiability import analyse
from armcal.identify.problem import build_problem
from armcal.identify.starting_values import starting_values
from armcal.kinematics.compiler import compile_robot
from armcal.spec import load_spec

GOAL = 2.0  # s, issue 7
AMPLITUDE = {"angle": 1e-3, "compliance": 1e-5, "per_s": 1e-7, "scale": 1e-4}  # of the candidates in the model check


def naive(spec, calibration, names, start, base, pool):
    """Fit, then each candidate added and refitted: (its id, theta) of the lowest cost, residual evaluations."""
    device = numpy_device(spec)
    theta, calls = scipy_lm_fd(NumpyCampaign(spec.robot, device, names, calibration), start, base)
    best = (np.inf, None, None)
    for candidate in pool:
        model = NumpyCampaign(spec.robot, device, names, calibration, (candidate,))
        free = np.concatenate([base, [names.index(p.name) for p in candidate.parameters()]])
        fitted, count = scipy_lm_fd(model, theta, free)
        calls += count
        best = min(best, (0.5 * float(np.sum(model.residuals(fitted) ** 2)), candidate.id, fitted), key=lambda b: b[0])
    return best[1], best[2], calls


def case_e() -> list[str]:
    folder = ROOT / "examples" / "hidden_harmonic"
    spec = load_spec(folder / "spec.yaml").spec
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    raw = read_measurements(folder / "calibration.csv", spec)
    calibration, validation = device.prepare(raw), device.prepare(read_measurements(folder / "validation.csv", spec))
    diagnose = lambda: identify_and_diagnose(spec, kinematics, device, raw, calibration, validation)  # noqa: E731
    first, _ = median_time(diagnose, repeats=1)
    armcal_time, calibrated = median_time(diagnose, repeats=7)

    pool = candidates(kinematics, device, calibration, [], spec.diagnose)
    effects = EffectSet(tuple(replace(c, free=False) for c in pool))  # every candidate in the model, fixed at zero
    problem, validation_problem = (build_problem(kinematics, device, data, effects) for data in (calibration, validation))
    names = problem.parameters.names
    assert names == calibrated.problem.parameters.names
    start = starting_values(problem, kinematics, device, calibration)
    every = NumpyCampaign(spec.robot, numpy_device(spec), names, calibration, pool)
    assert_same_model(every, problem, start)
    candidate = {p.name: AMPLITUDE[p.kind] for c in pool for p in c.parameters()}
    shaken = start + np.array([candidate.get(name, 0.0) for name in names]) * np.random.default_rng(7).standard_normal(len(start))
    assert_same_model(every, problem, shaken, " with the candidates")
    base = np.array([names.index(n) for n in analyse(problem.evaluate(start)[1], problem.parameters, problem.parameters.free).base])
    baseline_time, (picked, theta, calls) = median_time(lambda: naive(spec, calibration, names, start, base, pool), repeats=3)

    diagnosis = calibrated.diagnosis
    theta_armcal = calibrated.identified.theta
    chosen = diagnosis.rounds[0].accepted.id if diagnosis.rounds[0].accepted else "none"
    return [
        row(
            f"(e) diagnosis, {len(pool)} candidates, {len(problem.residuals.sample)} res",
            armcal_time,
            baseline_time,
            (cost(problem, theta_armcal), cost(problem, theta)),
            (rms(validation_problem, theta_armcal), rms(validation_problem, theta)),
        ),
        f"    picks: armcal {chosen} (round 1; added {', '.join(e.id for e in diagnosis.added) or 'nothing'} in {len(diagnosis.rounds)} rounds),"
        f" baseline {picked}: {'agree' if chosen == picked else 'DISAGREE'}",
        f"    (armcal: {armcal_time:.2f} s against the goal of {GOAL:.0f} s, {'met' if armcal_time < GOAL else 'NOT met'};"
        f" first call {first:.2f} s incl. compiling/loading; baseline: {len(pool) + 1} fits, {calls} residual evaluations incl. finite differences)",
    ]


def main() -> None:
    print_table(case_e(), "cost, val: of the final model (armcal: every effect it added; baseline: its pick), weighted residuals")


if __name__ == "__main__":
    main()
