"""run(spec): load, compile, read data, fit, evaluate, write the artifacts - the stages in order."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from armcal.dataio.reader import read_measurements
from armcal.devices import device_model
from armcal.errors import Issue, SpecError, UserError
from armcal.diagnose.stage import identify_and_diagnose
from armcal.evaluate.evidence import evidence
from armcal.evaluate.grid import evaluation_tasks
from armcal.evaluate.summary import summarize
from armcal.fileio import output_folder
from armcal.kinematics.compiler import compile_robot
from armcal.report.plots import draw_plots
from armcal.report.render import certificate_files, write_files
from armcal.results.calibrated import calibrated_text
from armcal.results.campaign import campaign
from armcal.simulate import find_truth
from armcal.spec import load_spec

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
    out_dir = output_folder(out_dir if out_dir is not None else default_out_dir(loaded.path))
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
    for data in filter(None, (calibration, validation)):
        check_readable(device, data)
    calibrated = identify_and_diagnose(spec, kinematics, device, raw, calibration, validation)
    tasks = evaluation_tasks(spec, kinematics, calibrated, find_truth(calibration_path))
    found = evidence(loaded, kinematics, calibrated, calibration)
    plots = draw_plots(found)
    results = summarize(loaded, calibrated, calibration.rows, tasks, found, list(plots), campaign(loaded, calibration, validation))
    user_templates = folder / spec.report.template if spec.report.template else None
    files = {
        "results.json": json.dumps(results.model_dump(mode="json"), indent=2) + "\n",
        "calibrated.yaml": calibrated_text(loaded, results, calibrated, out_dir),
        **plots,
        **certificate_files(results.model_dump(mode="json"), plots, pdf, user_templates),
    }
    write_files(out_dir, files)  # only now: a failure above leaves the previous artifacts as they were
    return Outcome(results, out_dir)


def check_readable(device, data) -> None:
    """Readings the instrument could not have produced are a user error, named by file, line and column."""
    problems = device.unreadable(data)
    if problems:
        raise SpecError([Issue(data.source, line, None, column, message) for line, column, message in problems[:20]])


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
