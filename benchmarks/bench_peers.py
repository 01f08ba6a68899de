"""Benchmark: armcal against the tools a user would pick instead (issue 18), on the same data.

Cases (one table):

(1) UR10 real laser-tracker data (../shared/data): fit Series C, predict Series B; positions only.
(2) A simulated PUMA 560 tracker campaign (tests/independent_sim.py: manufacturing errors, Hayati
    tilts on the parallel axes 2-3, a hidden joint compliance of 3 noise sigmas, 0.02 mm noise).
(3) Goswami's PUMA 560 ball-bar campaign (examples/goswami_ballbar), validated on its held-out shells.

Tools, each fitting the same calibration data from the same start the way its documentation says:

- armcal: its compiled residuals and Levenberg-Marquardt on its identifiable base set (geometry only:
  no diagnosis, no added effects; ``armcal run`` would add them).
- armcal run: the whole loop a user runs on the case's spec and CSVs (fit, residual diagnosis, the effects
  that hold out; for the UR10 the shipped spec's noise from the data and compliance from UR's masses,
  positions only): its held-out predictions are the measured readings plus its residuals.csv residuals.
- scipy LM: the existing baseline (benchmarks/_common.py): numpy models of armcal's, scipy
  least_squares(method="lm") with finite differences, armcal's free set.
- pybotics: its Modified-DH Robot (the spec's DH converted to MDH), its OptimizationHandler (world frame,
  kinematic chain, tool masks) and optimize_accuracy (per-pose distance residuals) minimised by
  scipy.optimize.least_squares, as in its calibration example.
- FIGAROH: its geometric calibration (Pinocchio, a URDF exported by armcal from the spec), the
  "full_params" model with its own QR selection of identifiable parameters, solved by its solve().

Held-out accuracy is computed here by one function (held_out_rms) for every tool from the tool's own
predictions of the held-out readings: tracker positions in the tracker frame (with the tool's own
registration, i.e. its fitted world frame), or ball-bar lengths; the same function of its predictions of
the calibration readings is its fit's residual (cal mm): a tool at the least-squares minimum of a complete
model has the smallest (benchmarks/peer_differences.py changes armcal's fit one peer difference at a
time); "registered" is the held-out figure after the rigid transform that best maps the tool's held-out
positions onto the readings (Kabsch: the tracker registered anew on the held-out data, six parameters
no robot geometry changes), so a gap there is the robot's, not the registration's. Fit time is the tool's fit call; end-to-end adds model building (armcal: compiling or loading its
functions; peers: the whole subprocess, interpreter start and imports included).

Peers run in their own interpreters (pybotics pins numpy < 2, Pinocchio 4 wants numpy 2; neither is an
armcal dependency). Set them up once, outside the repository:

    python3 -m venv /tmp/peers-pybotics && /tmp/peers-pybotics/bin/pip install pybotics
    python3 -m venv /tmp/peers-figaroh && /tmp/peers-figaroh/bin/pip install figaroh

(other locations: ARMCAL_PYBOTICS_PYTHON, ARMCAL_FIGAROH_PYTHON). A peer that is missing or fails
prints its one-line reason in the table; the other rows still print.

Run: .venv/bin/python benchmarks/bench_peers.py   (one run, minutes: pybotics' fit is pure Python)
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from _common import ROOT, BallBar, NumpyCampaign, NumpyRobot, Tracker, pose, scipy_lm_fd

import numpy as np

from armcal.dataio.ipa import read_ipa
from armcal.dataio.reader import read_measurements
from armcal.dataio.writer import write_measurements
from armcal.devices import device_model
from armcal.export.urdf import urdf
from armcal.identify.fit import fit
from armcal.identify.problem import build_problem
from armcal.identify.starting_values import starting_values
from armcal.kinematics.compiler import compile_robot
from armcal.kinematics.transforms import rigid_registration
from armcal.commands.run import run
from armcal.spec import load_spec
from armcal.support.units import from_internal

SERIES = ROOT.parent / "shared" / "data" / "ipa-robot-accuracy"
PEERS = Path(__file__).resolve().parent / "peers"
INTERPRETERS = {
    "pybotics": os.environ.get("ARMCAL_PYBOTICS_PYTHON", "/tmp/peers-pybotics/bin/python"),
    "FIGAROH": os.environ.get("ARMCAL_FIGAROH_PYTHON", "/tmp/peers-figaroh/bin/python"),
}
WORKERS = {"pybotics": PEERS / "pybotics_fit.py", "FIGAROH": PEERS / "figaroh_fit.py"}
PEER_TIMEOUT = 1800  # s


def held_out_rms(predicted: np.ndarray, measured: np.ndarray) -> float:
    """RMS over held-out samples of the Euclidean error per sample (mm): a 3D position error per pose for
    a tracker (rows x, y, z), the length error for a ball-bar (one column). The one accuracy figure of
    every tool."""
    predicted, measured = np.atleast_2d(predicted), np.atleast_2d(measured)
    if predicted.shape != measured.shape:
        raise ValueError(f"predictions {predicted.shape} do not match measurements {measured.shape}")
    return float(np.sqrt(np.mean(np.sum((predicted - measured) ** 2, axis=1))))


def registered_rms(predicted: np.ndarray, measured: np.ndarray) -> float | None:
    """held_out_rms of tracker positions after the rigid transform that best maps them onto the measured ones
    (armcal.kinematics.transforms.rigid_registration); None for ball-bar lengths."""
    if predicted.shape[1] != 3:
        return None
    T = rigid_registration(predicted, measured)
    return held_out_rms(predicted @ T[:3, :3].T + T[:3, 3], measured)


@dataclass
class Case:
    """One calibration case as every tool sees it: the spec, armcal's data, and the plain arrays."""

    name: str
    spec: object
    calibration: object
    validation: object
    start_from_data: bool = True
    spec_text: str | None = None  # the spec as `armcal run` reads it, data: {calibration: calibration.csv, validation: validation.csv}
    rows: list = field(default_factory=list)  # table rows (tool, params, fit s, end-to-end s, cal mm, held-out mm, registered mm, note)

    def add(self, tool: str, parameters: int, fit_seconds: float, total: float, fitted: np.ndarray, predicted: np.ndarray, note: str) -> None:
        """The row of a tool from its predictions of the calibration (``fitted``) and held-out readings."""
        measured = _measured(self.spec, self.validation)
        cal = held_out_rms(fitted, _measured(self.spec, self.calibration))
        self.rows.append((tool, parameters, fit_seconds, total, cal, held_out_rms(predicted, measured), registered_rms(predicted, measured), note))

    def reason(self, tool: str, note: str) -> None:
        """The row of a tool that gave no answer."""
        self.rows.append((tool, None, None, None, None, None, None, note))


