"""Effects as symbolic terms of the measurement model: ``EffectSet`` asks each effect's type object (one module per
type, effects/registry.py and the instruments' modules) for its terms, built on the regressors here.

Per sample the model takes extras x = [dir_1..dir_n, t, temperature] besides
the joint readings q. Joint-side effects add to the joint value the chain sees:
encoder scale s q, gear harmonic A sin(h r q) + B cos(h r q) (Whitney &
Lozinski's transmission error), backlash w dir, coupling c q_from (joint ``from``
drives this one too), and compliance: c tau_g(q) with tau_g the gravity torque
about the joint from lumped link masses (form masses), or the elastostatic form
linear in the links' unknown first mass moments (form moments),

    Delta_j = sum_{k=j..n} P_k . R_k^T (g_hat x z_(j-1))        P_k = c_j |g| M'_k

with R_k the rotation of frame F_k, z_(j-1) joint j's axis, g_hat the unit gravity
and M'_k link k's first mass moment regrouped with the masses beyond it (so no
mass appears on its own); a prismatic joint: Delta_j = w (z_(j-1) . g_hat).
Bending of joint j tilts everything beyond it about o_(j-1), by the rotation vector

    phi_j = (I - z z^T) sum_{k=j..n} (R_k B_k) x g_hat        B_k = b_j |g| M'_k

(the weight's moment about o_(j-1) without its part along the axis, times one
bending compliance b_j of the bearing, the same about every axis square to it),
applied to the target's pose; bends of several joints compose outermost first.
Thermal drift scales every length of the robot by 1 + k (T - T_ref) (or 1 + k t). Instrument-side:
a scale on length readings, a bias on one microphone's range, an offset of the
ball-bar's length, a displacement of one pivot.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import casadi as ca
import numpy as np

from armcal.effects.library import AXIS_WEIGHT, EffectSpec, LumpedMass, moment_link
from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.params import ParameterSet

GRAVITY = (0.0, 0.0, -9.81)  # m/s^2 in the robot base frame (z up)
DEFAULT_LINK_MASS = 5.0  # kg at each link frame's origin when an effect names no masses


def extras_size(dof: int) -> int:
    return dof + 2


def extras_matrix(extras: dict, count: int, dof: int, reference_temperature: float = 20.0) -> np.ndarray:
    """(N, n+2) rows [dir_1..dir_n, t, temperature] from a data set's optional columns."""
    out = np.zeros((count, extras_size(dof)))
    if "dir" in extras:
        out[:, :dof] = extras["dir"]
    if "t" in extras:
        out[:, dof] = extras["t"]
    out[:, dof + 1] = extras.get("temperature", np.full(count, reference_temperature))
    return np.nan_to_num(out)


def _unit_gravity():
    return np.array(GRAVITY) / np.linalg.norm(GRAVITY)


def moment_regressor(frames: ca.SX, joint: int, term: str):
    """The deflection of joint ``joint`` per unit of one mass-moment product (form moments), from the frames
    F_0..F_n at the readings: (R_k^T (g_hat x z))_c for m<c><k>, z . g_hat for a prismatic joint's w."""
    g = ca.DM(_unit_gravity())
    axis = frames[:3, 4 * (joint - 1) + 2]
    if term == AXIS_WEIGHT:
        return ca.dot(axis, g)
    link, c = moment_link(term)
    return ca.dot(frames[:3, 4 * link + c], ca.cross(g, axis))


def moment_regressors(frames: np.ndarray, joint: int, terms) -> np.ndarray:
    """Numeric moment_regressor of every term at N configurations: frames (N, n+1, 4, 4) -> (N, len(terms))."""
    g = _unit_gravity()
    axis = frames[:, joint - 1, :3, 2]
    lever = np.cross(g, axis)
    columns = []
    for term in terms:
        if term == AXIS_WEIGHT:
            columns.append(axis @ g)
        else:
            link, c = moment_link(term)
            columns.append(np.einsum("ni,ni->n", frames[:, link, :3, c], lever))
    return np.column_stack(columns) if columns else np.zeros((len(frames), 0))


