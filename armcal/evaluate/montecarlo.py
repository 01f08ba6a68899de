"""Stone's Monte-Carlo study (7.2-7.4): many simulated robots, each identified, then the grid task.

Robot i of a study is drawn from the i-th child of SeedSequence(seed) (Stone's manufacturing-error model 7.1-7.8
generalised, simulate/truth.py), measured by the spec's procedure with the
instrument's noise (7.9), identified by the spec's method, and sent to the 12
grid vertices under design-model control (7.2.2) and under control with the
identified model (7.2.3); the 34 indices are computed from the reached frames.
The grid stands at Table 7-1 where the design model reaches it (the PUMA: Stone's
own study), else scaled and placed in the robot's workspace as `armcal run` places
it (evaluate/grid.grid_control, procedures/placement.py). The statistics of the 34 indices over the
robots (mean, standard deviation) are Stone's output; a sweep repeats the study
at several values of one input (sweeps.py) with the same robots (the same seeds:
common random numbers, so a trend is not masked by drawing other robots).

Work is split in chunks of robots; a worker builds a study's simulator, model and
design-control solution once and keeps it for the chunks that follow.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armcal.devices import device_model
from armcal.diagnose.calibration import calibration_problem
from armcal.support.errors import UserError
from armcal.evaluate.grid import grid_control, grid_indices, grid_unreachable, measured_point
from armcal.identify.feature_method import feature_parameters
from armcal.identify.fit import FitResult, fit
from armcal.identify.problem import combined_parameters
from armcal.simulate.campaign import CampaignSimulator
from armcal.simulate.truth import TrueRobot
from armcal.spec.document import Spec


@dataclass(frozen=True)
class Chunk:
    """Robots ``robots`` of study point ``point``: what one task of a worker computes."""

    spec: Spec
    spec_dir: Path
    point: int
    robots: tuple[int, ...]
    seed: int


@dataclass(frozen=True)
class ChunkResult:
    point: int
    robots: tuple[int, ...]
    design: np.ndarray  # (robots, 34) grid indices, mm / rad
    calibrated: np.ndarray  # (robots, 34)
    converged: np.ndarray  # (robots,) bool: the identification converged


class RobotStudy:
    """One study point: the simulator, the identification and the design-model solution of the grid."""

    def __init__(self, spec: Spec, spec_dir: Path):
        self.spec = spec
        self.simulator = CampaignSimulator(spec, spec_dir, validation=False)
        kinematics = self.simulator.kinematics
        self.fit_device = device_model(spec, "points" if spec.fit.method == "s_model_features" else None)
        free = {e.name for e in self.fit_device.parameters.entries if e.free}
        teach = spec.device.base_frame_free(free)
        solved = grid_control(kinematics, kinematics.parameters.nominal, measured_point(spec), teach)
        if solved is None:
            raise UserError(f"{grid_unreachable(kinematics, kinematics.parameters.nominal, measured_point(spec))}; a Monte-Carlo study needs it")
        self.control, self.grid = solved
        self.design = None  # the base set, decided at the first robot's start and kept for the others
        self.functions = {}  # the model's compiled functions, derived once for every robot (build_problem)

    def robot(self, seed: np.random.SeedSequence) -> tuple[np.ndarray, np.ndarray, bool]:
        """Grid indices (34,) under design-model and calibrated control of the robot of ``seed``, and convergence."""
        kinematics = self.simulator.kinematics
        campaign = self.simulator.run(seed)
        theta, converged = self._identify(campaign.calibration)
        truth = TrueRobot.from_record(kinematics, campaign.truth)
        design, calibrated = self.control.reached(truth, theta[: len(kinematics.parameters)])
        desired = self.control.desired
        return _values(grid_indices(design, desired)), _values(grid_indices(calibrated, desired)), converged

    def _identify(self, raw) -> tuple[np.ndarray, bool]:
        """The spec's method: Stone's features alone (as in his study), or Levenberg-Marquardt with the
        spec's declared effects from the same start as `armcal run` (the diagnosis is not run in a study)."""
        kinematics = self.simulator.kinematics
        if self.spec.fit.method == "s_model_features":
            theta, _ = feature_parameters(self.spec, self.fit_device.prepare(raw), combined_parameters(kinematics, self.fit_device))
            return theta, True
        result = identify_simulated(self.spec, kinematics, self.fit_device, raw, self.design, self.functions)
        self.design = result.identifiability  # the study's base set: every robot is measured at the same poses
        return result.theta, bool(result.solver.converged)


def identify_simulated(spec: Spec, kinematics, fit_device, raw, design=None, functions: dict | None = None) -> FitResult:
    """Levenberg-Marquardt on simulated readings ``raw`` with the spec's declared effects, from the same start
    as `armcal run` (no diagnosis); ``design``: the base set to keep (None: decided at the start); ``functions``: the
    model's compiled functions from the study's earlier robots (build_problem)."""
    problem, start = calibration_problem(spec, kinematics, fit_device, fit_device.prepare(raw), functions)
    return fit(problem, spec.fit, start=start, identifiability=design)


def _values(indices: dict[str, float]) -> np.ndarray:
    return np.fromiter(indices.values(), dtype=float)


_STUDIES: dict[str, RobotStudy] = {}  # per worker process: study points already built


def _study(spec: Spec, spec_dir: Path) -> RobotStudy:
    key = hashlib.sha256(f"{spec_dir}|{spec.model_dump_json()}".encode()).hexdigest()
    study = _STUDIES.get(key)
    if study is None:  # threads of one worker may race here: each then builds its own, none is lost
        study = RobotStudy(spec, spec_dir)
        _STUDIES.clear()  # a worker keeps the point it is on; chunks come point by point
        _STUDIES[key] = study
    return study


def robot_seeds(seed: int, runs: int) -> list[np.random.SeedSequence]:
    """Robot i's seed, the same at every point of a sweep and whoever computes it."""
    return np.random.SeedSequence(seed).spawn(runs)


def run_chunk(chunk: Chunk) -> ChunkResult:
    """Identify and evaluate the chunk's robots (a worker's task)."""
    study = _study(chunk.spec, chunk.spec_dir)
    seeds = robot_seeds(chunk.seed, max(chunk.robots) + 1)
    design, calibrated, converged = zip(*(study.robot(seeds[i]) for i in chunk.robots))
    return ChunkResult(chunk.point, chunk.robots, np.array(design), np.array(calibrated), np.array(converged))


def chunks(points: list[Spec], spec_dir: Path, runs: int, seed: int, size: int) -> list[Chunk]:
    """All robots of all points, ``size`` robots a task, point by point."""
    return [
        Chunk(spec, spec_dir, point, tuple(range(start, min(start + size, runs))), seed)
        for point, spec in enumerate(points)
        for start in range(0, runs, size)
    ]


def check_points(points: list[Spec], spec_dir: Path) -> RobotStudy:
    """Build the studies here first, so a user error is said before any work is sent out; the first point's study
    (its grid stands where every point's does: a sweep changes the measurements, not the design model)."""
    first = _study(points[0], spec_dir)  # also solves the grid
    for spec in points[1:]:
        CampaignSimulator(spec, spec_dir, validation=False)
    return first
