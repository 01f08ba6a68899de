"""S-Model <-> Denavit-Hartenberg conversions and the pseudo-DH model (Stone ch. 3, 4.3.3-4.3.5).

All values are in mm and rad. A DH row holds the joint *offset*: for a
revolute joint theta = q + row.theta, for a prismatic one d = q + row.d.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.transforms import compose, inverse, pose_from_matrix, rot_z, trans
from armcal.support.units import snapped

PARALLEL_TOL = 1e-10  # |sin| below which two joint axes count as parallel


@dataclass(frozen=True)
class DHRow:
    theta: float
    d: float
    a: float
    alpha: float


@dataclass(frozen=True)
class SModelRow:
    beta: float
    d: float
    a: float
    alpha: float
    gamma: float
    b: float


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def offset_transform(gamma: float, b: float) -> np.ndarray:
    """G = Rot(z, gamma) Trans(0, 0, b): DH frame T_i to S-Model frame S_i, Stone (3.8)."""
    return compose(rot_z(gamma), trans(0.0, 0.0, b))


def dh_to_smodel(rows: list[DHRow], gamma: list[float], b: list[float]) -> list[SModelRow]:
    """S-Model rows for DH rows and chosen frame offsets gamma_0..gamma_n, b_0..b_n, Stone (3.10)-(3.11).

    The S-Model chain starts at S_0 = T_0 G_0 and ends at S_n = T_n G_n, so a robot
    keeps its tool poses with base_S = base G_0 and tool_S = G_n^-1 tool.
    """
    if len(gamma) != len(rows) + 1 or len(b) != len(rows) + 1:
        raise ValueError("gamma and b need one value per frame, 0..n")
    return [
        SModelRow(row.theta - gamma[i], row.d - b[i], row.a, row.alpha, gamma[i + 1], b[i + 1])
        for i, row in enumerate(rows)
    ]


def smodel_to_dh(rows: list[SModelRow], gamma_0: float, b_0: float) -> list[DHRow]:
    """DH rows from S-Model rows, Stone (3.12)-(3.15): theta_i = beta_i + gamma_{i-1}, d_i = d_i + b_{i-1}."""
    gammas = [gamma_0] + [row.gamma for row in rows]
    bs = [b_0] + [row.b for row in rows]
    return [DHRow(row.beta + gammas[i], row.d + bs[i], row.a, row.alpha) for i, row in enumerate(rows)]


def smodel_from_transform(B: np.ndarray, reference: DHRow | None = None) -> SModelRow:
    """S-Model parameters of a transform B_i by backward multiplication, Stone (3.21)-(3.33), (4.52)-(4.57).

    beta has two solutions 180 degrees apart (3.21)/(3.22); the one closest to
    ``reference`` (a design DH row) is kept, else the one with a >= 0. For parallel
    axes Stone sets beta = 0 (3.23); that keeps (3.19) only when p_y = 0, so for
    parallel but distinct axes beta points along the offset between them, and
    (3.23) is kept for coincident axes.

    Erratum: (3.32) and (4.56) print b = (-p_x sin(beta) + p_y cos(beta)) / sin(alpha);
    solving (3.31), -p_x sin(beta) + p_y cos(beta) = -b sin(alpha), gives the opposite
    sign, which is what is used here (the tool pose test catches either error).
    """
    (nx, ox, ax, px), (ny, oy, ay, py), (_, _, az, pz) = B[0], B[1], B[2]
    if math.hypot(ax, ay) > PARALLEL_TOL:
        base = math.atan2(-ax, ay)  # (3.21)
    elif math.hypot(px, py) > PARALLEL_TOL * max(1.0, abs(pz)):
        base = math.atan2(py, px)
    else:
        base = 0.0  # (3.23)
    candidates = []
    for beta in (base, _wrap(base + math.pi)):  # (3.21), (3.22)
        cb, sb = math.cos(beta), math.sin(beta)
        alpha = math.atan2(ax * sb - ay * cb, az)  # (3.26)
        gamma = math.atan2(-ox * cb - oy * sb, nx * cb + ny * sb)  # (3.29)
        a = px * cb + py * sb  # (3.30)
        sa = math.sin(alpha)
        b = (px * sb - py * cb) / sa if abs(sa) > PARALLEL_TOL else 0.0  # (3.31); see erratum above
        d = pz - b * math.cos(alpha)  # (3.33)
        candidates.append(SModelRow(beta, d, a, alpha, gamma, b))
    if reference is not None:
        return min(candidates, key=lambda r: (round(abs(_wrap(r.alpha - reference.alpha)), 6), abs(r.a - reference.a)))
    return max(candidates, key=lambda r: (round(r.a, 9), r.alpha))


def _parallel_axes_convention(rows: list[SModelRow]) -> list[SModelRow]:
    """Where joints i and i+1 are parallel, b_i is free (only d_i + b_i cos(alpha_i) is fixed, (3.33)).

    Take the DH convention of Stone 2.2.1: place the frame so that the next joint
    distance is zero, d_{i+1} = d_{i+1}(S) + b_i = 0.
    """
    out = list(rows)
    for i in range(len(rows) - 1):
        row = out[i]
        if abs(math.sin(row.alpha)) <= PARALLEL_TOL and row.b == 0.0:
            b = -out[i + 1].d
            out[i] = SModelRow(row.beta, row.d - b * math.cos(row.alpha), row.a, row.alpha, row.gamma, b)
    return out


@dataclass(frozen=True)
class PseudoDH:
    """Stone's pseudo-DH model (4.71): base -> S_0, DH rows on encoder readings, S_n -> tool."""

    base: np.ndarray
    rows: list[DHRow]
    tool: np.ndarray
    smodel: list[SModelRow]
    joint_types: tuple[str, ...]

    def robot_dict(self, name: str, serial: str, limits: np.ndarray) -> dict:
        """A ``dh`` robot spec section (mm, rad) that reproduces this model, rounding dust written as 0."""
        pose = lambda T: dict(zip(("x", "y", "z", "rz", "ry", "rx"), map(snapped, pose_from_matrix(T))))  # noqa: E731
        joints = [
            {"type": kind, "limits": list(map(float, lim)), **{field: snapped(value) for field, value in row.__dict__.items()}}
            for row, kind, lim in zip(self.rows, self.joint_types, limits)
        ]
        return {
            "name": name,
            "serial": serial,
            "units": {"length": "mm", "angle": "rad"},
            "convention": "dh",
            "base": pose(self.base),
            "tool": pose(self.tool),
            "joints": joints,
        }


