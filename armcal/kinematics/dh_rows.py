"""The DH rows of any serial chain, from its joint axes at q = 0: Stone's (2.9) where the axes allow, Hayati's beta
where two consecutive axes are near parallel but not parallel.

A chain is given by frames Z_0 .. Z_(n-1) whose z axes are joints 1..n (with their positive sense; a prismatic
joint's line through its frame's origin) and the tool frame, all in the world at q = 0. The DH frames follow
Stone 2.2.1: F_0 = Z_0 (the base), then for each joint i < n, with axis i+1 the line p + t u seen from F_(i-1):

- axes more than PARALLEL_DEG from parallel: x_i along their common normal (a >= 0), d_i the height of its foot on
  axis i, alpha_i the twist about it; beta_i = 0, A_i = Rot(z, theta) Trans(0, 0, d) Trans(a, 0, 0) Rot(x, alpha);
- within PARALLEL_DEG: Hayati's row with d_i = 0 (Hayati & Mirmirani 1985, kinematics/parallel_axes.py): F_i's origin
  where axis i+1 crosses the plane z = 0 of F_(i-1), at distance a in direction theta, and
  Rot(x, alpha) Rot(y, beta) turning z onto u. A beta of 0 (below BETA_DUST) makes it Stone's row: x_i is then
  the common normal, at d_i = 0 (parallel axes: one of many).

Row n is the identity at q = 0 and the tool F_(n-1)^-1 T. A chain whose rows all have beta = 0 is a ``dh`` chain;
one with a beta is ``mdh``, and ``reason`` says which axes make it so: neither parallel nor far from it, their
common normal lies far along the axis (Stone's Table 6-3, the pseudo-DH d of kilometres).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from armcal.kinematics.conventions import mdh_link
from armcal.kinematics.parallel_axes import PARALLEL_DEG
from armcal.kinematics.transforms import inverse

BETA_DUST = 1e-12  # rad: a Hayati tilt below it moves a 10 m arm by 1e-8 mm, and is Stone's row (beta 0)
ORIGIN_DUST = 1e-12  # mm: a Hayati origin this close to axis i gives theta 0


@dataclass(frozen=True)
class Row:
    theta: float  # rad (the joint's offset at q = 0 when revolute)
    d: float  # mm (the offset at q = 0 when prismatic)
    a: float
    alpha: float
    beta: float
    parallel: bool = False  # axis i + 1 within PARALLEL_DEG of parallel to axis i: Hayati's row, d = 0


@dataclass(frozen=True)
class DHChain:
    base: np.ndarray  # F_0 in the world
    rows: tuple[Row, ...]
    tool: np.ndarray  # the tool in F_n
    frames: tuple[np.ndarray, ...]  # F_0 .. F_(n-1): z on joints 1..n, in the world at q = 0
    reason: str | None  # why the chain needs Hayati's beta (the first such pair), None for a dh chain

    @property
    def convention(self) -> str:
        return "dh" if self.reason is None else "mdh"


def dh_chain(axes: list[np.ndarray], tool: np.ndarray, names: list[str]) -> DHChain:
    """The DH (or MDH) rows of the chain whose joints ``names`` turn about the z axes of ``axes`` and ends at ``tool``."""
    frames, rows, reason = [axes[0]], [], None
    for i in range(1, len(axes)):
        line = inverse(frames[-1]) @ axes[i]
        row = _row(line[:3, 3], line[:3, 2])
        if row.beta and reason is None:
            reason = _why_not_dh(line[:3, 3], line[:3, 2], names[i - 1], names[i])
        rows.append(row)
        frames.append(frames[-1] @ mdh_link(row.theta, row.d, row.a, row.alpha, row.beta))
    rows.append(Row(0.0, 0.0, 0.0, 0.0, 0.0))
    return DHChain(axes[0], tuple(rows), inverse(frames[-1]) @ tool, tuple(frames), reason)


def _row(p: np.ndarray, u: np.ndarray) -> Row:
    """The row taking a frame on axis i (z) to one on axis i + 1 (the line p + t u)."""
    normal = np.array([-u[1], u[0], 0.0])  # z x u
    if np.linalg.norm(normal) > math.sin(math.radians(PARALLEL_DEG)):
        return _common_normal(p, u, normal)
    c = p - p[2] / u[2] * u  # where axis i + 1 crosses the plane z = 0
    a = float(np.hypot(c[0], c[1]))
    theta = math.atan2(c[1], c[0]) if a > ORIGIN_DUST else 0.0
    ct, st = math.cos(theta), math.sin(theta)
    ux, uy, uz = ct * u[0] + st * u[1], -st * u[0] + ct * u[1], u[2]  # u seen after Rot(z, theta)
    beta = math.asin(max(-1.0, min(1.0, ux)))
    return Row(theta, 0.0, a if a > ORIGIN_DUST else 0.0, math.atan2(-uy, uz), beta if abs(beta) > BETA_DUST else 0.0, True)


def _common_normal(p: np.ndarray, u: np.ndarray, normal: np.ndarray) -> Row:
    """Stone's row (2.9) between axis i and the line p + t u, which is not parallel to it."""
    d, t = _feet(p, u)
    x = normal / np.linalg.norm(normal)
    a = float((p + t * u) @ x)
    if a < 0.0:
        x, a = -x, -a
    return Row(math.atan2(x[1], x[0]), d, a, math.atan2(float(x @ normal), float(u[2])), 0.0)


def _feet(p: np.ndarray, u: np.ndarray) -> tuple[float, float]:
    """(d, t): the common normal of axis i (z) and the line p + t u runs from (0, 0, d) to p + t u."""
    b, pu, sine2 = float(u[2]), float(p @ u), float(u[0] ** 2 + u[1] ** 2)  # sine2 = 1 - b^2, without cancelling
    return (p[2] - b * pu) / sine2, (b * p[2] - pu) / sine2


def _why_not_dh(p: np.ndarray, u: np.ndarray, joint: str, following: str) -> str:
    """One line: the two axes neither parallel nor far from it, and where their common normal lies."""
    sine = float(np.hypot(u[0], u[1]))
    foot = abs(_feet(p, u)[0])
    return (f"the axes of {joint} and {following} are {math.degrees(math.asin(min(sine, 1.0))):.3g} deg from parallel, "
            f"neither parallel nor more than {PARALLEL_DEG:g} deg from it: their common normal lies {foot:.3g} mm along "
            f"{joint}'s axis (Stone's Table 6-3); Hayati's beta holds them")
