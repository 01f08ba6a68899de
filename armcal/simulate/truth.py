"""The "true" robot of a simulation: the nominal chain with manufacturing errors and hidden effects.

Stone's simulator (7.1)-(7.8) builds each PUMA link from its design values and
small random errors (App. F.1): positional errors with sigma_p, orientational
errors with sigma_o, encoder calibration errors with sigma_e. Generalised here
to any chain: the base and every link transform A_i are followed by an error
transform Trans(e1, e2, e3) Rot(x, e4) Rot(y, e5) Rot(z, e6), every joint reading
carries an encoder offset error, and every free target position is off by
sigma_p per coordinate. This model is never the one fitted.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from functools import cached_property

import numpy as np

from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.transforms import compose, rot_x, rot_y, rot_z, trans
from armcal.effects.library import EffectSpec, LumpedMass, from_spec
from armcal.effects.measurement import EffectSet, extras_matrix
from armcal.devices.registry import vocabulary
from armcal.spec.sections import Simulate


def _error_transform(rng: np.random.Generator, sigma_p: float, sigma_o: float) -> np.ndarray:
    e = rng.normal(size=6)
    return compose(trans(*(sigma_p * e[:3])), rot_x(sigma_o * e[3]), rot_y(sigma_o * e[4]), rot_z(sigma_o * e[5]))


@dataclass(frozen=True)
class TrueRobot:
    kinematics: KinematicModel
    p: np.ndarray  # nominal parameters with the free target positions' errors
    link_errors: np.ndarray  # (n+1, 4, 4): after the base, after each A_i
    encoder_errors: np.ndarray  # (n,) mm / rad
    effects: EffectSet  # hidden effects, at their simulated values

    @staticmethod
    def draw(kinematics: KinematicModel, settings: Simulate, rng: np.random.Generator) -> "TrueRobot":
        """A random robot of the nominal design (Stone 7.2.2 with sigma_p, sigma_o, sigma_e)."""
        n = kinematics.dof
        link_errors = np.array([_error_transform(rng, settings.sigma_p, settings.sigma_o) for _ in range(n + 1)])
        sigma_joint = np.array([settings.sigma_e if t == "revolute" else settings.sigma_p for t in kinematics.joint_types])
        encoder_errors = sigma_joint * rng.normal(size=n)
        p = kinematics.parameters.nominal.copy()
        for i, entry in enumerate(kinematics.parameters.entries):
            target_coordinate = entry.name.split(".")[0] in kinematics.targets and entry.kind == "length"
            if target_coordinate and entry.free:
                p[i] += settings.sigma_p * rng.normal()
        return TrueRobot(kinematics, p, link_errors, encoder_errors, EffectSet(tuple(from_spec(e) for e in settings.effects)))

    @staticmethod
    def from_record(kinematics: KinematicModel, record: dict) -> "TrueRobot":
        """The robot described by truth.json (as written by ``describe``)."""
        effects = EffectSet(tuple(_effect(e) for e in record["hidden_effects"]))
        recorded = record["parameters"]  # a parameter the model has and the record lacks (Hayati's beta) is at its nominal
        p = np.array([recorded.get(e.name, e.nominal) for e in kinematics.parameters.entries])
        return TrueRobot(kinematics, p, np.array(record["link_errors"]), np.array(record["encoder_errors"]), effects)

    def target_poses(self, name: str, Q: np.ndarray, extras: dict) -> np.ndarray:
        """True poses (N, 4, 4) of a target at joint readings Q (N, n)."""
        return self._poses(Q, extras, self.kinematics.target_links[name], lambda q: self.kinematics.target_poses(name, q, self.p))

    def tool_poses(self, Q: np.ndarray, extras: dict) -> np.ndarray:
        """True tool poses (N, 4, 4) at joint readings Q (N, n)."""
        return self._poses(Q, extras, self.kinematics.dof, lambda q: self.kinematics.tool_poses(q, self.p))

    @cached_property
    def _joint_deviation(self):
        """The hidden effects' joint deviations and length factor (effects.joint_deviation_function), built once a
        robot: a campaign carries its targets through the chain at every key."""
        return self.effects.joint_deviation_function(self.kinematics)

    def _poses(self, Q: np.ndarray, extras: dict, link: int, nominal) -> np.ndarray:
        """A frame fixed on ``link``, carried by the true chain: its nominal offset from the link frame kept."""
        Q = np.atleast_2d(Q)
        X = extras_matrix(extras, len(Q), self.kinematics.dof)
        deviation, factor = self._joint_deviation.map(len(Q))(Q.T, X.T, self.p, self.effects.values())
        Q_true = Q + self.encoder_errors + np.array(deviation).T
        frames = self.kinematics.link_frames_batch(Q_true, self.p)
        scale = np.array(factor).ravel()
        true_frames = self._true_frames(frames, scale)
        offset = np.einsum("nij,njk->nik", _inverse_batch(frames[:, link]), nominal(Q_true))
        offset[:, :3, 3] *= scale[:, None]
        return np.einsum("nij,njk->nik", true_frames[:, link], offset)

    def _true_frames(self, frames: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """F'_0 = F_0 E_0, F'_i = F'_{i-1} A_i E_i with A_i = F_{i-1}^-1 F_i, lengths scaled."""
        out = np.empty_like(frames)
        out[:, 0] = frames[:, 0] @ self.link_errors[0]
        for i in range(1, frames.shape[1]):
            link = np.einsum("nij,njk->nik", _inverse_batch(frames[:, i - 1]), frames[:, i])
            link[:, :3, 3] *= scale[:, None]
            out[:, i] = np.einsum("nij,njk->nik", out[:, i - 1], link) @ self.link_errors[i]
        return out

    def describe(self) -> dict:
        """The truth, for the record (truth.json)."""
        return {
            "encoder_errors": self.encoder_errors.tolist(),
            "link_errors": [e.tolist() for e in self.link_errors],
            "parameters": dict(zip(self.kinematics.parameters.names, self.p.tolist())),
            "hidden_effects": [_record(e) for e in self.effects.effects],
        }


