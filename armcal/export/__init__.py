"""Calibrations out of armcal: the calibrated chain in the formats other tools read (docs/export.md).

The source is a calibrated spec (a run's calibrated.yaml, or any spec: its values are
the model) or a run's output folder (its calibrated.yaml, with results.json's
uncertainties for the json format). Effects a kinematic format cannot hold are listed in
the export and returned, so that the command says so.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from armcal.support.errors import UserError
from armcal.export.dh_table import dh_table
from armcal.export.parameters import learned_section, parameters_json
from armcal.export.ur_calibration import ur_calibration
from armcal.export.urdf import urdf
from armcal.kinematics.compiler import compile_robot
from armcal.results.reader import read_results
from armcal.results.schema import Results
from armcal.spec import LoadedSpec, load_spec

FORMATS = ("urdf", "ur-calibration", "dh-table", "json")


@dataclass(frozen=True)
class Export:
    text: str
    left_out: tuple[str, ...]  # effects (and joint scales) the format cannot hold
    learned: str | None = None  # what the terminal says of the run's learned residual model (learned_model)


def learned_model(loaded: LoadedSpec, results: Results | None, fmt: str | None = None) -> str | None:
    """What to say of the learned residual model (diagnose.residual_model): ``export --format json`` carries an
    accepted one (calibrated.yaml's residual_model section, or results.json's), the other formats do not; a spec that
    asks for one and holds none carries none. None when there is nothing to say."""
    if learned_section(loaded, results) is not None:
        if fmt == "json":
            return "the learned residual model that the run accepted is carried: residual_model (training inputs and hyperparameters)"
        return "the learned residual model that the run accepted is not carried (only the physical model is): see calibrated.yaml residual_model"
    if results is None and loaded.spec.diagnose.residual_model == "gp":
        return ("the spec asks for a learned residual model (diagnose.residual_model: gp) and holds none (a run's calibrated.yaml holds "
                "the one it accepted, or says it is in the run's results.json only: then give the run's folder): only the physical model is carried")
    return None


def calibration_source(path: Path) -> tuple[LoadedSpec, Results | None]:
    """The calibrated spec of ``path`` (a spec, or a run's folder) and the run's results.json if there is one."""
    if path.is_dir():
        spec = path / "calibrated.yaml"
        if not spec.exists():
            raise UserError(f"{path}: not a run's output folder (no calibrated.yaml); give a calibrated spec or a run's folder")
        results = read_results(path / "results.json") if (path / "results.json").exists() else None
        return load_spec(spec), results
    return load_spec(path), None


def export(path: Path, fmt: str) -> Export:
    """The calibration of ``path`` in format ``fmt`` (FORMATS)."""
    if fmt not in FORMATS:
        raise UserError(f"unknown format '{fmt}': choose one of {', '.join(FORMATS)}")
    loaded, results = calibration_source(path)
    spec = loaded.spec
    effects = tuple(f"{e.type}" + (f" (joint {e.joint})" if getattr(e, "joint", None) else "") for e in spec.effects)
    learned = learned_model(loaded, results, fmt)
    if fmt == "json":
        return Export(parameters_json(loaded, results), (), learned)
    if fmt == "urdf":
        text, scaled = urdf(spec, compile_robot(spec.robot.chain()), effects)
        return Export(text, effects + scaled, learned)
    if fmt == "ur-calibration":
        return Export(*ur_calibration(loaded, effects), learned)
    return Export(dh_table(loaded, effects), effects, learned)
