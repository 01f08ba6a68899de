"""``armcal batch``: calibrate a fleet, one spec and one certificate each, on a process pool or a Dask cluster.

Each spec runs the whole pipeline (pipeline.run) in a worker; a spec with a user
error is reported and the others go on. The outcome of each is plain data, so
it crosses process and machine boundaries.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from armcal.errors import UserError
from armcal.fileio import output_folder
from armcal.parallel import run_tasks
from armcal.pipeline import default_out_dir, run


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
    results = outcome.results
    validation = results.residuals.validation
    return {
        "spec": str(job.spec),
        "status": results.status,
        "exit_code": outcome.exit_code,
        "robot": f"{results.robot.name} ({results.robot.serial})",
        "unit": results.device.unit,
        "calibration_rms": [results.residuals.calibration.before.rms, results.residuals.calibration.after.rms],
        "validation_rms": [validation.before.rms, validation.after.rms] if validation else None,
        "out_dir": str(outcome.out_dir),
    }


def jobs(specs: list[Path], out_dir: Path | None, force: bool, pdf: bool) -> list[Job]:
    """One job per spec, paths absolute (workers may run elsewhere); with ``out_dir`` each writes to
    out_dir/<spec stem> (or <folder>-<stem> where stems repeat), else to the spec's default folder."""
    missing = [spec for spec in specs if not Path(spec).is_file()]
    if missing:
        raise UserError(f"{missing[0]}: no such spec file")
    paths = [Path(spec).resolve() for spec in specs]
    if out_dir is None:
        folders = [default_out_dir(path) for path in paths]
    else:
        stems = Counter(path.stem for path in paths)
        folders = [Path(out_dir) / (p.stem if stems[p.stem] == 1 else f"{p.parent.name}-{p.stem}") for p in paths]
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
    planned = jobs(specs, out_dir, force, pdf)
    done = [0]

    def finished(_) -> None:
        done[0] += 1
        if progress:
            progress(done[0], len(planned))

    return run_tasks(run_job, planned, scheduler, workers, finished)


def exit_code(outcomes: list[dict]) -> int:
    """1 if any spec had a user error, else 3 if any fit did not converge, else 0."""
    codes = {outcome["exit_code"] for outcome in outcomes}
    return 1 if 1 in codes else 3 if 3 in codes else 0
