"""Score (Lagrange-multiplier) tests of candidate effects at zero, with Holm's family-wise control.

At the fitted parameters the residuals r are orthogonal to the free columns
J_b. A candidate's columns J_c are projected off them, J_c' = (I - P_b) J_c; a
column whose projection keeps under 5 % of its norm is absorbed by the geometry
("not distinguishable": the data cannot tell it from a change of the free
parameters, at any amplitude the fit would notice). The statistic S = r' P_c' r / s^2, with P_c' the projector on the
remaining columns and s^2 = r'r / (M - p), follows chi^2 with as many degrees of
freedom as columns when the effect is absent.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import chdtrc

from armcal.effects.library import EffectSpec

ABSORBED = 0.05


@dataclass(frozen=True)
class Test:
    effect: EffectSpec
    statistic: float
    dof: int
    p_value: float
    distinguishable: bool
    significant: bool = False


def score_tests(r: np.ndarray, J_free: np.ndarray, candidate_columns: list[np.ndarray], effects: list[EffectSpec]) -> list[Test]:
    """One test per candidate; ``candidate_columns[i]`` is the (M, k) Jacobian of candidate i at zero."""
    basis, _ = np.linalg.qr(J_free)
    s2 = float(r @ r) / max(len(r) - J_free.shape[1], 1)
    tests = []
    for effect, J_c in zip(effects, candidate_columns):
        norms = np.linalg.norm(J_c, axis=0)
        projected = J_c - basis @ (basis.T @ J_c)
        kept = np.linalg.norm(projected, axis=0) > ABSORBED * np.maximum(norms, 1e-300)
        kept &= norms > 0
        if not kept.any():
            tests.append(Test(effect, 0.0, 0, 1.0, False))
            continue
        q, _ = np.linalg.qr(projected[:, kept])
        statistic = float(np.sum((q.T @ r) ** 2) / s2)
        dof = int(kept.sum())
        tests.append(Test(effect, statistic, dof, float(chdtrc(dof, statistic)), True))
    return tests


def holm(tests: list[Test], alpha: float) -> list[Test]:
    """Mark the tests Holm's step-down procedure rejects at family-wise level alpha."""
    order = sorted((t.p_value, i) for i, t in enumerate(tests) if t.distinguishable)
    significant = set()
    for rank, (p, i) in enumerate(order):
        if p > alpha / (len(order) - rank):
            break
        significant.add(i)
    return [Test(t.effect, t.statistic, t.dof, t.p_value, t.distinguishable, i in significant) for i, t in enumerate(tests)]
