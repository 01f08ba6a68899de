"""run(spec): load, compile, read data, fit, evaluate, write the artifacts - the stages in order."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from armcal.dataio.reader import read_measurements
from armcal.devices import device_model, readings_mode
from armcal.support.errors import Issue, SpecError, UserError, shown_value
from armcal.diagnose.calibration import identify_and_diagnose
from armcal.diagnose.residual_model import IN_RESULTS_ONLY
from armcal.evaluate.evidence import evidence
from armcal.evaluate.grid import evaluation_tasks
from armcal.evaluate.residuals import residuals_csv
from armcal.evaluate.run_figures import run_figures
from armcal.kinematics.compiler import compile_robot
from armcal.report.plots import draw_plots
from armcal.support.output_set import output_set, run_id, stamp_svg
from armcal.support.progress import stage
from armcal.report.render import certificate_files, check_templates, template_folders
from armcal.results.build import build_results
from armcal.results.schema import Evidence, Results
from armcal.results.calibrated import calibrated_text
from armcal.results.campaign_block import campaign, certificate_unit
from armcal.results.history import history_entries
from armcal.results.reader import read_earlier
from armcal.simulate import find_truth, simulated_times
from armcal.spec.placeholders import placeholder_notes
from armcal.spec.sections import Simulate
from armcal.spec import load_spec


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


def run(spec_path: Path, out_dir: Path | None = None, force: bool = False, pdf: bool = True, history: list[Path] = ()) -> Outcome:
    """Calibrate the robot of a spec and publish the output set into ``out_dir`` (output_set.py); ``history``: earlier
    results of the same robot (results.json files or run folders), read before the fit and never replaced."""
    loaded = load_spec(spec_path)
    out_dir = out_dir if out_dir is not None else default_out_dir(loaded.path)
    spec = loaded.spec
    if spec.data is None:
        raise UserError(f"{loaded.path}: the spec has no data section; add one (or write data with 'armcal simulate')")
    folder = loaded.path.parent
    earlier = read_earlier(history, spec.robot.serial, str(loaded.path))
    inputs = [loaded.path, *(folder / f for f in (spec.data.calibration, spec.data.validation) if f), *(Path(source) for source, _ in earlier)]
    user_templates = folder / spec.report.template if spec.report.template else None
    check_templates(template_folders(user_templates))  # before any work: a template the run could not use is said first
    with output_set(out_dir, inputs + ([user_templates] if user_templates else []), force) as publish:
        return _run(loaded, inputs, user_templates, Path(out_dir), pdf, publish, earlier)


def _run(loaded, inputs: list[Path], user_templates: Path | None, out_dir: Path, pdf: bool, publish, earlier: list[tuple[str, Results]]) -> Outcome:
    """The stages in order, then the whole output set published at once."""
    spec = loaded.spec
    folder = loaded.path.parent
    calibration_path = folder / spec.data.calibration
    validation_path = folder / spec.data.validation if spec.data.validation else None
    kinematics = compile_robot(spec.robot.chain())
    with stage("reading the data"):
        raw = read_measurements(calibration_path, spec)
        device = fitted_device(spec, raw)
        calibration = device.prepare(raw)
        validation = device.prepare(read_measurements(validation_path, spec)) if validation_path else None
        for data in filter(None, (calibration, validation)):
            check_readable(device, data)
        check_stations(device, calibration)
        truth = find_truth(calibration_path)  # the inputs all read, and a record that is not one refused, before the work
        simulated = (truth is not None, validation_path is not None and find_truth(validation_path) is not None)
    with stage("identifying the robot and diagnosing the residuals"):
        calibrated = identify_and_diagnose(spec, kinematics, device, raw, calibration, validation)
    identifier = run_id(inputs + ([calibration_path.parent / "truth.json"] if truth else []))
    with stage("evaluating the tasks (grid, ISO 9283 cube)"):
        tasks = evaluation_tasks(spec, kinematics, calibrated, truth)
    with stage("drawing the evidence"):
        found = evidence(loaded, kinematics, device, calibrated, calibration)
        plots = {name: stamp_svg(svg, identifier) for name, svg in draw_plots(Evidence.model_validate(found), certificate_unit(spec)).items()}
    step = (spec.simulate or Simulate()).time_step
    warnings = [w for w in (
        simulated_times(calibration_path, raw.extras.get("t"), step, truth),
        simulated_times(validation_path, validation.extras.get("t"), step, None if not simulated[1] else {}) if validation is not None else None,
    ) if w] + placeholder_notes(loaded) + residual_model_note(spec, calibrated)
    measured = campaign(loaded, calibration, validation, simulated)
    figures = run_figures(loaded, calibrated, device, calibration.rows, tasks, found, list(plots), measured)
    results = build_results(loaded, figures, run_id=identifier, warnings=warnings,
                            simulated={"calibration": simulated[0], "validation": simulated[1] if validation_path else None})
    results = results.model_copy(update={"history": history_entries(results, earlier)})
    calibrated_spec, left_out = calibrated_text(loaded, results, calibrated, out_dir)
    if left_out is not None:
        results = in_results_only(results, left_out)
    with stage("writing the certificate" + (" (PDF)" if pdf else "")):
        files = {
            "results.json": json.dumps(results.model_dump(mode="json"), indent=2) + "\n",
            "calibrated.yaml": calibrated_spec,
            "residuals.csv": residuals_csv(calibrated, calibration.rows, validation.rows if validation is not None else None, spec.robot.units),
            **plots,
            **certificate_files(results, plots, pdf, user_templates),
        }
    publish(files, identifier)  # only now, all at once: a failure above leaves the previous set as it was
    return Outcome(results, out_dir)


def in_results_only(results: Results, why: str) -> Results:
    """``results`` whose accepted learned model calibrated.yaml does not hold (``why``: calibrated_text): where it is
    carried, and a warning, say so."""
    carried = IN_RESULTS_ONLY.format(why=why)
    warning = f"the learned residual model the run accepted is not in calibrated.yaml ({why}): export and compensate the run's folder, which read results.json's"
    return results.model_copy(update={"residual_model": results.residual_model.model_copy(update={"carried": carried}),
                                      "warnings": [*results.warnings, warning]})


def residual_model_note(spec, calibrated) -> list[str]:
    """The learned residual model the spec asks for was not judged (it is judged on the diagnosis' folds); the one a
    spec stores (residual_model, an earlier run's) is not this run's: it learns its own, never mixed with it."""
    notes = []
    if spec.residual_model is not None:
        notes.append("the spec's residual_model (an earlier run's learned model) is not used: this run's model is its physical fit"
                     + (" and the learned model it judges itself" if spec.diagnose.residual_model == "gp" else "")
                     + "; calibrated.yaml holds this run's accepted model only")
    if spec.diagnose.residual_model == "gp" and calibrated.residual is None:
        notes.append("diagnose.residual_model: gp was not run: it is judged on the diagnosis' k-fold folds, and no diagnosis ran "
                     "(diagnose.enabled false, diagnose.max_rounds 0, or fit.method other than least_squares)")
    return notes


def check_readable(device, data) -> None:
    """Readings the instrument could not have produced are a user error, named by file, line and column."""
    problems = device.unreadable(data)
    if problems:
        raise SpecError([Issue(data.source, line, None, column, message) for line, column, message in problems[:20]])


def check_stations(device, calibration) -> None:
    """Every station the calibration data name has its frame in the spec (held-out data may name new ones), and every
    declared one has calibration readings (else its frame would be the spec's guess, never fitted)."""
    declared = device.stations()
    named = {device.station(key) for key in calibration.keys}
    unseen = [name for name in declared if name not in named]
    if unseen:
        raise SpecError([Issue(calibration.source, None, None, "station",
                               f"device.stations declares {', '.join(shown_value(n) for n in unseen[:20])}, but no reading "
                               "here is at it: its frame could not be fitted; remove it from device.stations (held-out "
                               "data re-register a station the spec does not declare, from their rows marked use: register)")])
    problems = [(int(line), name) for key, line in zip(calibration.keys, calibration.rows)
                if (name := device.station(key)) is not None and name not in declared]
    if problems:
        known = ", ".join(declared) or "none"
        raise SpecError([Issue(calibration.source, line, None, "station",
                               f"station {shown_value(name)} is not one of device.stations (the spec's: {known}); declare it there "
                               "(only held-out data may name new stations, re-registered from their rows marked use: register)")
                         for line, name in problems[:20]])


def fitted_device(spec, raw):
    """The spec's instrument as it fits the calibration data's readings ``raw`` (a sonic digitizer's triangulated
    points when that is all the file has, else as the spec says)."""
    return device_model(spec, readings_mode(spec, list(raw.readings)))
