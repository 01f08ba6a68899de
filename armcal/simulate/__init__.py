"""Simulated campaigns: a true robot from the manufacturing-error model, hidden effects, instrument noise."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from armcal.dataio.writer import write_measurements
from armcal.errors import UserError
from armcal.fileio import read_input, refuse_replacing, write_text_atomic
from armcal.simulate.campaign import Campaign, simulate_campaign
from armcal.spec import LoadedSpec


def data_file_names(loaded: LoadedSpec) -> tuple[str, str]:
    """The calibration and validation file names the spec's data section expects."""
    data = loaded.spec.data
    if data is None:
        return "calibration.csv", "validation.csv"
    return Path(data.calibration).name, Path(data.validation or "validation.csv").name


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
    truth = {"spec_sha256": loaded.sha256, "data_sha256": data, "dropped_poses": campaign.dropped, **campaign.truth}
    truth_path = Path(out_dir) / "truth.json"
    write_text_atomic(truth_path, json.dumps(truth, indent=1, sort_keys=True) + "\n")
    return campaign, [*written, truth_path]


def find_truth(data_file: Path) -> dict | None:
    """The truth.json that ``armcal simulate`` wrote beside a data file, if these very data came from it."""
    record_path = Path(data_file).parent / "truth.json"
    if not record_path.exists():
        return None
    try:
        record = json.loads(read_input(record_path, "truth"))
    except (ValueError, RecursionError):
        record = None
    if not isinstance(record, dict) or not isinstance(record.get("data_sha256"), dict):
        raise UserError(f"{record_path}: not a truth record written by armcal simulate; remove it or simulate the data again")
    digest = hashlib.sha256(read_input(data_file, "data")).hexdigest()
    return record if record["data_sha256"].get(Path(data_file).name) == digest else None


__all__ = ["Campaign", "find_truth", "simulate_campaign", "write_simulation"]
