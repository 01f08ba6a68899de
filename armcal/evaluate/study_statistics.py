"""Statistics of a Monte-Carlo study: each grid index's mean and spread, and trends along a sweep.

Stone reports the mean and standard deviation of each of the 34 indices over
the robots (7.2.1) and reads the trends of the standard deviations off his
plots (7.4.1-7.4.5). Here a trend is the least-squares slope of log(std) on
log(value) per index; its median over the indices (over the 24 length and the
10 angle indices apart, over the 7 orientation indices - the angles less the three
perpendicularities, which are made of positions - and the mean slope of the four
vertex radial errors, his Figures 7-4 to 7-8) is compared with his finding.
"""

from __future__ import annotations

import numpy as np

from armcal.evaluate.grid import RADIAL, index_kind
from armcal.evaluate.sweeps import VARIABLES, Sweep
from armcal.support.units import from_internal



def index_statistics(names: list[str], design: np.ndarray, calibrated: np.ndarray, units) -> list[dict]:
    """Mean and standard deviation (ddof 1) of each index over the robots, in the spec's units."""
    rows = []
    for i, name in enumerate(names):
        kind = index_kind(name)
        unit = units.of(kind)
        shown = lambda values: {"mean": from_internal(float(values.mean()), kind, unit), "std": from_internal(float(values.std(ddof=1)), kind, unit)}  # noqa: E731
        rows.append({"index": name, "unit": unit, "design": shown(design[:, i]), "calibrated": shown(calibrated[:, i])})
    return rows


def trend(sweep: Sweep, points: list[list[dict]]) -> dict:
    """Slopes of log(std) against log(value) of the sweep's controller, per index and their median."""
    variable = VARIABLES[sweep.variable]
    x = np.log(np.asarray(sweep.values))
    slopes = {}
    for i, row in enumerate(points[0]):
        spread = np.array([point[i][variable.controller]["std"] for point in points])
        if (spread > 0).all():
            slopes[row["index"]] = float(np.polyfit(x, np.log(spread), 1)[0])
    return {
        "variable": sweep.variable,
        "controller": variable.controller,
        "expected_slope": variable.expected_slope,
        "source": variable.source,
        "median_slope": _median(list(slopes.values())),
        "length_slope": _median([v for name, v in slopes.items() if index_kind(name) == "length"]),
        "angle_slope": _median([v for name, v in slopes.items() if index_kind(name) == "angle"]),
        "orientation_slope": _median([v for name, v in slopes.items() if "orientation" in name]),
        "radial_slope": float(np.mean([slopes[name] for name in RADIAL])) if all(name in slopes for name in RADIAL) else None,
        "slopes": slopes,
    }


def _median(values: list[float]) -> float | None:
    """None when no index spreads at all (nothing to fit a slope to)."""
    return float(np.median(values)) if values else None