def record_problem(record: dict) -> str | None:
    """What is wrong with a truth.json record (None when it has the parts ``from_record`` reads, each of its shape);
    said in the record's terms only, never by quoting it."""
    try:
        parameters = record["parameters"]
        if not isinstance(parameters, dict) or not all(isinstance(v, (int, float)) and np.isfinite(v) for v in parameters.values()):
            return "its parameters are not a mapping of names to finite numbers"
        links, encoders = np.asarray(record["link_errors"], dtype=float), np.asarray(record["encoder_errors"], dtype=float)
        if encoders.ndim != 1 or links.shape != (len(encoders) + 1, 4, 4) or not (np.isfinite(links).all() and np.isfinite(encoders).all()):
            return "its link_errors and encoder_errors are not n + 1 finite 4 x 4 transforms and n finite numbers"
        if not isinstance(record["hidden_effects"], list):
            return "its hidden_effects are not a list"
        for effect in record["hidden_effects"]:
            if not isinstance(effect, dict) or effect.get("type") not in vocabulary():
                return "a hidden effect is not one of armcal's effect types"
            _effect(effect)
    except KeyError:
        return "it lacks parameters, link_errors, encoder_errors or hidden_effects"
    except (TypeError, ValueError, IndexError, AttributeError):  # a ValidationError of an effect is a ValueError
        return "a part of it is not of the kind armcal simulate writes"
    return None


def _part_keys() -> list[str]:
    """The spec keys naming an instrument's part (EffectType.part_key), in the vocabulary's order."""
    return list(dict.fromkeys(t.part_key for t in vocabulary().values() if t.part_key))


def _record(effect: EffectSpec) -> dict:
    """An effect as truth.json holds it: its type's name, then its other fields, its part under each part key (null
    where it is not that key's) as truth.json has always had them."""
    fields = asdict(replace(effect, kind=None))  # the type object is not copied
    del fields["kind"]
    part = fields.pop("part")
    fields.update({key: part if key == effect.kind.part_key else None for key in _part_keys()})
    return {"type": effect.type, **fields, "held": sorted(effect.held)}


def _effect(record: dict) -> EffectSpec:
    masses = tuple(LumpedMass(m["link"], m["mass"], tuple(m["centre"])) for m in record.get("masses", ()))
    keys = _part_keys()
    fields = {key: value for key, value in record.items() if key != "type" and key not in keys}
    part = next((record[key] for key in keys if record.get(key) is not None), None)
    return EffectSpec(**{**fields, "part": part, "kind": vocabulary()[record["type"]], "masses": masses, "held": frozenset(record.get("held", ()))})


def _inverse_batch(T: np.ndarray) -> np.ndarray:
    out = np.zeros_like(T)
    R = T[:, :3, :3]
    out[:, :3, :3] = R.transpose(0, 2, 1)
    out[:, :3, 3] = -np.einsum("nji,nj->ni", R, T[:, :3, 3])
    out[:, 3, 3] = 1.0
    return out
