"""Optimal calibration poses: reachable candidates, their information on the base set, D-optimal selection.

Candidates (``candidate_poses``) are configurations the instrument can read:
  - tracker and theodolite: random configurations uniform within the joint limits, each kept with the keys
    (targets, stations) the instrument reads there (range, line of sight: ``DeviceModel.visible``);
  - an instrument that reads each pose on one key (a ball-bar): the poses it draws and solves by inverse
    kinematics (DeviceModel.random_keyed_poses: a ball-bar's random points on Goswami's hemispherical shells,
    Fig. 2), kept where it can read them (the length within the LVDT travel).
Every candidate dropped is counted with its reason.

Information (``information``): the weighted Jacobian of the readings (each row over its noise sigma, so
mixed units do not matter) at the design point (the nominal model, the instrument at its nominal place), on
the base parameters of identifiability.py decided over all candidates (Goswami's counting of independent
columns). Candidate i contributes A_i^T A_i (A_i: its rows) to the information matrix M = J^T J, whose
inverse is the covariance of the base parameters (identify/uncertainty.py).

Criterion: D-optimality, max log det M (Goswami: "identifiability by singular values"; Sun & Hollerbach's O1 =
(s_1 ... s_p)^(1/p) / sqrt(m) is det M^(1/2p) up to the count). It is invariant to the units and scale of the
parameters (a rescaling adds a constant to log det) and needs no choice of what to predict.
I-optimality (min trace W M^-1, W the average position information at a held-out pose, ``criterion="I"``)
targets the held-out accuracy directly; measured on simulated robots it is 0-8 % more accurate on that
metric and 4-35 times slower to select (docs/plan.md has the comparison and the choice). Selection: greedy, one pose at a time with the rank-k update
log det(M + A^T A) = log det M + log det(I + A M^-1 A^T), then Fedorov exchange passes (swap a chosen pose for
the candidate that raises the criterion most) until no swap helps. A tiny ridge (RIDGE of the pool's average
information per pose, in column-scaled coordinates) lets the first poses be chosen while M is still singular.
Poses of an existing plan (``--extend``) enter M first and are never exchanged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel, Key
from armcal.effects.library import from_spec
from armcal.effects.measurement import EffectSet
from armcal.identify.identifiability import Identifiability, analyse
from armcal.identify.problem import build_problem
from armcal.kinematics.compiler import KinematicModel
from armcal.model.measurement import predict
from armcal.procedures.plan import Plan
from armcal.procedures.poses import fixed_samples, random_keyed_plan
from armcal.spec.document import Spec

RIDGE = 1e-6  # of the average information per candidate (column-scaled), added while M is singular
EXCHANGE_PASSES = 20  # at most; a pass that swaps nothing ends the exchange


@dataclass(frozen=True)
class Candidates:
    """Poses (N, n) the instrument can read, the keys read at each, and how many were dropped and why."""

    q: np.ndarray
    keys: tuple[tuple[Key, ...], ...]
    dropped: dict[str, int]

    def __len__(self) -> int:
        return len(self.q)

    def plan(self, rows) -> Plan:
        """The samples of the poses ``rows``: pose by pose, each on its keys."""
        rows = [int(r) for r in rows]
        keys = tuple(k for r in rows for k in self.keys[r])
        q = np.array([self.q[r] for r in rows for _ in self.keys[r]]).reshape(len(keys), self.q.shape[1])
        return Plan(keys, q)

    @staticmethod
    def joined(parts: list["Candidates | None"]) -> "Candidates":
        """The parts that are not None, in order."""
        present = [c for c in parts if c is not None]
        out = present[0]
        for part in present[1:]:
            out = Candidates.join(out, part)
        return out

    @staticmethod
    def join(first: "Candidates", second: "Candidates") -> "Candidates":
        dropped = {**first.dropped}
        for why, count in second.dropped.items():
            dropped[why] = dropped.get(why, 0) + count
        return Candidates(np.concatenate([first.q, second.q]), first.keys + second.keys, dropped)


def candidate_poses(spec: Spec, kinematics: KinematicModel, device: DeviceModel, count: int, seed: int) -> Candidates:
    """``count`` random candidate poses of the spec's instrument, those it cannot read dropped (module doc)."""
    rng = np.random.default_rng(seed)
    if device.keyed_poses:
        return _keyed_candidates(spec, kinematics, device, count, rng)
    Q = rng.uniform(kinematics.limits[:, 0], kinematics.limits[:, 1], (count, kinematics.dof))
    return keyed_candidates(Q, kinematics, device)


