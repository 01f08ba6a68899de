"""Benchmark: armcal's identification against the way peers fit today, on identical model and data.

Case (a): Goswami's PUMA 560 ball-bar campaign (examples/goswami_ballbar: six-parameter model with
encoder offsets and scales, 9 pivot/sphere pairings, ~800 lengths, validation on the 61 cm shells).
Baseline: scipy.optimize.least_squares(method="lm") with finite-difference Jacobians on a numpy
forward model written here independently of armcal. Both start from the nominal values, fit the
same free parameters (armcal's base set) to the same weighted residuals.

Run: .venv/bin/python benchmarks/bench_identification.py   (prints one table; times are medians)
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import armcal  # noqa: E402, F401  (first: its single-threaded BLAS setting then holds for both sides)
import numpy as np  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

from armcal.dataio.reader import read_measurements  # noqa: E402
from armcal.devices import device_model  # noqa: E402
from armcal.identify.fit import fit  # noqa: E402
from armcal.identify.problem import build_problem  # noqa: E402
from armcal.kinematics.compiler import compile_robot  # noqa: E402
from armcal.spec import load_spec  # noqa: E402

REPEATS = 15


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


class NumpyBallBar:
    """Goswami's chain T = T1L T1J ... T6J T7L (3), theta = theta0 + k q (2), and the bar length, in numpy."""

    def __init__(self, names: list[str], data, spec):
        self.names = names
        self.q = data.q
        self.measured = data.readings["length"]
        self.sigma = spec.device.noise
        self.pivots = np.array([[0.0, 0.0, 0.0]])
        self.keys = data.keys
        self.length0 = spec.device.length.value

    def residuals(self, p: np.ndarray) -> np.ndarray:
        v = dict(zip(self.names, p))
        count = len(self.q)
        R = np.repeat(np.eye(3)[None], count, 0)
        t = np.zeros((count, 3))

        def link(i):
            nonlocal R, t
            L = lambda f: np.full(count, v[f"L{i}.{f}"])  # noqa: E731
            t = t + np.einsum("nij,nj->ni", R, np.stack([L("x"), L("y"), L("z")], 1))
            R = R @ _rz(L("alpha")) @ _ry(L("beta")) @ _rx(L("gamma"))

        for joint in range(1, 7):
            link(joint)
            R = R @ _rz(v[f"j{joint}.theta0"] + v[f"j{joint}.k"] * self.q[:, joint - 1])
        link(7)
        out = np.empty(count)
        for sphere in ("sphere1", "sphere2", "sphere3"):
            for pivot in ("chuck1", "chuck2", "chuck3"):
                rows = np.array([k[0] == pivot and k[1] == sphere for k in self.keys])
                if not rows.any():
                    continue
                offset = np.array([v[f"{sphere}.{c}"] for c in "xyz"])
                position = t[rows] + np.einsum("nij,j->ni", R[rows], offset)
                centre = np.array([v[f"pivot.{pivot}.{c}"] for c in "xyz"])
                predicted = np.linalg.norm(position - centre, axis=1) + self.length0 - v["bar.length"]
                out[rows] = (predicted - self.measured[rows]) / self.sigma
        return out


def _median_time(function, repeats=REPEATS):
    times, result = [], None
    for _ in range(repeats):
        started = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - started)
    return statistics.median(times), result


def case_a() -> list[str]:
    folder = ROOT / "examples" / "goswami_ballbar"
    spec = load_spec(folder / "spec.yaml").spec
    kinematics, device = compile_robot(spec.robot), device_model(spec)
    calibration = read_measurements(folder / "calibration.csv", spec)
    validation = read_measurements(folder / "validation.csv", spec)
    started = time.perf_counter()
    problem = build_problem(kinematics, device, calibration)
    setup = time.perf_counter() - started
    validation_problem = build_problem(kinematics, device, validation)
    armcal_time, result = _median_time(lambda: fit(problem, spec.fit))
    names = problem.parameters.names
    base = result.base
    start = problem.parameters.nominal.copy()
    model = NumpyBallBar(names, calibration, spec)
    check = np.abs(model.residuals(start) - problem.evaluate(start)[0]).max()
    assert check < 1e-6, f"the baseline's model differs from armcal's by {check}"

    def baseline():
        def residuals(x):
            p = start.copy()
            p[base] = x
            return model.residuals(p)

        return least_squares(residuals, start[base], method="lm", x_scale="jac")

    baseline_time, solution = _median_time(baseline, repeats=3)
    p_baseline = start.copy()
    p_baseline[base] = solution.x
    rms = lambda pr, p: float(np.sqrt(np.mean(pr.evaluate(p)[0] ** 2)))  # noqa: E731
    cost_armcal, cost_baseline = 0.5 * rms(problem, result.theta) ** 2 * len(calibration), 0.5 * float(solution.fun @ solution.fun)
    return [
        f"{'(a) ball-bar, 36 of 85 params, %d lengths' % len(calibration):44s} {armcal_time * 1000:9.1f} {baseline_time * 1000:10.1f} {baseline_time / armcal_time:7.1f}"
        f" {cost_armcal:10.2f} {cost_baseline:10.2f} {rms(validation_problem, result.theta):8.4f} {rms(validation_problem, p_baseline):8.4f}",
        f"    (armcal: problem built and compiled/loaded in {setup * 1000:.0f} ms, once per setup; {result.solver.iterations} LM iterations;"
        f" baseline: {solution.nfev} residual evaluations)",
    ]


def main() -> None:
    header = f"{'case':44s} {'armcal ms':>9s} {'baseline ms':>10s} {'ratio':>7s} {'cost A':>10s} {'cost B':>10s} {'val A':>8s} {'val B':>8s}"
    print(header)
    print("-" * len(header))
    for line in case_a():
        print(line)
    print("cost: 1/2 sum of squared weighted residuals; val: RMS of validation residuals in noise sigmas; A armcal, B baseline")


if __name__ == "__main__":
    main()
