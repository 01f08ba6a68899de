"""Held-out data taken after the instrument was moved: re-register it before every evaluation.

The robot's parameters under test stay as given; only the instrument-to-base
transform (the 6 of Goswami's count (1); the instrument's pose Stone's 2.5 adds to the
model, (2.32)) is set anew, so the held-out error still judges the robot model alone.

- The whole set taken after the instrument was set up anew (``data.instrument_moved``,
  no row marked): the transform is the least-squares rigid registration (Kabsch) of the
  predicted target positions onto the measured ones. (A weighted fit of all readings would
  trade positions for the far more precise orientations whenever the model is poor.)
- A station the calibration data do not have (a robot set up anew at each station), or the
  moved instrument's readings at no station where the data mark rows: the frame is fitted
  to the rows marked ``use: register`` alone, its 6 parameters by Gauss-Newton from their
  rigid registration, the robot held; only the other rows are predicted, so the held-out
  figures never include a reading that placed its own frame. Their Jacobian is the total
  derivative with the frame re-fitted, J_e - J_eF (J_rF^+ J_r), and ``registration_noise``
  gives the covariance the frame's own fit adds to them, J_eF (J_rF' J_rF)^-1 J_eF'
  (weighted readings), for the held-out check.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel
from armcal.effects.measurement import EffectSet
from armcal.support.errors import UserError, shown_value
from armcal.identify.problem import Problem, Residual, build_problem
from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.transforms import POSE_FIELDS

FRAME = tuple(f"robot_base.{f}" for f in POSE_FIELDS)
FRAME_PREFIXES = ("robot_base.", "station.")  # an instrument-to-base transform's parameters: the one, or a station's
ITERATIONS = 20  # Gauss-Newton steps of a station's frame fit (from Kabsch it converges in two or three)
FLAT = 1e-6  # s_min / s_max of the frame's scaled derivative below which register points lie on one line
STEP_TOLERANCE = 1e-10  # mm or rad: a step this small ends the frame fit


@dataclass(frozen=True)
class MovedInstrument(Problem):
    kinematics: KinematicModel | None = None
    device: DeviceModel | None = None
    data: Measurements | None = None

    def evaluate(self, theta: np.ndarray, columns: np.ndarray | None = None, out: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        return Problem.evaluate(self, self.registered(theta), columns, out)

    def registered(self, theta: np.ndarray) -> np.ndarray:
        """theta with every instrument-to-base transform of these data (robot_base and each station's) registered to
        them, every component of it."""
        frames = {n for n in self.parameters.names if n.startswith(FRAME_PREFIXES)}
        theta = np.array(theta, dtype=float)
        registered = self.device.registered(theta, self.parameters.names, frames, self.kinematics, self.data)
        return theta if registered is None else registered


@dataclass(frozen=True)
class Station:
    """A held-out station re-registered from its own rows: its residuals' range, its register rows' problem and data."""

    first: int  # its residuals are first .. last of the held-out problem's
    last: int
    blocks: range  # its blocks in the held-out problem
    registration: Problem
    data: Measurements


@dataclass(frozen=True)
class NewStations(Problem):
    """Held-out data with stations the calibration did not see, each re-registered before the rest is predicted."""

    kinematics: KinematicModel | None = None
    device: DeviceModel | None = None
    stations: tuple[Station, ...] = ()

    def evaluate(self, theta: np.ndarray, columns: np.ndarray | None = None, out: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        theta = np.asarray(theta, dtype=float).ravel()
        columns = np.arange(len(theta)) if columns is None else np.asarray(columns, dtype=int)
        r, J_all = Problem.evaluate(self, theta)  # the calibrated frames' rows; the new stations' rewritten below
        frame = [self.parameters.index(name) for name in FRAME]
        for station in self.stations:
            placed, follows = self._frame(theta, station, frame)
            position, start = np.arange(len(theta)), station.first
            for b in station.blocks:
                self.blocks[b].weighted(placed, position, r, J_all, start)
                start += self.blocks[b].size
            rows = slice(station.first, station.last)
            J_all[rows] = J_all[rows] + J_all[rows][:, frame] @ follows
            J_all[rows, frame] = 0.0  # re-fitted, not held: exactly, not to rounding
        J = J_all[:, columns]
        if out is not None:
            out[:] = J
            J = out
        return r, J

    def _frame(self, theta: np.ndarray, station: Station, frame: list[int]) -> tuple[np.ndarray, np.ndarray]:
        """theta with the station's frame fitted to its register rows, and d(frame)/d(theta) as the frame follows."""
        placed = self.device.registered(theta.copy(), self.parameters.names, set(FRAME), self.kinematics, station.data)
        for _ in range(ITERATIONS):
            r, J = station.registration.evaluate(placed, np.array(frame))
            step = np.linalg.lstsq(J, -r, rcond=None)[0]
            placed[frame] += step
            if np.max(np.abs(step)) < STEP_TOLERANCE:
                break
        _, J = station.registration.evaluate(placed)
        follows = -np.linalg.lstsq(J[:, frame], J, rcond=None)[0]  # (6, p); its frame columns are -I
        return placed, follows

    def registration_noise(self, theta: np.ndarray) -> np.ndarray:
        """G (M, 6 per station) with G G' the covariance the frames' fits add to the weighted held-out residuals."""
        theta = np.asarray(theta, dtype=float).ravel()
        frame = [self.parameters.index(name) for name in FRAME]
        G = np.zeros((len(self.residuals.sigma), 6 * len(self.stations)))
        for s, station in enumerate(self.stations):
            placed, _ = self._frame(theta, station, frame)
            _, J_r = station.registration.evaluate(placed, np.array(frame))
            _, J_e = Problem.evaluate(self, placed, np.array(frame))
            _, values, vectors = np.linalg.svd(J_r, full_matrices=False)
            G[station.first : station.last, 6 * s : 6 * s + 6] = J_e[station.first : station.last] @ vectors.T / values
        return G


def held_out(kinematics: KinematicModel, device: DeviceModel, data: Measurements, effects: EffectSet, instrument_moved: bool) -> Problem:
    """The validation problem: its new stations re-registered, or the instrument when it was moved (from the rows
    marked register where the data mark any, else from all of them)."""
    stations = list(dict.fromkeys(device.station(k) for k in data.keys))
    new = [s for s in stations if s is not None and s not in device.stations()]
    if not new and data.register is None:
        problem = build_problem(kinematics, device, data, effects)
        if not instrument_moved:
            return problem
        return MovedInstrument(problem.parameters, problem.n_robot, problem.blocks, problem.residuals, problem.design,
                               kinematics=kinematics, device=device, data=data)
    return _new_stations(kinematics, device, data, effects, new + ([None] if instrument_moved and None in stations else []))


def _new_stations(kinematics: KinematicModel, device: DeviceModel, data: Measurements, effects: EffectSet,
                  moved: list[str | None]) -> NewStations:
    """The held-out problem of data at calibrated frames and at the ``moved`` stations (None: the readings at no
    station), each re-registered from its rows marked register; rows marked register are never predicted."""
    register = np.zeros(len(data), dtype=bool) if data.register is None else data.register
    at = [device.station(k) for k in data.keys]
    rows_at = lambda name, marked: np.flatnonzero([s == name and r == marked for s, r in zip(at, register)])  # noqa: E731
    parts = [(False, None, np.flatnonzero([s not in moved and not r for s, r in zip(at, register)]))]
    parts += [(True, name, rows_at(name, False)) for name in moved]
    problems, stations, first, block = [], [], 0, 0
    for moving, name, rows in parts:
        if moving:
            registering = _placed(device, data.subset(rows_at(name, True)))
            registration = build_problem(kinematics, device, registering, effects) if len(registering) >= 3 else None
            _check_registration(data, name, registering, registration)
        if not len(rows):
            continue
        problem = build_problem(kinematics, device, _placed(device, data.subset(rows)) if moving else data.subset(rows), effects)
        problems.append((rows, problem))
        size = len(problem.residuals.sigma)
        if moving:
            stations.append(Station(first, first + size, range(block, block + len(problem.blocks)), registration, registering))
        first, block = first + size, block + len(problem.blocks)
    if not problems:
        raise UserError(f"{data.origin}: every row is marked use: register; mark the readings to predict use: evaluate (or leave use empty)")
    residuals = Residual(
        sample=np.concatenate([np.where(p.residuals.sample >= 0, rows[np.maximum(p.residuals.sample, 0)], -1) for rows, p in problems]),
        channel=sum((p.residuals.channel for _, p in problems), ()),
        kind=sum((p.residuals.kind for _, p in problems), ()),
        key=sum((tuple(data.keys[rows[s]] if s >= 0 else k for s, k in zip(p.residuals.sample, p.residuals.key)) for rows, p in problems), ()),
        sigma=np.concatenate([p.residuals.sigma for _, p in problems]),
        measured=np.concatenate([p.residuals.measured for _, p in problems]),
    )
    like = problems[0][1]
    return NewStations(like.parameters, like.n_robot, sum((p.blocks for _, p in problems), ()), residuals,
                       kinematics=kinematics, device=device, stations=tuple(stations))


def _placed(device: DeviceModel, data: Measurements) -> Measurements:
    """The same samples read in the instrument's one placement (robot_base), the frame a new station is fitted as."""
    return replace(data, keys=tuple(device.placed(k) for k in data.keys))


def _check_registration(data: Measurements, name: str | None, registering: Measurements, registration: Problem | None) -> None:
    """A frame is fixed by 3 or more registered points not on one line: the robot's predicted points (at the nominal
    values), since a line the model puts them on leaves the rotation about it to the noise. Seen in the column-scaled
    derivative of their readings by the frame's 6 parameters: a singular value below FLAT of the largest."""
    count = len(registering)
    on_line = False
    if registration is not None:
        frame = np.array([registration.parameters.index(n) for n in FRAME])
        _, J = registration.evaluate(registration.parameters.nominal, frame)
        s = np.linalg.svd(J / np.maximum(np.linalg.norm(J, axis=0), 1e-300), compute_uv=False)
        on_line = s[-1] <= FLAT * s[0]
    if count < 3 or on_line:
        lines = ", ".join(str(int(line)) for line in registering.rows[:20]) if count else "none"
        lines += ", ..." if count > 20 else ""
        which = (f"held-out station {shown_value(name)} is not in the calibration data" if name is not None
                 else "the instrument moved (data.instrument_moved)")
        raise UserError(
            f"{data.origin}: {which}, so its frame is re-registered from its "
            f"rows marked use: register, and it has {count} (lines: {lines}){' on one line' if count >= 3 else ''}; "
            "mark at least 3 readings of points not on one line as use: register"
        )