def pseudo_dh(
    model: KinematicModel,
    q_signature: np.ndarray,
    p: np.ndarray | None = None,
    reference: list[DHRow] | None = None,
) -> PseudoDH:
    """Pseudo-DH parameters of any compiled robot, from its joint axes at the signature configuration."""
    q_signature = np.asarray(q_signature, dtype=float)
    frames = model.link_frames(q_signature, p)
    tool = np.array(model.fk(q_signature, model.parameter_vector(p)))
    return pseudo_dh_from_frames(list(frames[: model.dof]), model.joint_types, q_signature, reference, tool)


def pseudo_dh_from_frames(
    frames: list[np.ndarray],
    joint_types: tuple[str, ...],
    q_signature: np.ndarray,
    reference: list[DHRow] | None = None,
    tool: np.ndarray | None = None,
) -> PseudoDH:
    """Pseudo-DH model from S-Model frames S_0..S_{n-1} (z on joints 1..n) at the signature configuration.

    B_i = S_{i-1}^-1 S_i (4.51); S-Model parameters (4.52)-(4.57), with the DH
    convention for parallel axes. For the last frame Stone takes S_n = S_{n-1} at
    the signature (4.3.3); here S_n is S_{n-1} moved along joint n to the DH
    origin, so that d_n = 0 as in the DH convention (2.2.1) and Table 6-2; the
    tool transform (from a given tool pose at the signature, else identity)
    absorbs the difference. DH parameters (3.12)-(3.15) with encoder offsets
    (4.59)-(4.60); joint 1 by (4.72)/(4.73).
    """
    n = len(frames)
    S = list(frames)
    smodel = [
        smodel_from_transform(inverse(S[i - 1]) @ S[i], reference[i - 1] if reference and i <= len(reference) else None)
        for i in range(1, n)
    ]
    smodel = _parallel_axes_convention(smodel)
    b_last = smodel[-1].b if smodel else 0.0
    smodel.append(SModelRow(0.0, -b_last, 0.0, 0.0, 0.0, 0.0))  # B_n = Trans(0, 0, -b_{n-1})
    S.append(S[n - 1] @ trans(0.0, 0.0, -b_last))
    rows = []
    for i, (row, kind) in enumerate(zip(smodel, joint_types)):
        gamma_prev, b_prev = (0.0, 0.0) if i == 0 else (smodel[i - 1].gamma, smodel[i - 1].b)  # (4.71)
        theta, d = row.beta + gamma_prev, row.d + b_prev  # (3.12), (3.13)
        if kind == "revolute":
            theta = _wrap(theta - q_signature[i])  # (4.59), (4.72)
        else:
            d -= q_signature[i]  # (4.73)
        rows.append(DHRow(theta, d, row.a, row.alpha))
    tool_offset = inverse(S[n]) @ tool if tool is not None else np.eye(4)
    return PseudoDH(base=S[0], rows=rows, tool=tool_offset, smodel=smodel, joint_types=tuple(joint_types))
