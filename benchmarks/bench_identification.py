"""Benchmark: armcal's identification against the way peers fit today, on identical model and data.

Baseline: scipy.optimize.least_squares(method="lm", x_scale="jac") with finite-difference Jacobians on
numpy forward models written independently of armcal (benchmarks/_common.py). Both sides start from
the same values and fit the same free parameters (armcal's base set) to the same weighted residuals,
which are asserted equal first. Issue 7's cases:

(a) Goswami's PUMA 560 ball-bar campaign (examples/goswami_ballbar), validated on the 61 cm shells.
(b) Stone's circle-point sonic campaign (examples/puma560_sonic) simulated with 100 points per joint,
    fitted by least squares on the slant ranges (the example's spec asks for Stone's features).
(c) The theodolite network of examples/theodolite (two stations, a scale bar).
(d) The UR10's real laser-tracker data of ../shared/data (fit Series C, validate on Series B);
    skipped when ../shared is absent.

armcal shares each fit's evaluations and QR out to one thread per processor (identify/threads.py, at most 4);
the note under each case gives its time on one thread too. The baseline runs on one (scipy's MINPACK).

Run: .venv/bin/python benchmarks/bench_identification.py   (prints one table; times are medians)
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from _common import ROOT, NumpyCampaign, assert_same_model, cost, median_time, numpy_device, print_table, rms, row, scipy_lm_fd

from armcal.dataio.ipa import read_ipa
from armcal.dataio.reader import read_measurements
from armcal.dataio.writer import write_measurements
from armcal.devices import device_model
from armcal.identify import threads
from armcal.identify.fit import fit
from armcal.identify.problem import build_problem
from armcal.identify.starting_values import starting_values
from armcal.kinematics.compiler import compile_robot
from armcal.simulate import simulate_campaign
from armcal.spec import load_spec

SERIES = ROOT.parent / "shared" / "data" / "ipa-robot-accuracy"
SONIC_POINTS = 100  # per joint


def compare(name: str, spec, calibration, validation=None, start_from_data: bool = False, repeats: int = 15) -> list[str]:
    """Time armcal's fit and the baseline's on prepared data; the table line and a note."""
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    calibration = device.prepare(calibration)
    started = time.perf_counter()
    problem = build_problem(kinematics, device, calibration)
    setup = time.perf_counter() - started
    validation_problem = build_problem(kinematics, device, device.prepare(validation)) if validation is not None else None
    start = starting_values(problem, kinematics, device, calibration) if start_from_data else problem.parameters.nominal
    names = problem.parameters.names
    model = NumpyCampaign(spec.robot, numpy_device(spec), names, calibration)
    assert_same_model(model, problem, start)
    armcal_time, result = median_time(lambda: fit(problem, spec.fit, start), repeats)
    shared = threads.workers()
    threads.limit(1)
    one_thread, _ = median_time(lambda: fit(problem, spec.fit, start), repeats)
    threads.limit(shared)
    baseline_time, (theta, calls) = median_time(lambda: scipy_lm_fd(model, start, result.base), repeats=3)
    line = row(
        f"{name}: {len(result.base)}/{len(names)} par, {len(problem.residuals.sample)} res",
        armcal_time,
        baseline_time,
        (cost(problem, result.theta), cost(problem, theta)),
        (rms(validation_problem, result.theta), rms(validation_problem, theta)),
    )
    note = (
        f"    (armcal: problem built and compiled/loaded in {setup * 1000:.0f} ms, once per setup; {result.solver.iterations} LM iterations;"
        f" {shared} threads, on one thread {one_thread * 1000:.1f} ms = ratio {baseline_time / one_thread:.1f};"
        f" baseline: {calls} residual evaluations incl. finite differences, one thread)"
    )
    return [line, note]


def _shipped(example: str):
    """A shipped example's spec with its calibration and validation data."""
    folder = ROOT / "examples" / example
    spec = load_spec(folder / "spec.yaml").spec
    return (spec, *(read_measurements(folder / f"{name}.csv", spec) for name in ("calibration", "validation")))


def case_a() -> list[str]:
    return compare("(a) ball-bar", *_shipped("goswami_ballbar"))


def case_b() -> list[str]:
    folder = ROOT / "examples" / "puma560_sonic"
    spec = load_spec(folder / "spec.yaml").spec
    spec = spec.model_copy(update={"procedure": spec.procedure.model_copy(update={"points_per_joint": SONIC_POINTS})})
    campaign = simulate_campaign(spec, folder)
    lines = compare(f"(b) sonic 6x{SONIC_POINTS} ranges", spec, campaign.calibration)
    dropped = sum(campaign.dropped["calibration"].values())
    return lines + [
        f"    (simulated in memory, {len(campaign.calibration)} positions ({dropped} not visible); both fit the slant ranges"
        " after armcal's speed-of-sound compensation (App. E, a data step without parameters); no validation data)"
    ]


def case_c() -> list[str]:
    return compare("(c) theodolite", *_shipped("theodolite"))


def case_d() -> list[str]:
    if not SERIES.exists():
        return [f"(d) UR10 laser tracker: skipped, {SERIES} is absent"]
    spec = load_spec(ROOT / "specs" / "ur10.yaml").spec
    data = {}
    with tempfile.TemporaryDirectory() as folder:
        for series in ("C", "B"):  # as `armcal import-ipa` converts them, read back as a run reads them
            path = Path(folder) / f"{series}.csv"
            write_measurements(path, read_ipa(next((SERIES / f"Series_{series}").glob("measurements_*.csv")), "tmac", spec.device.orientation), spec)
            data[series] = read_measurements(path, spec)
    lines = compare("(d) UR10 real, C (val B)", spec, data["C"], data["B"], start_from_data=True)
    return lines + ["    (both start from armcal's registration of the tracker (Kabsch); positions and probe orientations fitted)"]


def main() -> None:
    print_table([line for case in (case_a, case_b, case_c, case_d) for line in case()])


if __name__ == "__main__":
    main()
