"""Simulated campaigns: a true robot from the manufacturing-error model, hidden effects, instrument noise."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from armcal.dataio.writer import write_measurements
from armcal.support.errors import UserError
from armcal.support.fileio import read_input, refuse_replacing, write_text_atomic
from armcal.simulate.campaign import Campaign, simulate_campaign
from armcal.simulate.truth import record_problem
from armcal.spec import LoadedSpec


def data_file_names(loaded: LoadedSpec) -> tuple[str, str]:
    """The calibration and validation file names the spec's data section expects."""
    data = loaded.spec.data
    if data is None:
        return "calibration.csv", "validation.csv"
    return Path(data.calibration).name, Path(data.validation or "validation.csv").name


def data_folder(loaded: LoadedSpec) -> Path:
    """Where the spec's data section points (its calibration file's folder), or the spec's folder without one."""
    data = loaded.spec.data
    return loaded.path.parent / (Path(data.calibration).parent if data is not None else Path("."))


def write_simulation(loaded: LoadedSpec, out_dir: Path, force: bool = False) -> tuple[Campaign, list[Path]]:
    """Simulate the spec's campaign and write its CSV files and truth.json into ``out_dir``
    (replacing existing ones only with ``force``, the spec never)."""
    names = data_file_names(loaded)
    refuse_replacing([Path(out_dir) / n for n in (*names, "truth.json")], [loaded.path], force)
    campaign = simulate_campaign(loaded.spec, loaded.path.parent)
    written = []
    for name, measurements in zip(names, (campaign.calibration, campaign.validation)):
        if measurements is not None:
            path = Path(out_dir) / name
            write_measurements(path, measurements, loaded.spec)
            written.append(path)
    data = {path.name: hashlib.sha256(path.read_bytes()).hexdigest() for path in written}
    truth = json.loads(json.dumps({"spec_sha256": loaded.sha256, "data_sha256": data, "dropped_poses": campaign.dropped, **campaign.truth}))
    truth_path = Path(out_dir) / "truth.json"
    write_text_atomic(truth_path, json.dumps({**truth, RECORD_DIGEST: record_digest(truth)}, indent=1, sort_keys=True) + "\n")
    return campaign, [*written, truth_path]


RECORD_DIGEST = "record_sha256"  # truth.json's digest of its own content: record_digest of the rest


def record_digest(record: dict) -> str:
    """SHA-256 (hex) of a truth record without its RECORD_DIGEST field, as canonical JSON: keys sorted, no spaces,
    ASCII, numbers as Python writes them (so the file's layout does not count, any changed value does)."""
    rest = {key: value for key, value in record.items() if key != RECORD_DIGEST}
    text = json.dumps(rest, sort_keys=True, separators=(",", ":"), ensure_ascii=True, allow_nan=False)
    return hashlib.sha256(text.encode("ascii")).hexdigest()


def find_truth(data_file: Path) -> dict | None:
    """The truth.json that ``armcal simulate`` wrote beside a data file, if these very data came from it: the
    record's own digest must match its content (an edited value is refused), its data hashes the file's."""
    record_path = Path(data_file).parent / "truth.json"
    if not record_path.exists():
        return None
    try:
        record = json.loads(read_input(record_path, "truth"))
    except (ValueError, RecursionError):
        record = None
    problem = "it is not a JSON mapping with data_sha256" if not isinstance(record, dict) or not isinstance(record.get("data_sha256"), dict) else _digest_problem(record) or record_problem(record)
    if problem:
        raise UserError(f"{record_path}: not a truth record written by armcal simulate ({problem}); remove it or simulate the data again")
    digest = hashlib.sha256(read_input(data_file, "data")).hexdigest()
    return record if record["data_sha256"].get(Path(data_file).name) == digest else None


def _digest_problem(record: dict) -> str | None:
    """What is wrong with a record's own digest (None when it matches its content)."""
    if RECORD_DIGEST not in record:
        return f"it carries no {RECORD_DIGEST}: written before armcal checked its records, or the digest was removed"
    try:
        matches = record[RECORD_DIGEST] == record_digest(record)
    except (TypeError, ValueError, RecursionError):  # e.g. NaN, which armcal never writes
        matches = False
    return None if matches else f"its content does not match its {RECORD_DIGEST}: a value was changed after armcal simulate wrote it"


def simulated_times(data_file: Path, t: np.ndarray | None, time_step: float, truth: dict | None) -> str | None:
    """A warning when a data file not written by ``armcal simulate`` (or changed since) still has the simulator's t
    column: 0, 10, 20, ... s (``simulate.time_step`` apart, from 0 or from where the calibration file ended). Such
    times are not the readings' and would feed the drift test (thermal_drift, source: time) and the plots."""
    if truth is not None or t is None or len(t) < 3 or time_step <= 0 or np.isnan(t).any():
        return None
    steps = np.diff(t)
    if not (np.allclose(steps, time_step, rtol=0, atol=1e-9) and abs(t[0] / time_step - round(t[0] / time_step)) < 1e-9):
        return None
    record = Path(data_file).parent / "truth.json"
    beside = f" ({record.name} beside it records other contents: the readings were changed)" if record.exists() else ""
    return (
        f"{Path(data_file).name}: its t column is {t[0]:g}, {t[1]:g}, {t[2]:g}, ... s, every {time_step:g} s, as `armcal simulate` "
        f"writes it{beside}; if these are real readings, those are not their times: they feed the drift test "
        "(thermal_drift, source: time) and the plots. Put the readings' times in t (s), or delete the column"
    )


__all__ = ["Campaign", "find_truth", "simulate_campaign", "simulated_times", "write_simulation"]
