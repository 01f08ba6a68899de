"""Two calibrations of one robot compared where the parameterisation does not matter: predicted positions.

Two runs may identify different members of a redundant group (the base set is the data's choice where a spec's
order cannot decide, armcal/identify/identifiability.py) and still predict the same robot. What they predict does not
depend on that choice: at POSES poses spread over the joint ranges both campaigns measured (the unscrambled Halton
sequence, its points 1 to POSES, over the intersection of results.json's campaign.joint_ranges: a model is compared where
its data determined it), the position in the robot base frame of the tool's origin and of each
target, from each run's calibrated.yaml (its geometry; effects are not included). The change d = p_new - p_old per pose
and point has the covariance S = J_old C_old J_old^T + J_new C_new J_new^T: first-order propagation (GUM, JCGM
100:2008 5.1.2, matrix form), the runs independent (separate campaigns), J = dp/d(parameters) by CasADi's automatic
differentiation at the calibrated values over each run's identified robot parameters, C their covariance from
results.json: ``std`` and ``correlation_matrix``. Each change is
tested by chi2 = d^T S^+ d on rank(S) (3) degrees of freedom and the family of all poses and points by Holm's
step-down test at family-wise ALPHA (multiple_testing.py).
Used by `armcal compare` (results/compare.py).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import casadi as ca
import numpy as np
from scipy.special import chdtrc

from armcal.kinematics.compiler import KinematicModel, compile_robot
from armcal.evaluate.multiple_testing import holm
from armcal.spec import load_spec
from armcal.kinematics.params import joint_kind
from armcal.support.units import factor

POSES = 50
TOOL = "tool"  # the tool's origin, beside the targets' names


@dataclass(frozen=True)
class RunModel:
    """One run's geometry and the covariance (internal units) of its identified robot parameters."""

    model: KinematicModel
    identified: list[int]  # indices into model.parameters
    covariance: np.ndarray
    ranges: np.ndarray  # (dof, 2) internal units: the joints' ranges in the calibration data (the limits if not recorded)


@dataclass(frozen=True)
class PositionChange:
    point: str  # TOOL or a target's name
    pose: int  # 1-based, of poses()
    change: np.ndarray  # (3,) mm, new - old
    std: np.ndarray  # (3,) mm, sqrt(diag S)
    chi2: float
    dof: int
    p_value: float
    significant: bool = False


def run_model(folder: Path, results) -> RunModel | None:
    """The geometry of a run's calibrated.yaml in ``folder`` and its parameters' covariance from ``results``' std
    and correlation matrix (``results``: results.json's Results model, read by attribute); None for results written
    before the matrix was."""
    matrix = results.correlation_matrix
    if matrix is None:
        return None
    robot = load_spec(folder / "calibrated.yaml").spec.robot
    model = compile_robot(robot.chain())
    rows = {p.name: p for p in results.parameters}
    names = model.parameters.names
    order = {name: k for k, name in enumerate(matrix.parameters)}
    identified = [i for i, n in enumerate(names) if n in order and rows[n].std is not None]
    std = np.array([rows[names[i]].std * factor(model.parameters.entries[i].kind, rows[names[i]].unit) for i in identified])
    taken = [order[names[i]] for i in identified]
    correlation = np.array(matrix.matrix, dtype=float)[np.ix_(taken, taken)]
    ranges = model.limits.copy()
    for i, (recorded, kind) in enumerate(zip(results.campaign.joint_ranges or [], model.joint_types)):
        if recorded is not None:
            unit = robot.units.of(joint_kind(kind))
            ranges[i] = [v * factor(joint_kind(kind), unit) for v in recorded]
    return RunModel(model, identified, std[:, None] * correlation * std[None, :], ranges)


def poses(box: np.ndarray, count: int = POSES) -> np.ndarray:
    """``count`` poses (rad, mm) spread over ``box`` (dof, 2): points 1..count of the unscrambled Halton sequence."""
    from scipy.stats import qmc  # here: scipy.stats takes seconds to import, and only compare needs it

    low, high = box.T
    return low + qmc.Halton(d=len(box), scramble=False).random(count + 1)[1:] * (high - low)


def common_box(old: RunModel, new: RunModel) -> np.ndarray | None:
    """The joint ranges both calibrations were fitted on (their intersection), or None where they share none: a
    model is compared where its data determined it, not extrapolated beyond them."""
    box = np.column_stack([np.maximum(old.ranges[:, 0], new.ranges[:, 0]), np.minimum(old.ranges[:, 1], new.ranges[:, 1])])
    return box if np.all(box[:, 0] <= box[:, 1]) else None


def predicted(run: RunModel, Q: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per point (TOOL, then each target): positions (N, 3) in mm and their covariance (N, 3, 3), J C J^T."""
    model = run.model
    q, p = ca.MX.sym("q", model.dof), ca.MX.sym("p", len(model.parameters))
    out = {}
    for point, pose in ((TOOL, model.fk), *model.targets.items()):
        position = pose(q, p)[:3, 3]
        mapped = ca.Function("position", [q, p], [position, ca.jacobian(position, p)]).map(len(Q))
        values, jacobians = mapped(Q.T, model.parameters.nominal)
        J = np.array(jacobians).reshape(3, len(Q), -1).transpose(1, 0, 2)[:, :, run.identified]
        out[point] = (np.array(values).T, J @ run.covariance @ J.transpose(0, 2, 1))
    return out


def position_changes(old: RunModel, new: RunModel, box: np.ndarray) -> list[PositionChange]:
    """Every point both models carry at every pose of poses(box), tested by chi2 and flagged by Holm's test."""
    Q = poses(box)
    before, after = predicted(old, Q), predicted(new, Q)
    rows = []
    for point in (p for p in after if p in before):
        for k, (d, S) in enumerate(zip(after[point][0] - before[point][0], after[point][1] + before[point][1])):
            dof = int(np.linalg.matrix_rank(S, hermitian=True))
            chi2 = float(d @ np.linalg.pinv(S, hermitian=True) @ d)
            rows.append(PositionChange(point, k + 1, d, np.sqrt(np.diag(S)), chi2, dof, float(chdtrc(dof, chi2)) if dof else 1.0))
    return [replace(r, significant=s) for r, s in zip(rows, holm([r.p_value for r in rows]))]
