"""Simulated campaigns: a true robot from the manufacturing-error model, hidden effects, instrument noise."""

from __future__ import annotations

import json
from pathlib import Path

from armcal.dataio.writer import write_measurements
from armcal.fileio import write_text_atomic
from armcal.simulate.campaign import Campaign, simulate_campaign
from armcal.spec import LoadedSpec


def data_file_names(loaded: LoadedSpec) -> tuple[str, str]:
    """The calibration and validation file names the spec's data section expects."""
    data = loaded.spec.data
    if data is None:
        return "calibration.csv", "validation.csv"
    return Path(data.calibration).name, Path(data.validation or "validation.csv").name


def write_simulation(loaded: LoadedSpec, out_dir: Path) -> tuple[Campaign, list[Path]]:
    """Simulate the spec's campaign and write its CSV files and truth.json into ``out_dir``."""
    campaign = simulate_campaign(loaded.spec, loaded.path.parent)
    names = data_file_names(loaded)
    written = []
    for name, measurements in zip(names, (campaign.calibration, campaign.validation)):
        if measurements is not None:
            path = Path(out_dir) / name
            write_measurements(path, measurements, loaded.spec)
            written.append(path)
    truth = {"spec_sha256": loaded.sha256, "dropped_poses": campaign.dropped, **campaign.truth}
    truth_path = Path(out_dir) / "truth.json"
    write_text_atomic(truth_path, json.dumps(truth, indent=1, sort_keys=True) + "\n")
    return campaign, [*written, truth_path]


__all__ = ["Campaign", "simulate_campaign", "write_simulation"]