def _measured(spec, data) -> np.ndarray:
    """Held-out readings in row order: (N, 3) tracker positions or (N, 1) bar lengths."""
    columns = ("x", "y", "z") if spec.device.type == "tracker" else ("length",)
    return np.stack([data.readings[c] for c in columns], axis=1)


def _predict(spec, names: list[str], theta: np.ndarray, data) -> np.ndarray:
    """Predicted held-out readings (rows of _measured) of armcal's parameter vector, by the numpy models of
    benchmarks/_common.py (written independently of armcal)."""
    v, robot = dict(zip(names, theta)), NumpyRobot(spec.robot)
    device = Tracker(spec.device) if spec.device.type == "tracker" else BallBar(spec.device)
    out = np.empty((len(data.q), 3 if spec.device.type == "tracker" else 1))
    for key, rows in data.groups().items():
        seen = robot.target(v, device.target(key), data.q[rows])
        out[rows] = device.readings(v, key, seen)[:, : out.shape[1]]
    return out


def run_armcal(case: Case) -> dict:
    """armcal's geometric fit and scipy's LM baseline; the peers' common start comes from armcal's."""
    spec = case.spec
    started = time.perf_counter()
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    calibration = device.prepare(case.calibration)
    problem = build_problem(kinematics, device, calibration)
    start = starting_values(problem, kinematics, device, calibration) if case.start_from_data else problem.parameters.nominal
    setup = time.perf_counter() - started
    started = time.perf_counter()
    result = fit(problem, spec.fit, start)
    seconds = time.perf_counter() - started
    names = problem.parameters.names
    fitted, predicted = (_predict(spec, names, result.theta, data) for data in (case.calibration, case.validation))
    case.add("armcal", len(result.base), seconds, setup + seconds, fitted, predicted, f"{result.solver.iterations} LM iterations")
    model = NumpyCampaign(spec.robot, {"tracker": Tracker, "ballbar": BallBar}[spec.device.type](spec.device), names, calibration)
    started = time.perf_counter()
    theta, calls = scipy_lm_fd(model, start, result.base)
    seconds = time.perf_counter() - started
    fitted, predicted = (_predict(spec, names, theta, data) for data in (case.calibration, case.validation))
    case.add("scipy LM (FD)", len(result.base), seconds, seconds, fitted, predicted, f"{calls} residual evaluations")
    return {"names": names, "start": start, "kinematics": kinematics}


