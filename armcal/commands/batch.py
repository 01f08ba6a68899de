"""``armcal batch``: calibrate a fleet, one spec and one certificate each, on a process pool or a Dask cluster.

Each spec runs the whole pipeline (pipeline.run) in a worker; a spec with a user
error, or one that meets an internal error (its traceback kept as its log), is
reported and the others go on. The outcome of each is plain data, so it crosses
process and machine boundaries; all of them are written to a fleet summary
(JSON, and the terminal's table as text).
"""

from __future__ import annotations

import json
import traceback
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from armcal.support.errors import UserError, shown_text
from armcal.support.fileio import output_folder, write_text_atomic
from armcal.commands.run import default_out_dir, run
from armcal.commands.workers import check_workers, run_tasks


INTERNAL = 4  # exit code of a fleet in which a spec met an internal error


@dataclass(frozen=True)
class Job:
    spec: Path
    out_dir: Path
    force: bool
    pdf: bool


def run_job(job: Job) -> dict:
    """One spec through the pipeline (a worker's task); its outcome as plain data."""
    try:
        outcome = run(job.spec, job.out_dir, job.force, job.pdf)
    except UserError as exc:
        return {"spec": str(job.spec), "status": "error", "exit_code": 1, "error": str(exc)}
    except Exception as exc:  # one robot's internal error must not cost the fleet its other results
        error = f"internal error: {type(exc).__name__}: {exc}"
        return {"spec": str(job.spec), "status": "internal_error", "exit_code": INTERNAL, "error": error, "log": traceback.format_exc()}
    results = outcome.results
    validation = results.residuals.validation
    return {
        "spec": str(job.spec),
        "status": results.status,
        "exit_code": outcome.exit_code,
        "robot": f"{shown_text(results.robot.name, 'a name')} ({shown_text(results.robot.serial, 'a serial')})",
        "unit": results.device.unit,
        "calibration_rms": [results.residuals.calibration.before.rms, results.residuals.calibration.after.rms],
        "validation_rms": [validation.before.rms, validation.after.rms] if validation else None,
        "noise_verdict": results.noise_check.verdict,
        "unexplained": results.diagnosis.unexplained,
        "out_dir": str(outcome.out_dir),
    }


def fleet_folder_name(spec: Path) -> str:
    """A spec's subfolder of ``--out``, from its own path alone: <folder>-<stem>, e.g. examples/theodolite/spec.yaml
    -> theodolite-spec (specs are often all called spec.yaml, one folder each)."""
    return f"{spec.parent.name}-{spec.stem}"


def jobs(specs: list[Path], out_dir: Path | None, force: bool, pdf: bool) -> list[Job]:
    """One job per spec, paths absolute (workers may run elsewhere); with ``out_dir`` each writes to
    out_dir/<folder>-<stem> (fleet_folder_name), else to the spec's default folder."""
    for spec in map(Path, specs):
        try:
            why = None if spec.is_file() else "it is a folder" if spec.is_dir() else "it is not a regular file" if spec.exists() else "there is no such file"
        except OSError as exc:  # a name too long, a loop of links
            why = exc.strerror or str(exc)
        if why:
            raise UserError(f"{spec}: cannot read the spec file: {why}")
    paths = [Path(spec).resolve() for spec in specs]
    if out_dir is None:
        folders = [default_out_dir(path) for path in paths]
    else:
        folders = [Path(out_dir) / fleet_folder_name(path) for path in paths]
    folders = [output_folder(folder.resolve()) for folder in folders]
    repeated = [folder for folder, count in Counter(folders).items() if count > 1]
    if repeated:
        raise UserError(f"two specs would write to {repeated[0]}; give each spec its own name or folder")
    return [Job(path, folder, force, pdf) for path, folder in zip(paths, folders)]


def batch(
    specs: list[Path],
    out_dir: Path | None = None,
    force: bool = False,
    pdf: bool = True,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> list[dict]:
    """Every spec's outcome, in the order given."""
    check_workers(workers)
    planned = jobs(specs, out_dir, force, pdf)
    done = [0]

    def finished(_) -> None:
        done[0] += 1
        if progress:
            progress(done[0], len(planned))

    return run_tasks(run_job, planned, scheduler, workers, finished)


def exit_code(outcomes: list[dict]) -> int:
    """4 if any spec met an internal error, else 1 if any had a user error, else 3 if any fit did not converge, else 0."""
    codes = {outcome["exit_code"] for outcome in outcomes}
    return next((code for code in (INTERNAL, 1, 3) if code in codes), 0)


def summary_files(out_dir: Path | None) -> list[Path]:
    """fleet.json and fleet.txt, in --out or else in the current folder."""
    path = Path(out_dir or ".") / "fleet.json"
    return [path, path.with_suffix(".txt")]


def write_summary(files: list[Path], outcomes: list[dict], table: str) -> None:
    """fleet.json (every outcome, internal errors with their log) and fleet.txt (the table), each whole."""
    json_path, text_path = files
    write_text_atomic(json_path, json.dumps({"specs": len(outcomes), "exit_code": exit_code(outcomes), "outcomes": outcomes}, indent=1) + "\n")
    write_text_atomic(text_path, table + "\n")