def fixed_readings(device: DeviceModel, kinematics: KinematicModel) -> Candidates | None:
    """What every design of the instrument reads besides its poses, as one entry to keep first in a design: a
    theodolite's scale-bar sightings (with the bar's length, a pseudo-observation), or the pseudo-observations alone
    (certified socket distances: an entry with no sample); None if nothing."""
    fixed = fixed_samples(device, kinematics.dof)
    if fixed is None and not device.pseudo_observations():
        return None
    return Candidates(np.zeros((1, kinematics.dof)), (fixed.keys if fixed is not None else (),), {})


def keyed_candidates(Q: np.ndarray, kinematics: KinematicModel, device: DeviceModel) -> Candidates:
    """Poses Q read on every key of the instrument that sees them (tracker, theodolite); unseen poses dropped."""
    keys = device.pose_keys()
    seen = np.array([device.visible(key, kinematics.target_poses(device.target(key), Q)) for key in keys]).reshape(len(keys), len(Q))
    keep = seen.any(axis=0)
    read = tuple(tuple(k for k, s in zip(keys, seen[:, i]) if s) for i in np.flatnonzero(keep))
    dropped = {"not visible to the instrument": int((~keep).sum())} if (~keep).any() else {}
    return Candidates(Q[keep], read, dropped)


def _keyed_candidates(spec: Spec, kinematics: KinematicModel, device: DeviceModel, count: int, rng: np.random.Generator) -> Candidates:
    """Random poses of an instrument that reads each pose on one key (the instrument draws and solves them), those it
    cannot read dropped."""
    return keyed_plan_candidates(random_keyed_plan(spec, kinematics, device, count, rng))


def keyed_plan_candidates(plan: Plan) -> Candidates:
    """A plan of poses each read on its own key, as candidates."""
    return Candidates(plan.q, tuple((k,) for k in plan.keys), plan.dropped)


@dataclass(frozen=True)
class Information:
    """Per candidate pose its weighted Jacobian rows on the base set, and its unweighted position rows."""

    blocks: np.ndarray  # (N, K, p): rows over sigma (zero rows pad poses with fewer readings)
    positions: np.ndarray  # (N, K, p): the rows of the held-out metric's readings (``metric``) unweighted, others zero
    identifiability: Identifiability
    kinds: tuple[str, ...]  # per base parameter: length | angle | scale
    metric: str = "length"  # the readings the held-out accuracy is about: length (positions), or angle where none are
    samples: np.ndarray | None = None  # (N,) per candidate, its samples (key read at the pose) with such readings

    @property
    def base(self) -> tuple[str, ...]:
        return self.identifiability.base

    def subset(self, rows: slice) -> "Information":
        """The information of the candidates ``rows`` (on the same base set)."""
        samples = None if self.samples is None else self.samples[rows]
        return Information(self.blocks[rows], self.positions[rows], self.identifiability, self.kinds, self.metric, samples)

    def prediction_weight(self) -> np.ndarray:
        """W (p, p): the average over the candidates' samples of their metric rows' G^T G, so that trace(W M^-1) is
        the mean squared error of a held-out sample (a target's 3D position, a bar length, a sighting's angles)."""
        count = self.samples.sum() if self.samples is not None else len(self.positions)
        return np.einsum("nkp,nkq->pq", self.positions, self.positions) / count


def information(spec: Spec, kinematics: KinematicModel, device: DeviceModel, candidates: Candidates) -> Information:
    """The candidates' Jacobian rows at the design point, on the base set decided over all of them; a reading that
    belongs to no pose (a theodolite's scale-bar length) counts with the first entry (``fixed_readings``')."""
    plan = candidates.plan(range(len(candidates)))
    pose = np.repeat(np.arange(len(candidates)), [len(k) for k in candidates.keys])
    readings: dict[str, np.ndarray] = {}
    for key in dict.fromkeys(plan.keys):
        rows = np.flatnonzero([k == key for k in plan.keys])
        predicted = predict(kinematics, device, key, plan.q[rows])
        for c, channel in enumerate(device.channels(key)):
            readings.setdefault(channel.name, np.full(len(plan), np.nan))[rows] = predicted[:, c]
    data = Measurements(plan.keys, plan.q, readings, {"t": np.zeros(len(plan))})
    problem = build_problem(kinematics, device, data, EffectSet(tuple(from_spec(e) for e in spec.effects)))
    _, J = problem.evaluate(problem.parameters.nominal)
    design = analyse(J, problem.parameters, problem.parameters.free)
    base = [problem.parameters.index(name) for name in design.base]
    residuals = problem.residuals
    owner = np.where(residuals.sample >= 0, pose[np.maximum(residuals.sample, 0)], 0)
    slot = np.zeros(len(owner), dtype=int)
    counts: dict[int, int] = {}
    for r, i in enumerate(owner):
        slot[r], counts[i] = counts.get(i, 0), counts.get(i, 0) + 1
    blocks = np.zeros((len(candidates), max(counts.values()), len(base)))
    blocks[owner, slot] = J[:, base]
    positions = np.zeros_like(blocks)
    on_poses = residuals.sample >= 0
    metric = "length" if "length" in np.array(residuals.kind)[on_poses] else "angle"  # a theodolite reads angles only
    rows = np.array([k == metric for k in residuals.kind]) & on_poses
    positions[owner[rows], slot[rows]] = J[rows][:, base] * residuals.sigma[rows, None]
    kinds = tuple(problem.parameters.entries[b].kind for b in base)
    read = np.unique(residuals.sample[rows])
    return Information(blocks, positions, design, kinds, metric, np.bincount(pose[read], minlength=len(candidates)))


