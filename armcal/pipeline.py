"""run(spec): load, compile, read data, fit, evaluate, write the artifacts - the stages in order."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armcal import __version__
from armcal.dataio.reader import read_measurements
from armcal.devices import device_model
from armcal.errors import UserError
from armcal.evaluate.features import evaluation
from armcal.evaluate.grid import grid_evaluation
from armcal.evaluate.residuals import before_after, improvement, residual_unit
from armcal.fileio import write_text_atomic
from armcal.identify.methods import identify_parameters
from armcal.identify.problem import build_problem
from armcal.kinematics.compiler import compile_robot
from armcal.results.build import build_results, parameter_rows
from armcal.results.calibrated import calibrated_yaml
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


def run(spec_path: Path, out_dir: Path | None = None, force: bool = False) -> Outcome:
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
    problem = build_problem(kinematics, device, calibration)
    identified = identify_parameters(spec, problem, raw)
    validation_problem = build_problem(kinematics, device, validation) if validation else None
    truth = find_truth(calibration_path)
    grid = grid_evaluation(kinematics, kinematics.parameters.nominal, identified.theta[: problem.n_robot], TrueRobot.from_record(kinematics, truth), spec.robot.units) if truth else None
    results = _results(loaded, problem, identified, validation_problem, calibration, grid)
    _write(loaded, results, identified, problem, out_dir)
    return Outcome(results, out_dir)


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


def _results(loaded: LoadedSpec, problem, identified, validation_problem, calibration, grid: dict | None) -> Results:
    spec = loaded.spec
    device_type = spec.device.type
    kind, unit = residual_unit(device_type)
    result = identified.least_squares
    start = problem.parameters.nominal
    calibration_pair = before_after(problem, start, identified.theta, device_type)
    validation_pair = before_after(validation_problem, start, identified.theta, device_type) if validation_problem else None
    free = set(result.identifiability.base) if identified.features is None else set(_changed(problem, identified.theta))
    ident = result.identifiability
    uncertainty = result.uncertainty
    rows = calibration.rows[problem.residuals.sample[result.outliers]] if len(result.outliers) else []
    return build_results(
        loaded,
        status="converged" if identified.features is not None or result.solver.converged else "not_converged",
        unit=unit,
        identifiability={
            "n_parameters": ident.n_parameters,
            "rank": ident.rank,
            "free": list(ident.base),
            "fixed": [{"name": n, "reason": r} for n, r in ident.fixed],
            "condition_number": ident.condition_number,
            "observability_o1": ident.observability_o1,
            "unidentifiable": list(ident.unidentifiable),
        },
        parameters=parameter_rows(loaded, problem.parameters.entries, identified.theta, identified.std, free),
        residuals={"calibration": calibration_pair, "validation": validation_pair},
        improvement_factor={
            "calibration": improvement(calibration_pair),
            "validation": improvement(validation_pair) if validation_pair else None,
        },
        diagnosis={"rounds": [], "added_effects": [], "unexplained": bool(uncertainty.scaled)},
        evaluation={**evaluation(loaded, problem, identified, validation_problem), **({"grid_task": grid} if grid else {})},
        solver={
            "method": identified.method,
            "iterations": result.solver.iterations,
            "reason": result.solver.reason if identified.features is None else (
                f"closed-form feature identification (Stone 4.3); least squares started from it: {result.solver.reason}"
            ),
            "loss": spec.fit.loss,
            "outliers": sorted(int(r) for r in set(np.asarray(rows).tolist())),
        },
        noise_check={"chi2": uncertainty.chi2, "dof": uncertainty.dof, "p_value": uncertainty.p_value, "covariance_scaled": uncertainty.scaled},
        correlations=[list(c) for c in uncertainty.correlations],
    )


def _changed(problem, theta: np.ndarray) -> list[str]:
    """Parameters a method moved from their nominal values."""
    return [e.name for e, v in zip(problem.parameters.entries, theta) if v != e.nominal]


def _write(loaded: LoadedSpec, results: Results, identified, problem, out_dir: Path) -> None:
    write_text_atomic(out_dir / "results.json", json.dumps(results.model_dump(mode="json"), indent=2) + "\n")
    kinds = {e.name: e.kind for e in problem.parameters.entries}
    values = {r.name for r in results.parameters if r.free}
    identified = {name: (float(identified.theta[problem.parameters.index(name)]), kinds[name]) for name in values}
    note = (
        f"Calibrated by armcal {__version__} on {results.created} from {loaded.path.name} "
        f"(sha256 {loaded.sha256[:12]}), status {results.status}."
    )
    text = calibrated_yaml(loaded.text, loaded.spec, identified, loaded.path, out_dir, note)
    write_text_atomic(out_dir / "calibrated.yaml", text)