def run_armcal_loop(case: Case, folder: Path) -> None:
    """`armcal run` as a user runs it (fit, residual diagnosis, the effects that hold out): its held-out
    predictions are the measured readings plus its residuals.csv's residuals after calibration."""
    if case.spec_text is None:
        return
    folder.mkdir()
    (folder / "spec.yaml").write_text(case.spec_text)
    for name, data in (("calibration", case.calibration), ("validation", case.validation)):
        write_measurements(folder / f"{name}.csv", data, case.spec)
    started = time.perf_counter()
    results = run(folder / "spec.yaml", folder / "out", pdf=False).results
    total = time.perf_counter() - started
    with (folder / "out" / "residuals.csv").open() as handle:
        rows = [r for r in csv.DictReader(handle) if r["channel"] in ("x", "y", "z")]
    scale = from_internal(1.0, "length", case.spec.robot.units.length)  # the CSV is in the spec's unit
    positions = []
    for name in ("calibration", "validation"):
        predicted: dict[str, dict[str, float]] = {}
        for r in rows:
            if r["data"] == name:
                predicted.setdefault(r["line"], {})[r["channel"]] = (float(r["measured"]) + float(r["residual_after"])) / scale
        positions.append(np.array([[predicted[line][c] for c in "xyz"] for line in sorted(predicted, key=int)]))
    added = ", ".join(f"{e.type}" + (f" j{e.joint}" if e.joint else "") for e in results.diagnosis.added_effects) or "none"
    case.add("armcal run", results.identifiability.rank, total, total, *positions, f"the whole loop (fit s: the whole run); effects added: {added}")


def _peer_input(case: Case, armcal: dict, folder: Path) -> Path:
    """The case as plain arrays (mm, rad) and a URDF, for a peer's own interpreter."""
    spec, v = case.spec, dict(zip(armcal["names"], armcal["start"]))
    robot = spec.robot
    (target,) = spec.device.targets
    if robot.convention != "dh" or any(j.type != "revolute" for j in robot.joints):
        raise ValueError("peers get a revolute DH chain")
    dh = np.array([[v[f"{j}.theta"], v[f"{j}.d"], v[f"{j}.a"], v[f"{j}.alpha"]] for j in robot.joint_names()])
    world = pose(v, "robot_base") @ pose(v, "base")  # the registered tracker-to-robot start, spec's base included
    flange_target = pose(v, "tool") @ pose(v, target)
    text, _ = urdf(spec, armcal["kinematics"], ())
    path = folder / f"case{len(list(folder.glob('*.npz'))) + 1}.npz"
    np.savez(
        path, dh=dh, world=world, target=flange_target, urdf=np.array(text),
        q_cal=case.calibration.q, y_cal=_measured(spec, case.calibration), q_val=case.validation.q,
    )
    return path


def run_peer(tool: str, case: Case, path: Path) -> None:
    """One peer in its own interpreter: its row, or its one-line reason."""
    python, worker = INTERPRETERS[tool], WORKERS[tool]
    if not Path(python).exists():
        case.reason(tool, f"not installed: no interpreter {python} (see this script's docstring)")
        return
    out = path.with_suffix(f".{tool}.json")
    started = time.perf_counter()
    try:
        done = subprocess.run([python, str(worker), str(path), str(out)], capture_output=True, text=True, timeout=PEER_TIMEOUT)
    except subprocess.TimeoutExpired:
        case.reason(tool, f"no answer within {PEER_TIMEOUT} s")
        return
    total = time.perf_counter() - started
    if done.returncode != 0 or not out.exists():
        lines = [line for line in (done.stderr or done.stdout).strip().splitlines() if line.strip()]
        case.reason(tool, f"failed: {lines[-1] if lines else f'exit {done.returncode}'}")
        return
    answer = json.loads(out.read_text())
    fitted, predicted = np.array(answer["fitted"]), np.array(answer["predicted"])
    case.add(tool, answer["parameters"], answer["fit_seconds"], total, fitted, predicted, answer["note"])


# --- cases ---------------------------------------------------------------------------------------


LOOP_DATA = "data: {calibration: calibration.csv, validation: validation.csv}\n"


