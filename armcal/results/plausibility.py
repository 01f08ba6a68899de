"""Is every identified robot value plausible? Its deviation from nominal against a tolerance per kind (issue 29).

A fit can end `converged` with a length 1.8 m from its drawing value and a std of 0.05 mm: the data determined a
combination, the rounding or a flat direction chose the rest. Every identified robot value (base, links, joints,
tool, targets: kinematics/params.parameter_set gives them their tolerance) is compared with its nominal value: a length beyond
`robot.tolerance.length` (default 10 mm) or an angle beyond `robot.tolerance.angle` (default 2 deg, the difference
taken the short way round) is implausible, and the terminal, results.json and the certificate say so, with why:
a value many of its stds from nominal was put there by the data (check the nominal value: the drawing, the
robot library, an earlier calibration); one whose std is itself of the tolerance's size was chosen by a flat
direction. Encoder scales (kind 1) are judged against `robot.tolerance.scale` (default 0.01); the instrument's
parameters are not judged.
"""

from __future__ import annotations

import math

import numpy as np

from armcal.spec.document import Spec
from armcal.support.units import from_internal

JUDGED = ("length", "angle", "scale")
DETERMINED = 5.0  # deviation over std beyond which the data, not a flat direction, put the value there
WHY = {
    "nominal": "the data put it there (many stds from nominal): check the nominal value",
    "undetermined": "poorly determined: a flat direction chose it, not the data",
}


def status_words(status: str, plausibility) -> str:
    """'converged', or 'converged; implausible values' (a fit that did not converge says that alone: its values are
    no estimate to judge). ``plausibility``: results.json's Plausibility, or None."""
    found = plausibility is not None and plausibility.implausible
    return status + ("; implausible values" if status == "converged" and found else "")


def plausibility(spec: Spec, entries, values: np.ndarray, std: np.ndarray, identified: set[str]) -> dict:
    """results.json's `plausibility`: the tolerances in the spec's units (and whether the spec gave them) and the
    identified robot values beyond them."""
    tolerance = spec.robot.plausible_deviations
    limit = {"length": tolerance.length, "angle": tolerance.angle, "scale": tolerance.scale}
    unit = {kind: spec.robot.units.of(kind) for kind in JUDGED}
    shown = lambda value, kind: from_internal(float(value), kind, unit[kind])  # noqa: E731
    implausible = []
    for entry, value, sd in zip(entries, values, std):
        if entry.name not in identified or entry.tolerance is None:
            continue
        deviation = float(value - entry.nominal)
        if entry.kind == "angle":
            deviation = math.remainder(deviation, 2 * math.pi)
        if abs(deviation) > entry.tolerance:
            implausible.append(
                {
                    "name": entry.name,
                    "unit": unit[entry.kind],
                    "nominal": shown(entry.nominal, entry.kind),
                    "value": shown(value, entry.kind),
                    "deviation": shown(deviation, entry.kind),
                    "tolerance": shown(entry.tolerance, entry.kind),
                    "std": None if math.isnan(sd) else shown(sd, entry.kind),
                    "why": "nominal" if not math.isnan(sd) and abs(deviation) > DETERMINED * sd else "undetermined",
                }
            )
    return {
        "length": shown(limit["length"], "length"),
        "length_unit": unit["length"],
        "angle": shown(limit["angle"], "angle"),
        "angle_unit": unit["angle"],
        "scale": limit["scale"],
        "from_spec": spec.robot.tolerance is not None,
        "implausible": implausible,
    }
