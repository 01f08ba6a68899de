"""run(spec): load, compile, read data, fit, evaluate, write the artifacts - the stages in order."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from armcal import __version__
from armcal.dataio.reader import read_measurements
from armcal.devices import device_model
from armcal.errors import UserError
from armcal.diagnose.stage import identify_and_diagnose
from armcal.evaluate.evidence import evidence
from armcal.evaluate.grid import grid_evaluation, iso9283_evaluation
from armcal.evaluate.summary import summarize
from armcal.fileio import write_text_atomic
from armcal.kinematics.compiler import compile_robot
from armcal.report.plots import write_plots
from armcal.report.render import write_certificate
from armcal.results.calibrated import calibrated_yaml
from armcal.results.campaign import campaign
from armcal.results.model import Results
from armcal.simulate import find_truth
from armcal.simulate.truth import TrueRobot
from armcal.spec import LoadedSpec, load_spec

CERTIFICATE_FILES = ("certificate.pdf", "certificate.html")


@dataclass(frozen=True)
class Outcome:
    results: Results
    out_dir: Path

    @property
    def exit_code(self) -> int:
        return 0 if self.results.status == "converged" else 3


def default_out_dir(spec_path: Path) -> Path:
    """out/<spec stem>/ next to the spec (contract)."""
    return spec_path.parent / "out" / spec_path.stem


def run(spec_path: Path, out_dir: Path | None = None, force: bool = False, pdf: bool = True) -> Outcome:
    loaded = load_spec(spec_path)
    out_dir = Path(out_dir) if out_dir is not None else default_out_dir(loaded.path)
    _refuse_overwrite(out_dir, force)
    spec = loaded.spec
    if spec.data is None:
        raise UserError(f"{loaded.path}: the spec has no data section; add one (or write data with 'armcal simulate')")
    folder = loaded.path.parent
    calibration_path = folder / spec.data.calibration
    kinematics = compile_robot(spec.robot)
    device = device_model(spec, _sonic_mode(spec, calibration_path))
    raw = read_measurements(calibration_path, spec)
    calibration = device.prepare(raw)
    validation = device.prepare(read_measurements(folder / spec.data.validation, spec)) if spec.data.validation else None
    calibrated = identify_and_diagnose(spec, kinematics, device, raw, calibration, validation)
    truth = find_truth(calibration_path)
    theta = calibrated.identified.theta[: calibrated.problem.n_robot]
    tasks = {}
    if truth:
        true_robot = TrueRobot.from_record(kinematics, truth)
        free = {e.name for e in calibrated.problem.parameters.entries if e.free}
        setting = (kinematics, kinematics.parameters.nominal, theta, true_robot, spec.robot.units)
        where = {"frame": measured_point(spec), "teach": any(name.startswith("robot_base.") for name in free)}
        if "grid_task" in spec.report.tasks:
            tasks["grid_task"] = grid_evaluation(*setting, **where)
        if "iso9283" in spec.report.tasks:
            tasks["iso9283"] = iso9283_evaluation(*setting, spec.report.iso9283_cube, **where)
    found = evidence(loaded, kinematics, calibrated, calibration)
    measured = campaign(loaded, calibration, validation)
    results = summarize(loaded, calibrated, calibration.rows, tasks, found, write_plots(found, out_dir), measured)
    _write(loaded, results, calibrated, out_dir)
    user_templates = loaded.path.parent / spec.report.template if spec.report.template else None
    write_certificate(results.model_dump(mode="json"), out_dir, pdf, user_templates)
    return Outcome(results, out_dir)


def measured_point(spec) -> str | None:
    """The one robot target a point-measuring instrument saw, if that is all it saw (the grid's tool centre point)."""
    targets = getattr(spec.device, "targets", None)
    return targets[0] if targets and len(targets) == 1 and spec.device.type in ("tracker", "theodolite") else None


def _sonic_mode(spec, calibration_path: Path) -> str:
    """Fit triangulated points when that is all the data file has, else as the spec says."""
    if spec.device.type != "sonic_digitizer" or not calibration_path.exists():
        return spec.fit.sonic_readings
    header = calibration_path.read_text(encoding="utf-8-sig").split("\n", 1)[0].split(",")
    return "points" if "x" in header and not any(h.startswith("s_") for h in header) else spec.fit.sonic_readings


def _refuse_overwrite(out_dir: Path, force: bool) -> None:
    existing = [name for name in CERTIFICATE_FILES if (out_dir / name).exists()]
    if existing and not force:
        raise UserError(f"{out_dir / existing[0]} exists; use --force to replace the certificate")


def _write(loaded: LoadedSpec, results: Results, calibrated, out_dir: Path) -> None:
    write_text_atomic(out_dir / "results.json", json.dumps(results.model_dump(mode="json"), indent=2) + "\n")
    problem, theta = calibrated.problem, calibrated.identified.theta
    kinds = {e.name: e.kind for e in problem.parameters.entries}
    added = calibrated.diagnosis.added if calibrated.diagnosis else []
    added_names = {p.name for e in added for p in e.parameters()}
    values = {r.name for r in results.parameters if r.free and r.name not in added_names}
    identified = {name: (float(theta[problem.parameters.index(name)]), kinds[name]) for name in values}
    new_effects = [(e, {p.name.rsplit(".", 1)[1]: (float(theta[problem.parameters.index(p.name)]), p.kind) for p in e.parameters()}) for e in added]
    note = (
        f"Calibrated by armcal {__version__} on {results.created} from {loaded.path.name} "
        f"(sha256 {loaded.sha256[:12]}), status {results.status}."
    )
    text = calibrated_yaml(loaded.text, loaded.spec, identified, loaded.path, out_dir, note, new_effects)
    write_text_atomic(out_dir / "calibrated.yaml", text)
