"""Compile a declared chain (kinematics/chain.py, built by the spec) into CasADi forward-kinematics Functions.

Every convention is assembled as one chain: F_0 = base (times Goswami's first
link), F_i = F_{i-1} A_i(q_i), tool = F_n * tool. The z axis of F_{i-1} is
joint i's axis, so ``frames`` also gives the joint axes that Stone's S-Model
extraction starts from (4.48)-(4.51).
"""

from __future__ import annotations

from dataclasses import dataclass
import casadi as ca
import numpy as np

from armcal.kinematics import conventions
from armcal.kinematics.chain import DeclaredChain
from armcal.kinematics.masses import LumpedMass
from armcal.kinematics.params import LINK_FIELDS, ParameterSet, parameter_set
from armcal.kinematics.transforms import compose, trans, xyz_zyx


@dataclass(frozen=True)
class KinematicModel:
    """A compiled robot: named parameters and fk Functions of (q, p)."""

    name: str
    convention: str
    joint_names: tuple[str, ...]
    joint_types: tuple[str, ...]
    limits: np.ndarray  # (n, 2), rad or mm
    parameters: ParameterSet
    fk: ca.Function  # (q, p) -> 4x4 base-to-tool
    frames: ca.Function  # (q, p) -> 4 x 4(n+1): F_0 .. F_n side by side
    targets: dict[str, ca.Function]  # (q, p) -> 4x4 base-to-target
    target_links: dict[str, int]  # the link each target rides on
    masses: tuple[LumpedMass, ...] = ()  # the spec's robot.masses: the maker's mass layout, if declared

    @property
    def dof(self) -> int:
        return len(self.joint_names)

    def tool_poses(self, Q: np.ndarray, p: np.ndarray | None = None) -> np.ndarray:
        """Tool poses (N, 4, 4) for joint configurations Q (N, n), one call for all."""
        return _batch(self.fk, Q, self.parameter_vector(p))

    def target_poses(self, name: str, Q: np.ndarray, p: np.ndarray | None = None) -> np.ndarray:
        """Poses (N, 4, 4) of a named target."""
        return _batch(self.targets[name], Q, self.parameter_vector(p))

    def link_frames(self, q: np.ndarray, p: np.ndarray | None = None) -> np.ndarray:
        """Frames F_0 .. F_n (n+1, 4, 4) at one configuration."""
        return self.link_frames_batch(np.asarray(q, dtype=float)[None], p)[0]

    def link_frames_batch(self, Q: np.ndarray, p: np.ndarray | None = None) -> np.ndarray:
        """Frames F_0 .. F_n (N, n+1, 4, 4) at N configurations, one call."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        if len(Q) == 0:
            return np.zeros((0, self.dof + 1, 4, 4))
        out = np.array(self.frames.map(len(Q))(Q.T, self.parameter_vector(p)))
        return out.reshape(4, len(Q), self.dof + 1, 4).transpose(1, 2, 0, 3)

    def parameter_vector(self, p: np.ndarray | None = None) -> np.ndarray:
        """p itself, or the nominal parameter vector when p is None."""
        return self.parameters.nominal if p is None else np.asarray(p, dtype=float)


def _batch(function: ca.Function, Q: np.ndarray, p: np.ndarray) -> np.ndarray:
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    n_samples = Q.shape[0]
    if n_samples == 0:
        return np.zeros((0, 4, 4))
    out = np.array(function.map(n_samples)(Q.T, p))
    return out.reshape(4, n_samples, 4).transpose(1, 0, 2)


def compile_robot(chain: DeclaredChain) -> KinematicModel:
    """Build the symbolic chain of a declared chain and wrap it in CasADi Functions."""
    parameters = parameter_set(chain)
    p = ca.SX.sym("p", len(parameters))
    symbol = parameters.symbols(p)
    q = ca.SX.sym("q", chain.dof)
    joint_types = tuple(j.type for j in chain.joints)
    first, links = _chain(chain, symbol, ca.vertsplit(q), joint_types)

    frames = [compose(pose_from_symbols(symbol, "base"), first)]
    for link in links:
        frames.append(compose(frames[-1], link))
    tool = compose(frames[-1], pose_from_symbols(symbol, "tool"))

    targets = {}
    for number, (name, target) in enumerate(chain.targets.items(), start=1):
        pose = trans(symbol[f"{name}.x"], symbol[f"{name}.y"], symbol[f"{name}.z"])
        if target.is_frame:
            pose = pose_from_symbols(symbol, name)
        # named by its place, not its name: a spec's names are any text, a CasADi function's an identifier
        targets[name] = ca.Function(f"fk_target_{number}", [q, p], [compose(frames[target.link], pose)], ["q", "p"], ["T"])

    return KinematicModel(
        name=chain.name,
        convention=chain.convention,
        joint_names=tuple(chain.joint_names()),
        joint_types=joint_types,
        limits=np.array([j.limits for j in chain.joints], dtype=float),
        parameters=parameters,
        fk=ca.Function("fk", [q, p], [tool], ["q", "p"], ["T"]),
        frames=ca.Function("frames", [q, p], [ca.horzcat(*frames)], ["q", "p"], ["F"]),
        targets=targets,
        target_links={name: target.link for name, target in chain.targets.items()},
        masses=chain.masses,
    )


def pose_from_symbols(symbol: dict, prefix: str):
    """Trans(x, y, z) Rot(z, rz) Rot(y, ry) Rot(x, rx) of a pose whose absent angles are 0."""
    get = lambda field: symbol.get(f"{prefix}.{field}", 0.0)  # noqa: E731
    return xyz_zyx(get("x"), get("y"), get("z"), get("rz"), get("ry"), get("rx"))


def _chain(chain: DeclaredChain, symbol: dict, q: list, joint_types: tuple[str, ...]):
    """(first, [A_1..A_n]): the constant transform after the base and each joint's link transform."""
    names = chain.joint_names()
    convention = chain.convention
    links = []
    for i, (name, qi, kind) in enumerate(zip(names, q, joint_types), start=1):
        s = {key[len(name) + 1 :]: value for key, value in symbol.items() if key.startswith(f"{name}.")}
        revolute = kind == "revolute"
        if convention == "six_parameter":
            value = s["theta0"] + s["k"] * qi
            links.append(compose(conventions.six_parameter_joint(value, revolute), _link(symbol, i + 1)))
        elif convention == "s_model":
            beta, d = (s["beta"] + qi, s["d"]) if revolute else (s["beta"], s["d"] + qi)
            links.append(conventions.smodel_link(beta, d, s["a"], s["alpha"], s["gamma"], s["b"]))
        else:
            theta, d = (s["theta"] + qi, s["d"]) if revolute else (s["theta"], s["d"] + qi)
            if "beta" in s:  # mdh, or a dh joint with Hayati's beta (kinematics/parallel_axes.py)
                links.append(conventions.mdh_link(theta, d, s["a"], s["alpha"], s["beta"]))
            else:
                links.append(conventions.dh_link(theta, d, s["a"], s["alpha"]))
    first = _link(symbol, 1) if convention == "six_parameter" else np.eye(4)
    return first, links


def _link(symbol: dict, index: int):
    """Goswami's link transform T^L_index from the parameter symbols."""
    return conventions.six_parameter_link(*(symbol[f"L{index}.{f}"] for f in LINK_FIELDS))
