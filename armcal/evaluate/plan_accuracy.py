"""Predicted held-out accuracy of a pose plan: identification of many simulated robots measured at its poses.

Held-out accuracy (what ``armcal plan`` reports and docs/plan.md defines): the RMS, over held-out readings, of
the error of the calibrated model's predicted position readings against the true robot's noise-free readings,
in mm. For a tracker (or any instrument reading target positions) it is the RMS 3D position error of the
targets, in the instrument frame; for a ball-bar the RMS error of the predicted bar length (the only
position reading it has). Orientation and angle readings do not enter it, except for an instrument that reads
angles only (a theodolite): there it is the RMS error of the predicted angles (azimuth, elevation), in rad. The held-out poses are a second,
independent draw of candidates (the same distribution as the candidates the plan was chosen from: uniform in
the joint limits and readable, or random points on the shells), so the figure is the accuracy a user gets
over the space the candidates cover. With a working region (``PlanStudy(region=...)``, armcal plan --region) the
held-out poses are random poses in that region instead (procedures/regions.py; docs/plan.md).

Robot r of a study is drawn from the r-th child of SeedSequence(seed) by the spec's manufacturing-error
model (simulate/truth.py, Stone 7.1-7.8; never the fitted model), measured at the plan's poses with the
instrument's noise (the simulator's, 7.9), identified as a Monte-Carlo study does (evaluate/montecarlo.py
``identify_simulated``: Levenberg-Marquardt with the declared effects, no diagnosis), then read exactly at
the held-out poses. Every design of a comparison is measured on the same robots (common random numbers); a
random design of robot r is drawn from its own seed too. A design with fewer distinct readings than free
parameters cannot be identified: its figure is NaN (not a number) and the table says so.

The linearised prediction beside it, sqrt(trace(W M^-1)) with M the design's information on the base set
and W the average position information of a held-out pose, is the noise's share alone (no manufacturing
error left unidentified, no nonlinearity); the Monte Carlo includes both.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from armcal.devices import device_model
from armcal.effects.library import from_spec
from armcal.effects.measurement import EffectSet
from armcal.support.errors import UserError
from armcal.evaluate.montecarlo import identify_simulated, robot_seeds
from armcal.identify.problem import build_problem
from armcal.procedures import pose_selection as ps
from armcal.procedures.regions import Region, region_candidates
from armcal.simulate.campaign import CampaignSimulator
from armcal.spec.document import Spec
from armcal.support.units import from_internal

HELD_OUT = 300  # candidate draws for the held-out poses
REGION_POOL = 1000  # random poses in the working region: the weight W of the I-criterion and the random designs there


class PlanStudy:
    """A spec's candidates, their information, held-out poses and simulator: plans chosen and scored.

    With a working ``region`` (procedures/regions.py) the held-out poses are random poses in the region (at the
    task's orientation where the region is ``oriented``), the I-criterion's weight W is the average position
    information of another draw of them (``region_pool`` poses, never the held-out ones), and ``random_in_region``
    draws random designs from ``region_pool`` poses whose point lies in the region at any orientation (at the task's
    orientation alone the base set is not identifiable); plans are still chosen from the candidates over the
    whole joint range."""

    def __init__(self, spec: Spec, spec_dir: Path, candidates: int, seed: int = 0, existing: ps.Candidates | None = None,
                 criterion: str = "D", region: Region | None = None, region_pool: int = REGION_POOL):
        self.spec, self.criterion, self.region = spec, criterion, region
        self.simulator = CampaignSimulator(spec, spec_dir, validation=False, calibration=False)
        self.kinematics = self.simulator.kinematics
        self.device = device_model(spec)
        self._functions = {}  # the model's compiled functions, derived once for every robot and design (build_problem)
        fresh = ps.candidate_poses(spec, self.kinematics, self.device, candidates, seed)
        self.fresh_dropped = fresh.dropped
        if not len(fresh):
            reasons = "; ".join(f"{count} {why}" for why, count in fresh.dropped.items())
            raise UserError(f"none of {candidates} candidate poses can be read by the instrument ({reasons}); check its placement in the spec")
        fixed = ps.fixed_readings(self.device, self.kinematics)  # first: never exchanged, never written as a pose
        self.existing = sum(len(c) for c in (fixed, existing) if c is not None)
        self.candidates = ps.Candidates.joined([fixed, existing, fresh])
        weighted = None  # an oriented region's poses for W (its random designs take any orientation)
        if region is None:
            self.region_pool, held = None, ps.candidate_poses(spec, self.kinematics, self.device, HELD_OUT, seed + 1)
        else:
            any_orientation = replace(region, oriented=False)
            self.region_pool = region_candidates(spec, self.kinematics, self.device, any_orientation, region_pool, seed + 2)
            weighted = region_candidates(spec, self.kinematics, self.device, region, region_pool, seed + 3) if region.oriented else None
            held = region_candidates(spec, self.kinematics, self.device, region, HELD_OUT, seed + 1)
            found = [len(c) for c in (self.region_pool, weighted if weighted is not None else self.region_pool, held)]
            if any(f < n for f, n in zip(found, (region_pool, region_pool, HELD_OUT))):
                raise UserError(f"too few random poses the instrument reads lie in the working region {region.name}: "
                                f"{sum(found)} of {2 * region_pool + HELD_OUT} found")
        self.designs = ps.Candidates.joined([self.candidates, self.region_pool])  # the rows a design may use
        everything = ps.information(spec, self.kinematics, self.device, ps.Candidates.joined([self.designs, weighted]))
        self.information = everything.subset(slice(0, len(self.candidates)))
        if region is None:  # W over the poses the held-out accuracy is about: the candidates, the region's pool, the oriented poses
            weighted_rows = slice(0, len(self.candidates))
        else:
            weighted_rows = slice(len(self.candidates), len(self.designs)) if weighted is None else slice(len(self.designs), None)
        self.weight = everything.subset(weighted_rows).prediction_weight()
        self._blocks = everything.blocks[: len(self.designs)]
        self.held_out = held.plan(range(len(held)))
        self.effects = EffectSet(tuple(from_spec(e) for e in spec.effects))
        self.seed = seed

    @property
    def pool(self) -> int:
        """Candidates a plan may add (the existing poses are not among them)."""
        return len(self.candidates) - self.existing

    def planned(self, count: int, criterion: str | None = None) -> ps.Selection:
        """``count`` poses chosen by ``criterion`` (D or I; default the study's) after the existing ones."""
        return ps.select(self.information.blocks, count, self.existing, criterion or self.criterion, self.weight)

    def random(self, count: int, robot: int) -> np.ndarray:
        """Robot ``robot``'s random design: the existing poses and ``count`` candidates drawn at random."""
        rng = np.random.default_rng([self.seed, robot, count, 7])
        return ps.random_rows(len(self.candidates), count, self.existing, rng)

    def random_in_region(self, count: int, robot: int) -> np.ndarray:
        """Robot ``robot``'s random design in the working region: the existing poses and ``count`` poses of the
        region's pool drawn at random (rows of ``designs``)."""
        rng = np.random.default_rng([self.seed, robot, count, 11])
        pool = len(self.designs) - len(self.candidates)
        return np.r_[np.arange(self.existing), len(self.candidates) + rng.choice(pool, size=count, replace=False)].astype(int)

    def linearised(self, rows) -> float:
        """sqrt(trace(W M^-1)), mm: the noise's share of the held-out accuracy (inf where M is singular)."""
        covariance = ps.Selection(np.asarray(rows), ps.design_information(self._blocks, rows), self.criterion).covariance()
        return float(np.sqrt(np.trace(self.weight @ covariance))) if np.isfinite(covariance).all() else float("inf")

    def accuracy(self, rows, seed: np.random.SeedSequence) -> float:
        """Held-out accuracy (mm; rad for angles-only instruments; module doc) of the robot of ``seed`` calibrated at the poses ``rows``; NaN where
        the design has too few readings to identify the model."""
        plans = {"calibration": self.designs.plan(rows), "validation": self.held_out}
        campaign = self.simulator.run(seed, plans, exact=("validation",))
        try:
            result = identify_simulated(self.spec, self.kinematics, self.device, campaign.calibration, functions=self._functions)
        except UserError:
            return float("nan")
        truth = self.device.prepare(campaign.validation)
        problem = build_problem(self.kinematics, self.device, truth, self.effects, functions=self._functions)
        r, _ = problem.evaluate(result.theta)
        residuals = problem.residuals
        length = np.array([k == self.information.metric for k in residuals.kind]) & (residuals.sample >= 0)
        error = (r * residuals.sigma)[length]
        samples = np.unique(residuals.sample[length])
        return float(np.sqrt(np.sum(error**2) / len(samples)))


@dataclass(frozen=True)
class AccuracyCurve:
    """Held-out accuracy (mm) against the number of poses, planned and random, robot by robot."""

    counts: np.ndarray  # (k,) poses added
    planned: dict[str, np.ndarray]  # criterion (D, I) -> (runs, k)
    random: dict[int, np.ndarray]  # factor f -> (runs, k): f x count random poses (NaN where the pool is too small)
    linearised: dict[str, np.ndarray]  # criterion -> (k,) sqrt(trace W M^-1) of the planned designs, mm
    random_in_region: dict[int, np.ndarray] = field(default_factory=dict)  # factor f -> (runs, k): f x count random poses in the working region

    def values(self) -> dict:
        """Plain values (JSON, report/plan_plots.accuracy_plot): the counts and each design's mean over the robots."""
        mean = lambda a: [float(v) if np.isfinite(v) else None for v in a.mean(axis=0)]  # noqa: E731
        return {"counts": self.counts.tolist(), "planned": {c: mean(a) for c, a in self.planned.items()},
                "random": {str(f): mean(a) for f, a in self.random.items()},
                "random_in_region": {str(f): mean(a) for f, a in self.random_in_region.items()},
                "linearised": {c: a.tolist() for c, a in self.linearised.items()}}


def accuracy_curve(study: PlanStudy, counts, runs: int, factors=(1,), criteria=("D",), progress: Callable[[int, int], None] | None = None,
                   region_factors=()) -> AccuracyCurve:
    """Planned designs of each count (by each criterion) and random ones of ``factors`` x count poses (over the whole
    joint range; of ``region_factors`` x count in the study's working region), scored on ``runs`` robots (the same
    robots for every design): arrays for a plot of accuracy against the number of poses. The mean over the robots
    (axis 0) is the figure; NaN marks a design too small to identify."""
    counts = np.asarray(counts, dtype=int)
    seeds = robot_seeds(study.seed, runs)
    total, done = len(counts) * (len(criteria) + len(factors) + len(region_factors)), 0
    planned = {c: np.full((runs, len(counts)), np.nan) for c in criteria}
    random = {f: np.full((runs, len(counts)), np.nan) for f in factors}
    in_region = {f: np.full((runs, len(counts)), np.nan) for f in region_factors}
    linearised = {c: np.zeros(len(counts)) for c in criteria}
    for j, count in enumerate(counts):
        for criterion in criteria:
            rows = study.planned(int(count), criterion).rows
            linearised[criterion][j] = study.linearised(rows)
            planned[criterion][:, j] = [study.accuracy(rows, seed) for seed in seeds]
            done += 1
            if progress is not None:
                progress(done, total)
        for f in factors:
            if f * count <= study.pool:
                random[f][:, j] = [study.accuracy(study.random(int(f * count), r), seed) for r, seed in enumerate(seeds)]
            done += 1
            if progress is not None:
                progress(done, total)
        for f in region_factors:
            in_region[f][:, j] = [study.accuracy(study.random_in_region(int(f * count), r), seed) for r, seed in enumerate(seeds)]
            done += 1
            if progress is not None:
                progress(done, total)
    return AccuracyCurve(counts, planned, random, linearised, in_region)


def accuracy_label(spec: Spec, study: PlanStudy) -> tuple[str, str, float]:
    """What a held-out accuracy figure is, its unit, and the factor from the study's values (mm, rad) to that unit."""
    metric = spec.device.held_out_metric
    unit, scale = ("mm", 1.0) if study.information.metric == "length" else ("arcsec", from_internal(1.0, "angle", "arcsec"))
    where = "" if study.region is None else f" in the working region ({study.region.name}, {'the task' if study.region.oriented else 'any'} orientation)"
    definition = (f"RMS {metric} at {HELD_OUT} independent held-out poses{where}: the model calibrated from the plan's "
                  "noisy readings against the true robot's noise-free readings")
    return definition, unit, scale