@dataclass(frozen=True)
class Selection:
    """Poses chosen (indices into the candidates, existing ones first) and the design's information matrix."""

    rows: np.ndarray
    information: np.ndarray  # (p, p) M = sum A_i^T A_i over the design, unscaled
    criterion: str

    def covariance(self) -> np.ndarray:
        """(p, p) M^-1, infinite on the diagonal where M is singular."""
        try:
            covariance = np.linalg.inv(self.information)
        except np.linalg.LinAlgError:
            return np.full(self.information.shape, np.inf)
        if np.linalg.cond(self.information) > 1e14:
            return np.full(self.information.shape, np.inf)
        return covariance


def design_information(blocks: np.ndarray, rows) -> np.ndarray:
    """M = sum over the poses ``rows`` of A_i^T A_i."""
    chosen = blocks[np.asarray(rows, dtype=int)]
    return np.einsum("nkp,nkq->pq", chosen, chosen)


def select(blocks: np.ndarray, count: int, existing: int = 0, criterion: str = "D", weight: np.ndarray | None = None) -> Selection:
    """``count`` poses among the candidates ``blocks[existing:]`` that maximise log det M (D) or minimise
    trace(weight M^-1) (I), with the first ``existing`` poses in the design and kept: greedy, then exchange."""
    pool = np.arange(existing, len(blocks))
    if count > len(pool):
        raise ValueError(f"{count} poses asked, {len(pool)} candidates")
    scale = np.sqrt(np.einsum("nkp,nkp->p", blocks, blocks) / len(blocks))
    scale = np.where(scale > 0, scale, 1.0)
    A = blocks / scale
    W = None if weight is None else weight / np.outer(scale, scale)
    kept = design_information(A, range(existing))
    ridge = RIDGE * np.eye(A.shape[2])
    chosen: list[int] = []
    for _ in range(count):
        gains = _gains(A, kept + ridge + design_information(A, chosen), criterion, W)
        gains[np.r_[np.arange(existing), chosen].astype(int)] = -np.inf
        chosen.append(int(np.argmax(gains)))
    for _ in range(EXCHANGE_PASSES):
        swapped = False
        for position in range(len(chosen)):
            others = chosen[:position] + chosen[position + 1 :]
            gains = _gains(A, kept + ridge + design_information(A, others), criterion, W)
            gains[np.r_[np.arange(existing), others].astype(int)] = -np.inf
            best = int(np.argmax(gains))
            if gains[best] > gains[chosen[position]] + 1e-9 * max(1.0, abs(gains[best])):
                chosen[position], swapped = best, True
        if not swapped:
            break
    rows = np.r_[np.arange(existing), chosen].astype(int)
    return Selection(rows, design_information(blocks, rows), criterion)


def _gains(A: np.ndarray, M: np.ndarray, criterion: str, W: np.ndarray | None) -> np.ndarray:
    """Each candidate's improvement of the criterion when added to information M (rank-k updates)."""
    Minv = np.linalg.inv(M)
    B = A @ Minv  # (N, K, p)
    S = np.eye(A.shape[1]) + np.einsum("nkp,njp->nkj", B, A)
    if criterion == "D":
        return np.linalg.slogdet(S)[1]  # log det(M + A^T A) - log det M
    T = np.einsum("nkp,pq,njq->nkj", B, W, B)  # A M^-1 W M^-1 A^T
    return np.trace(np.linalg.solve(S, T), axis1=1, axis2=2)  # decrease of trace(W M^-1)


def random_rows(candidates: int, count: int, existing: int, rng: np.random.Generator) -> np.ndarray:
    """The existing poses and ``count`` candidates drawn at random without replacement (the baseline)."""
    return np.r_[np.arange(existing), existing + rng.choice(candidates - existing, size=count, replace=False)].astype(int)


def condition_number(blocks: np.ndarray, rows) -> float:
    """Condition number of the design's column-scaled Jacobian on the base set (identifiability.conditioning)."""
    J = blocks[np.asarray(rows, dtype=int)].reshape(-1, blocks.shape[2])
    norms = np.linalg.norm(J, axis=0)
    if (norms == 0).any():
        return float("inf")
    s = np.linalg.svd(J / norms, compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")
