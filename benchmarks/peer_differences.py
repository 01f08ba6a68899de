"""Benchmark (issue 36): armcal's geometric fit changed, one difference at a time, to what a peer of
bench_peers.py frees or does, and the held-out error of each change.

The differences (bench_peers' docstring says how each peer is run):

- parallel axes: armcal adds Hayati's beta on joint i where axis i is parallel to axis i+1 and holds
  d_i (kinematics/parallel.py; Hayati & Mirmirani 1985); pybotics' Modified DH, like a plain DH
  chain, has no beta and frees every d ("no beta on ..."). The d's along parallel axes are then
  redundant, and the tie rule (identifiability.py) lets the first in the spec carry their offset;
  "no beta, last d" holds the others so that the last one carries it, as in Hayati's form;
- the last link: the peers free joint 5's a and alpha (pybotics' MDH a_5, alpha_5; FIGAROH's six
  placement errors a joint); armcal holds them where the target lies on the last axis at the design
  point (the UR10's T-Mac): they are then redundant with the target's offset. "a5, alpha5 free"
  starts the target off the axis where armcal's fit puts it, with the weak-identifiability rule off,
  so that both are fitted;
- the weak-identifiability rule (identify/precision.py: a robot value whose predicted std exceeds
  robot.tolerance / 10 is held): "weak rule off";
- FIGAROH's outlier rounds: armcal's Huber loss instead of least squares ("huber loss");
- pybotics' stop: scipy's trf with its default tolerances and unit scaling stops on a small step
  before the least-squares minimum; "LM stopped at k" stops armcal's Levenberg-Marquardt after k
  iterations.

The world frame (a free tracker pose, six parameters), the joint offsets and the target's position on
the flange are free in all three tools (armcal lets the tracker pose carry the first joint's theta and
d, and the target joint 6's d, a and alpha: redundant, so the same predictions).

Cases: the UR10's Series C predicting B (positions only, as in bench_peers), and two simulated truths
from tests/independent_sim.py (numpy, written without armcal): a UR10-like arm and a PUMA 560, each
with manufacturing errors on every DH parameter, Hayati tilts of 0.02-0.05 deg on the parallel axes,
a target off the last axis (joint 5's a and alpha are seen) and a hidden gravity compliance of 3
noise sigmas (a non-geometric error, as on the real arm). "truth mm" is the RMS 3D error against the
true robot's noise-free held-out positions; "cal mm" and "held-out mm" are against the measured ones,
"registered" the held-out figure with the tracker registered anew on the held-out readings
(bench_peers.registered_rms: what is left is the robot's, not the registration's).

Run: .venv/bin/python benchmarks/peer_differences.py   (a few minutes)
"""

from __future__ import annotations

import re
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from _common import ROOT
from bench_peers import SERIES, _measured, _predict, held_out_rms, registered_rms

import numpy as np

from armcal.dataio.ipa import read_ipa
from armcal.dataio.reader import read_measurements
from armcal.dataio.writer import write_measurements
from armcal.devices import device_model
from armcal.identify.fit import design_identifiability, fit
from armcal.identify.precision import WEAK
from armcal.identify.problem import build_problem
from armcal.identify.starting_values import starting_values
from armcal.kinematics.compiler import compile_robot
from armcal.spec import load_spec

sys.path.insert(0, str(ROOT / "tests"))
from independent_sim import readings, write_campaign  # noqa: E402

COMPLIANCE_SIGMAS = 3.0  # the simulated truths' hidden joint compliance, in noise sigmas of the calibration readings


@dataclass
class Case:
    name: str
    text: str  # the spec
    calibration: Path
    validation: Path
    parallel: tuple[str, ...]  # joints whose axis is parallel to the next one's
    last_joint: tuple[str, str]  # joint 5 and the target, for "a5, alpha5 free"
    truth: np.ndarray | None = None  # the true robot's noise-free validation positions (N, 3)


@dataclass(frozen=True)
class Variant:
    name: str
    edit: object = None  # spec text -> spec text
    hold_weak: bool = True
    iterations: int | None = None
    loss: str | None = None
    off_axis: bool = False


def _joint(text: str, name: str, change) -> str:
    """The spec text with joint ``name``'s flow mapping changed by ``change`` (its text -> new text)."""
    return re.sub(r"\{name: %s, [^}]*\}" % name, lambda m: change(m.group(0)), text)


def no_beta(*names):
    """Hayati's beta held at 0 on ``names``: their d is then free, as in a plain DH chain."""
    def edit(text):
        for name in names:
            text = _joint(text, name, lambda j: j[:-1] + ", beta: {value: 0, vary: false}}")
        return text
    return edit


def no_beta_last_d(names):
    """No beta on ``names``, each one's d held: the next joint's d carries the offset along the parallel axes."""
    def edit(text):
        for name in names:
            text = _joint(text, name, lambda j: re.sub(r"d: ([-0-9.e]+)", r"d: {value: \1, vary: false}", j[:-1])
                          + ", beta: {value: 0, vary: false}}")
        return text
    return edit


def variants(case: Case) -> list[Variant]:
    out = [Variant("armcal (Hayati beta, d held)")]
    out += [Variant(f"no beta on {name}", no_beta(name)) for name in case.parallel]
    if len(case.parallel) > 1:
        out.append(Variant("no beta on any", no_beta(*case.parallel)))
    out += [
        Variant("no beta, last d", no_beta_last_d(case.parallel)),
        Variant("a5, alpha5 free", hold_weak=False, off_axis=True),
        Variant("weak rule off", hold_weak=False),
        Variant("huber loss", loss="huber"),
        Variant("LM stopped at 1", iterations=1),
        Variant("LM stopped at 2", iterations=2),
    ]
    return out