def case_ur10() -> Case | str:
    if not SERIES.exists():
        return f"(1) UR10 C -> B: skipped, {SERIES} is absent"
    spec = load_spec(ROOT / "specs" / "ur10.yaml").spec
    device = spec.device.model_copy(update={"orientation": False, "estimate_noise": False})
    spec = spec.model_copy(update={"device": device})
    data = {}
    with tempfile.TemporaryDirectory() as folder:
        for series in ("C", "B"):  # as `armcal import-ipa` converts them, positions only
            path = Path(folder) / f"{series}.csv"
            write_measurements(path, read_ipa(next((SERIES / f"Series_{series}").glob("measurements_*.csv")), "tmac", False), spec)
            data[series] = read_measurements(path, spec)
    text = (ROOT / "specs" / "ur10.yaml").read_text().replace("orientation: true", "orientation: false")
    text = text.replace("armcal: 1\n", f"armcal: 1\n{LOOP_DATA}", 1)
    return Case("(1) UR10 real C -> B", spec, data["C"], data["B"], spec_text=text)


def case_puma_tracker() -> Case:
    sys.path.insert(0, str(ROOT / "tests"))
    from independent_sim import write_campaign

    with tempfile.TemporaryDirectory() as folder:
        info = write_campaign(Path(folder), "puma560", "tracker", "joint_compliance", seed=7, sigmas=3.0)
        spec = load_spec(Path(info["spec"])).spec
        data = [read_measurements(Path(folder) / f"{n}.csv", spec) for n in ("calibration", "validation")]
        text = Path(info["spec"]).read_text()
    return Case("(2) PUMA 560 tracker (simulated)", spec, *data, spec_text=text)


def case_ballbar() -> Case:
    folder = ROOT / "examples" / "goswami_ballbar"
    spec = load_spec(folder / "spec.yaml").spec
    data = [read_measurements(folder / f"{n}.csv", spec) for n in ("calibration", "validation")]
    return Case("(3) PUMA 560 ball-bar (Goswami)", spec, *data, start_from_data=False)


BALLBAR_REASONS = {
    "pybotics": "cannot express ball-bar distances: its fitness functions compare positions or the distance between two robot poses, not a bar to a fixed pivot",
    "FIGAROH": "cannot express ball-bar distances: its geometric calibration measures marker positions/poses only",
}


# --- table ---------------------------------------------------------------------------------------

HEADER = f"{'case':34s} {'tool':14s} {'par':>4s} {'fit s':>8s} {'e2e s':>8s} {'cal mm':>8s} {'held-out mm':>11s} {'/armcal':>7s} {'registered':>10s}  note"


def print_table(cases: list) -> None:
    print(HEADER)
    print("-" * len(HEADER))
    for case in cases:
        if isinstance(case, str):
            print(case)
            continue
        reference = next(r[5] for r in case.rows if r[0] == "armcal")
        for tool, par, fit_s, total, cal, rms, registered, note in case.rows:
            if rms is None:
                print(f"{case.name:34s} {tool:14s} {'-':>4s} {'-':>8s} {'-':>8s} {'-':>8s} {'-':>11s} {'-':>7s} {'-':>10s}  {note}")
            else:
                shown = f"{registered:10.4f}" if registered is not None else f"{'-':>10s}"
                print(f"{case.name:34s} {tool:14s} {par:4d} {fit_s:8.2f} {total:8.2f} {cal:8.4f} {rms:11.4f} {rms / reference:7.2f} {shown}  {note}")
    print(
        "held-out mm: RMS over held-out samples of the 3D position error per pose (tracker, each tool's own registration)"
        " or of the length error (ball-bar), one function for all tools; cal mm: the same of the calibration readings"
        " (the fit's residual); /armcal: the held-out RMS over armcal's; registered: the held-out RMS after the rigid"
        " transform that best maps the tool's held-out positions onto the readings (the tracker registered anew);"
        " par: parameters the tool fitted; fit s: the fit call; e2e s: model building + fit (peers: whole subprocess)"
    )


def main() -> None:
    cases = []
    with tempfile.TemporaryDirectory() as folder:
        for make in (case_ur10, case_puma_tracker, case_ballbar):
            case = make()
            cases.append(case)
            if isinstance(case, str):
                continue
            armcal = run_armcal(case)
            run_armcal_loop(case, Path(folder) / f"loop{len(cases)}")
            if case.spec.device.type == "ballbar":
                for tool, reason in BALLBAR_REASONS.items():
                    case.reason(tool, reason)
                continue
            path = _peer_input(case, armcal, Path(folder))
            for tool in ("pybotics", "FIGAROH"):
                run_peer(tool, case, path)
    print_table(cases)


if __name__ == "__main__":
    main()
