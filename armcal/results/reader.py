"""Reading results.json: the file a user names, bounded and checked against the Results model; earlier results of one robot."""

from __future__ import annotations

import json
from pathlib import Path

from pydantic import ValidationError

from armcal.support.errors import UserError, shown_key
from armcal.support.fileio import MiB, decoded, read_regular
from armcal.results.changes import check_same_robot
from armcal.results.schema import Results

RESULTS_LIMIT = 16 * MiB  # results.json (armcal's own are well below 1 MiB)


def results_file(path: Path) -> Path:
    """The results.json a user names: the file itself, or the one in a run's output folder."""
    return path / "results.json" if path.is_dir() else path


def read_results(path: Path) -> Results:
    """A results.json as armcal writes it, as the Results model (validated here, once), else one UserError naming the file."""
    data = read_regular(path, RESULTS_LIMIT, path)
    if data is None:
        raise UserError(f"{path}: cannot read results (no such file)")
    try:
        raw = json.loads(decoded(data, path))
    except ValueError:
        raise UserError(f"{path}: expected the results.json that armcal run writes (or its output folder), but this file is not JSON") from None
    except RecursionError:
        raise UserError(f"{path}: cannot read results (nested too deeply)") from None
    try:
        return Results.model_validate(raw)
    except ValidationError as exc:
        problems = [f"{'.'.join(map(shown_key, e['loc'])) or 'the top level'}: {e['msg']}" for e in exc.errors()]
        more = f" (and {len(problems) - 3} more)" if len(problems) > 3 else ""
        raise UserError(f"{path}: not a results.json as armcal writes it: {'; '.join(problems[:3])}{more}") from None


def read_earlier(paths: list[Path], serial: str, current: str) -> list[tuple[str, Results]]:
    """Earlier results (each a results.json or a run's folder, read_results) of the robot ``serial``; another serial is a
    UserError naming the file. ``current`` names the run they are compared with."""
    earlier = []
    for path in paths:
        source = results_file(Path(path))
        old = read_results(source)
        check_same_robot(old.robot.serial, serial, str(source), current)
        earlier.append((str(source.resolve()), old))
    return earlier