def geometric_fit(case: Case, variant: Variant, off_axis: dict[str, float]):
    """armcal's geometric fit of the case under ``variant``: (spec, parameter names, FitResult)."""
    text = variant.edit(case.text) if variant.edit else case.text
    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / "spec.yaml").write_text(text)
        spec = load_spec(Path(folder) / "spec.yaml").spec
    calibration = read_measurements(case.calibration, spec)
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    data = device.prepare(calibration)
    problem = build_problem(kinematics, device, data)
    start = starting_values(problem, kinematics, device, data)
    if variant.off_axis:
        for name, value in off_axis.items():
            start[problem.parameters.index(name)] = value
    update = {k: v for k, v in (("max_iterations", variant.iterations), ("loss", variant.loss)) if v is not None}
    design = design_identifiability(problem, start, variant.hold_weak)
    return spec, problem.parameters.names, fit(problem, spec.fit.model_copy(update=update), start, design)


def measure(case: Case) -> list[tuple]:
    """One row per variant: (variant, parameters, cal mm, held-out mm, registered mm, truth mm or None, note)."""
    rows, off_axis = [], {}
    for variant in variants(case):
        spec, names, result = geometric_fit(case, variant, off_axis)
        if not off_axis:  # the plain fit's target offset across the last axis
            off_axis = {f"{case.last_joint[1]}.{c}": result.theta[names.index(f"{case.last_joint[1]}.{c}")] for c in "xy"}
        validation = read_measurements(case.validation, spec)
        predicted = _predict(spec, names, result.theta, validation)
        calibration = read_measurements(case.calibration, spec)
        cal = held_out_rms(_predict(spec, names, result.theta, calibration), _measured(spec, calibration))
        truth = None if case.truth is None else held_out_rms(predicted, case.truth)
        base = [names[i] for i in result.base]
        weak = [n for n, reason in result.identifiability.fixed if reason.startswith(WEAK)]
        last = [n for n in (f"{case.last_joint[0]}.a", f"{case.last_joint[0]}.alpha") if n in base]
        note = f"{result.solver.iterations} it; weak held: {', '.join(weak) or 'none'}; free of a5, alpha5: {', '.join(last) or 'none'}"
        measured = _measured(spec, validation)
        rows.append((variant.name, len(base), cal, held_out_rms(predicted, measured), registered_rms(predicted, measured), truth, note))
    return rows


def case_ur10(folder: Path) -> Case | None:
    if not SERIES.exists():
        return None
    text = (ROOT / "specs" / "ur10.yaml").read_text().replace("orientation: true", "orientation: false")
    text = text.replace("estimate_noise: true", "estimate_noise: false")
    (folder / "spec.yaml").write_text(text)
    spec = load_spec(folder / "spec.yaml").spec
    for series in ("C", "B"):  # as `armcal import-ipa` converts them, positions only
        write_measurements(folder / f"{series}.csv", read_ipa(next((SERIES / f"Series_{series}").glob("measurements_*.csv")), "tmac", False), spec)
    return Case("UR10 real C -> B", text, folder / "C.csv", folder / "B.csv", ("shoulder_lift", "elbow"), ("wrist_2", "tmac"))


def case_simulated(folder: Path, robot: str, seed: int) -> Case:
    info = write_campaign(folder, robot, "tracker", "joint_compliance", seed=seed, sigmas=COMPLIANCE_SIGMAS)
    text = Path(info["spec"]).read_text()
    spec = load_spec(Path(info["spec"])).spec
    validation = read_measurements(folder / "validation.csv", spec)
    truth = readings(info["geometry"], "tracker", validation.q, [("smr",)] * len(validation.q), *info["hidden"]).reshape(-1, 3)
    parallel = {"ur_like": ("j2", "j3"), "puma560": ("j2",)}[robot]
    name = f"{robot} simulated (seed {seed})"
    return Case(name, text, folder / "calibration.csv", folder / "validation.csv", parallel, ("j5", "smr"), truth)


def main() -> None:
    header = f"{'case':28s} {'variant':30s} {'par':>4s} {'cal mm':>8s} {'held-out mm':>11s} {'registered':>10s} {'truth mm':>9s}  note"
    print(header)
    print("-" * len(header))
    with tempfile.TemporaryDirectory() as root:
        root = Path(root)
        makers = [(lambda f: case_ur10(f)), (lambda f: case_simulated(f, "ur_like", 3)), (lambda f: case_simulated(f, "puma560", 3))]
        for k, make in enumerate(makers):
            folder = root / f"case{k}"
            folder.mkdir()
            case = make(folder)
            if case is None:
                print(f"UR10 real C -> B: skipped, {SERIES} is absent")
                continue
            for variant, par, cal, held, registered, truth, note in measure(case):
                shown = f"{truth:9.4f}" if truth is not None else f"{'-':>9s}"
                print(f"{case.name:28s} {variant:30s} {par:4d} {cal:8.4f} {held:11.4f} {registered:10.4f} {shown}  {note}", flush=True)
    print("mm: RMS over samples of the 3D position error (bench_peers.held_out_rms); cal: the calibration data; held-out:"
          " the validation data; registered: the same after the tracker is registered anew on them; truth: the true"
          " robot's noise-free validation positions (simulated cases)")


if __name__ == "__main__":
    main()