def bending_regressor(frames: ca.SX, joint: int, term: str):
    """The tilt (rotation vector, base frame) of the links beyond joint ``joint`` per unit of one product m<c><k>:
    (I - z z^T) ((R_k e_c) x g_hat), z joint j's axis."""
    g = ca.DM(_unit_gravity())
    axis = frames[:3, 4 * (joint - 1) + 2]
    link, c = moment_link(term)
    moment = ca.cross(frames[:3, 4 * link + c], g)
    return moment - axis * ca.dot(axis, moment)


def bending_regressors(frames: np.ndarray, joint: int, terms) -> np.ndarray:
    """Numeric bending_regressor of every term at N configurations: frames (N, n+1, 4, 4) -> (N, 3, len(terms))."""
    g = _unit_gravity()
    axis = frames[:, joint - 1, :3, 2]
    columns = []
    for term in terms:
        link, c = moment_link(term)
        moment = np.cross(frames[:, link, :3, c], g)
        columns.append(moment - axis * np.einsum("ni,ni->n", axis, moment)[:, None])
    return np.stack(columns, axis=-1) if columns else np.zeros((len(frames), 3, 0))


def _small_rotation(phi):
    """Rot(phi) to second order, I + [phi] + [phi]^2 / 2: orthonormal to |phi|^3 (milliradians at most)."""
    K = ca.vertcat(ca.horzcat(0, -phi[2], phi[1]), ca.horzcat(phi[2], 0, -phi[0]), ca.horzcat(-phi[1], phi[0], 0))
    return ca.SX.eye(3) + K + ca.mtimes(K, K) / 2


def torque_masses(kinematics: KinematicModel, own: tuple[LumpedMass, ...] = ()) -> tuple[LumpedMass, ...]:
    """The masses of a gravity torque: an effect's own, else the robot's declared layout, else the assumed default
    (DEFAULT_LINK_MASS at each link frame's origin)."""
    return own or kinematics.masses or tuple(LumpedMass(k, DEFAULT_LINK_MASS, (0.0, 0.0, 0.0)) for k in range(1, kinematics.dof + 1))


def gravity_torque(frames: ca.SX, joint: int, masses: tuple[LumpedMass, ...]) -> ca.SX:
    """Gravity torque (N m) about joint ``joint`` (z of F_{joint-1}) from the masses on links joint..n."""
    frame = lambda k: frames[:, 4 * k : 4 * k + 4]  # noqa: E731
    axis, origin = frame(joint - 1)[:3, 2], frame(joint - 1)[:3, 3]
    torque = 0
    for mass in masses:
        if mass.link < joint:
            continue
        centre = ca.mtimes(frame(mass.link), ca.vertcat(*mass.centre, 1))[:3]
        lever = (centre - origin) / 1000.0  # m
        torque += ca.dot(axis, ca.cross(lever, mass.mass * ca.DM(GRAVITY)))
    return torque


class ChainState:
    """The chain at one sample as the joint-side terms read it: readings q, extras x, robot parameters p, and the frames
    F_0..F_n (built once, when a term first asks)."""

    def __init__(self, kinematics: KinematicModel, q, x, p):
        self.kinematics, self.q, self.x, self.p = kinematics, q, x, p

    @cached_property
    def frames(self):
        return self.kinematics.frames(self.q, self.p)


def _values(effect: EffectSpec, v: dict):
    """field -> the symbol of the effect's parameter ``<id>.<field>``."""
    return lambda f: v[f"{effect.id}.{f}"]


