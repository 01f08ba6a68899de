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
from armcal.parallel import run_tasks


@dataclass(frozen=True)
class Job:
    spec: Path
    out_dir: Path | None  # None: the spec's default folder
    force: bool
    pdf: bool


def run_job(job: Job) -> dict:
    """One spec through the pipeline (a worker's task); its outcome as plain data."""
    from armcal.pipeline import run

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
    """One job per spec; with ``out_dir`` each writes to out_dir/<spec stem> (or <folder>-<stem> where stems repeat)."""
    missing = [spec for spec in specs if not Path(spec).is_file()]
    if missing:
        raise UserError(f"{missing[0]}: no such spec file")
    if out_dir is None:
        return [Job(Path(spec), None, force, pdf) for spec in specs]
    stems = Counter(Path(spec).stem for spec in specs)
    names = [Path(s).stem if stems[Path(s).stem] == 1 else f"{Path(s).resolve().parent.name}-{Path(s).stem}" for s in specs]
    repeated = [name for name, count in Counter(names).items() if count > 1]
    if repeated:
        raise UserError(f"two specs would write to {Path(out_dir) / repeated[0]}; give each spec a distinct name")
    return [Job(Path(spec), Path(out_dir) / name, force, pdf) for spec, name in zip(specs, names)]


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
