"""Measured (or simulated) samples in memory, internal units (mm, rad)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from armcal.devices.base import Key


@dataclass(frozen=True)
class Measurements:
    """One data file: per sample its key, joint readings, device readings and extra columns.

    ``readings`` maps a channel (CSV column such as ``length`` or ``s_A``) to an
    (N,) array, NaN where a sample has no such reading. ``extras`` holds the
    optional columns (``t``, ``temperature``, ``dir`` (N, n), calibration-rod
    ranges). ``rows`` are the file's line numbers, so results can point back to
    the data. ``register`` marks held-out samples that only re-register their
    station's frame (a tracker's ``use`` column: register); None: no such column.
    """

    keys: tuple[Key, ...]
    q: np.ndarray
    readings: dict[str, np.ndarray]
    extras: dict[str, np.ndarray] = field(default_factory=dict)
    rows: np.ndarray | None = None
    source: Path | None = None
    sample: tuple[str, ...] | None = None
    register: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.keys)

    @property
    def origin(self) -> str:
        """What a message names the data by: its file, or a simulated campaign's readings, which no file holds."""
        return str(self.source) if self.source is not None else "the simulated readings"

    def subset(self, rows: np.ndarray) -> "Measurements":
        """The samples at ``rows`` (indices), every column kept."""
        pick = lambda array: None if array is None else np.asarray(array)[rows]  # noqa: E731
        return Measurements(
            keys=tuple(self.keys[i] for i in rows),
            q=self.q[rows],
            readings={k: v[rows] for k, v in self.readings.items()},
            extras={k: v[rows] for k, v in self.extras.items()},
            rows=pick(self.rows),
            source=self.source,
            sample=None if self.sample is None else tuple(self.sample[i] for i in rows),
            register=pick(self.register),
        )

    def groups(self) -> dict[Key, np.ndarray]:
        """Sample indices of each key, in order of first appearance."""
        out: dict[Key, list[int]] = {}
        for i, key in enumerate(self.keys):
            out.setdefault(key, []).append(i)
        return {key: np.array(rows) for key, rows in out.items()}