@dataclass(frozen=True)
class EffectSet:
    """The effects in a model and their parameter vector pe."""

    effects: tuple[EffectSpec, ...] = ()

    @property
    def parameters(self) -> ParameterSet:
        return ParameterSet(tuple(p for e in self.effects for p in e.parameters()))

    def joint_values(self, kinematics: KinematicModel, q, x, p, v: dict):
        """q + the joint-side effects' deviations; ``v`` maps effect parameter names to symbols."""
        delta = [0] * kinematics.dof
        chain = ChainState(kinematics, q, x, p)
        for e in self.effects:
            if e.joint is None:
                continue
            deviation = e.kind.joint_deviation(e, chain, _values(e, v))
            if deviation is not None:
                delta[e.joint - 1] += deviation
        return q + ca.vertcat(*delta)

    def bent(self, kinematics: KinematicModel, link: int, qv, pv, pose, v: dict):
        """``pose`` (a frame on ``link``) tilted by the bending of every joint up to ``link``, outermost first, so that
        each tilt is about its joint in the chain the inner ones then carry: F_(j-1) B_j F_(j-1)^-1 (...) pose."""
        bends = sorted((e for e in self.effects if e.kind.tilts and e.joint <= link), key=lambda e: -e.joint)
        if not bends:
            return pose
        frames = kinematics.frames(qv, pv)
        for e in bends:
            phi = e.kind.tilt(e, frames, _values(e, v))
            R, pivot = _small_rotation(phi), frames[:3, 4 * (e.joint - 1) + 3]
            tilt = ca.vertcat(ca.horzcat(R, pivot - ca.mtimes(R, pivot)), ca.DM([[0, 0, 0, 1]]))
            pose = ca.mtimes(tilt, pose)
        return pose

    def length_factor(self, x, v: dict, dof: int):
        """1 + thermal drift of the robot's lengths."""
        factor = 1
        for e in self.effects:
            change = e.kind.length_change(e, x, dof, _values(e, v))
            if change is not None:
                factor += change
        return factor

    def robot_parameters(self, kinematics: KinematicModel, x, p, v: dict):
        """p with every length scaled by the thermal factor."""
        lengths = ca.DM([1.0 if e.kind == "length" else 0.0 for e in kinematics.parameters.entries])
        return p + (self.length_factor(x, v, kinematics.dof) - 1) * (p * lengths)

    def device_parameters(self, parameters: ParameterSet, pd, v: dict):
        """pd, the instrument's ``parameters``, with the instrument-side effects' shifts (a ball-bar pivot's offset)."""
        shift = [0] * len(parameters)
        for e in self.effects:
            for index, change in e.kind.device_shift(e, parameters, _values(e, v)).items():
                shift[index] = change
        return pd + ca.vertcat(*shift)

    def readings(self, channels: tuple, y, v: dict):
        """Readings y of these channels with the instrument-side effects (a scale, a range's bias, the ball-bar's
        length offset)."""
        parts = [y[i] for i in range(len(channels))]
        for e in self.effects:
            value = _values(e, v)
            parts = [e.kind.reading(e, c, r, value) for r, c in zip(parts, channels)]
        return ca.vertcat(*parts)

    def joint_deviation_function(self, kinematics: KinematicModel) -> ca.Function:
        """(q, x, p, pe) -> joint deviations and the thermal length factor, for the simulator (a bending is no
        joint deviation: the spec refuses one under simulate.effects)."""
        n = kinematics.dof
        q, x = ca.SX.sym("q", n), ca.SX.sym("x", extras_size(n))
        p, pe = ca.SX.sym("p", len(kinematics.parameters)), ca.SX.sym("pe", len(self.parameters))
        v = self.parameters.symbols(pe)
        deviation = self.joint_values(kinematics, q, x, p, v) - q
        return ca.Function("effects", [q, x, p, pe], [deviation, self.length_factor(x, v, n)])

    def values(self) -> np.ndarray:
        """pe at the effects' own values (a simulation's hidden amplitudes)."""
        return self.parameters.nominal

    def reading_function(self, channels: tuple) -> ca.Function:
        """(y, pe) -> readings of these channels with the instrument-side effects, for the simulator."""
        y = ca.SX.sym("y", len(channels))
        pe = ca.SX.sym("pe", len(self.parameters))
        return ca.Function("readings", [y, pe], [self.readings(channels, y, self.parameters.symbols(pe))])

    def device_parameter_function(self, parameters: ParameterSet) -> ca.Function:
        """(pd, pe) -> pd, the instrument's ``parameters``, with pivot offsets, for the simulator."""
        pd = ca.SX.sym("pd", len(parameters))
        pe = ca.SX.sym("pe", len(self.parameters))
        return ca.Function("pivots", [pd, pe], [self.device_parameters(parameters, pd, self.parameters.symbols(pe))])


def gravity_torque_function(kinematics: KinematicModel) -> ca.Function:
    """(q, p) -> gravity torque (N m) about every joint from the robot's masses (``torque_masses``), for the evidence plots."""
    q, p = ca.SX.sym("q", kinematics.dof), ca.SX.sym("p", len(kinematics.parameters))
    frames = kinematics.frames(q, p)
    torques = [gravity_torque(frames, j, torque_masses(kinematics)) for j in range(1, kinematics.dof + 1)]
    return ca.Function("gravity_torque", [q, p], [ca.vertcat(*torques)])
