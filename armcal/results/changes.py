"""Parameter changes between two calibrations of one robot, in units of their combined uncertainty.

A parameter is compared only where both calibrations identified it (in the base set, with an uncertainty): one
that either side held (in the spec, or as redundant with another: two campaigns of one robot may carry a redundant
pair's sum on different members) or does not have is "not comparable", with the side and the reason, and is never
given a z: its value there is a convention, not a measurement. For each compared parameter the change
d = new - old is put in units of its combined standard uncertainty u = sqrt(u_old^2 + u_new^2) (the two
calibrations independent: separate campaigns), z = d / u, with its two-sided p-value; the changes are flagged
significant by Holm's step-down test (Holm 1979, "A simple sequentially rejective multiple test procedure") at a
family-wise ALPHA over every parameter compared, so that among forty unchanged parameters none is flagged by chance
more often than ALPHA of the time. Values given in other units (mm and m, deg and rad) are converted to the later
calibration's. Used by ``armcal compare`` and the certificate's history.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Protocol

from scipy.special import ndtr  # the normal distribution function (scipy.stats.norm.sf's own); scipy.stats imports slowly

from armcal.support.errors import UserError, shown_text
from armcal.evaluate.multiple_testing import ALPHA, holm
from armcal.results.schema import Results
from armcal.support.units import ANGLE_UNITS, LENGTH_UNITS


def check_same_robot(serial: str, other_serial: str, shown: str, other: str) -> None:
    """A UserError naming ``shown`` when two calibrations are of different serials."""
    if serial != other_serial:
        raise UserError(f"{shown}: serial {shown_text(serial, 'one')} is not {shown_text(other_serial, 'one')} of {other}: the calibrations compared must be of one robot")


@dataclass(frozen=True)
class Change:
    name: str
    unit: str
    old: float | None  # None: absent on that side
    new: float | None
    z: float | None  # None where the parameter is not comparable
    significant: bool = False
    not_comparable: str | None = None  # which side did not identify it, and why


class Row(Protocol):
    """A parameter of one calibration: results.json's ParameterResult, or a calibrated spec's (results/compare.py)."""

    name: str
    unit: str
    value: float
    std: float | None
    free: bool


def _unidentified(row: Row | None, reasons: dict[str, str]) -> str | None:
    """Why one side's row is not an identified value with an uncertainty (None when it is)."""
    if row is None:
        return "absent"
    if not row.free:
        return reasons.get(row.name, "held")
    return None if row.std is not None else "not identified (no std)"


def _in_unit(row: Row, unit: str) -> tuple[float, float | None]:
    """A parameter row's value and std in ``unit`` (the later calibration's: a spec may have changed its units)."""
    if row.unit == unit:
        return row.value, row.std
    scales = next((table for table in (LENGTH_UNITS, ANGLE_UNITS) if row.unit in table and unit in table), None)
    if scales is None:
        raise UserError(f"{row.name}: one calibration gives it in {row.unit}, the other in {unit}; they cannot be compared")
    scale = scales[row.unit] / scales[unit]
    return row.value * scale, None if row.std is None else row.std * scale


@dataclass(frozen=True)
class Basis:
    """What a calibration's base set says about its parameters: why each held one was held (identifiability.fixed)
    and which identified ones move together (results.json's correlations above 0.95)."""

    reasons: dict[str, str]
    correlated: tuple[tuple[str, str, float], ...] = ()

    def partners(self, name: str) -> set[str]:
        """The parameters ``name`` shares a redundancy with here: those its held reason names ("redundant with A, B"),
        and those an identified ``name`` is correlated with."""
        reason = self.reasons.get(name, "").removeprefix(NEARLY)
        named = reason.removeprefix(REDUNDANT).split(" at the design point")[0].split(" (new part")[0].split(", ") if reason.startswith(REDUNDANT) else []
        return {*named, *(b if a == name else a for a, b, _ in self.correlated if name in (a, b))}


REDUNDANT = "redundant with "  # identify/identifiability.py's reason for a parameter the base set holds
NEARLY = "weakly identifiable: nearly "  # its start for an effect parameter held as nearly redundant (extend)
NO_BASIS = Basis({})  # a calibrated spec: its base set is not written


def basis(results: Results) -> Basis:
    """The Basis of a run's results.json."""
    return Basis({f.name: f.reason for f in results.identifiability.fixed}, tuple(map(tuple, results.correlations)))


def changes(old: list[Row], new: list[Row], old_basis: Basis = NO_BASIS, new_basis: Basis = NO_BASIS) -> list[Change]:
    """Every parameter either calibration identified: with its change in combined standard uncertainties where both
    did, the significant ones flagged by Holm's test at family-wise ALPHA; else "not comparable" and why.

    Where one side identified a parameter the other held, the two base sets carry that redundancy on different
    members, and the values of its partners (Basis.partners, on either side) mean different things too: they are
    not comparable either."""
    before, after = {p.name: p for p in old}, {p.name: p for p in new}
    names = [name for name in [*after, *(n for n in before if n not in after)] if any(r is not None and r.free for r in (after.get(name), before.get(name)))]
    unidentified = {name: [f"{side}: {reason}" for side, reason in (("old", _unidentified(before.get(name), old_basis.reasons)),
                                                                    ("new", _unidentified(after.get(name), new_basis.reasons))) if reason]
                    for name in names}
    moved = {}  # partner -> the swapped parameter whose redundancy it shares
    for name in (n for n in names if len(unidentified[n]) == 1 and n in before and n in after):
        for partner in sorted(old_basis.partners(name) | new_basis.partners(name)):
            moved.setdefault(partner, name)
    rows = []
    for name in names:
        p, q = after.get(name), before.get(name)
        unit = (p or q).unit
        old_value, old_std = _in_unit(q, unit) if q is not None else (None, None)
        why = unidentified[name] or ([f"carries a redundancy with {moved[name]}, which one side holds and the other identifies"] if name in moved else [])
        spread = 0.0 if why else math.hypot(p.std, old_std)
        if not why and spread == 0:
            why = ["no uncertainty on either side"]
        rows.append(Change(name, unit, old_value, p and p.value, None if why else (p.value - old_value) / spread,
                           not_comparable="; ".join(why) or None))
    tested = [i for i, c in enumerate(rows) if c.z is not None]
    for i, rejected in zip(tested, holm([2.0 * ndtr(-abs(rows[i].z)) for i in tested])):
        rows[i] = replace(rows[i], significant=rejected)
    return rows
