"""The effects the diagnosis may propose: every type x joint x order the data could show and the model lacks.

Two kinds are chosen with the data in mind:

- compliance is proposed as one compliance per joint times the gravity torque of
  the robot's declared masses (``robot.masses``, the maker's data) or, without
  them, in its mass-moment form (effects/library.py), no masses assumed. Of a joint's products m<c><k> only those whose deflection patterns over
  the calibration poses are independent are proposed (Gram-Schmidt in link and
  axis order at the nominal geometry, INDEPENDENT): the others are combinations of
  them (a product along a joint's own axis regroups onto the link before it,
  products the poses never vary together with others drop out), and a candidate
  with dependent columns would count degrees of freedom its score test cannot see.
  A joint whose gravity torque is zero at every pose (a vertical first axis) gets
  no compliance candidate. Bending (the links beyond a revolute joint tilting about
  the axes square to it) is built the same way, from its tilt patterns, but tried
  only when ``diagnose.candidates`` names it (OPT_IN): a tilt about an axis square
  to joint j is, up to the lever, a turn about the axis of the joint before or
  after it, so bending and the neighbours' compliance explain a deflection almost
  equally well (measured: docs/effects.md), and left in the default pool the
  diagnosis names either.
- coupling (joint i drives joint j) is proposed for neighbouring joints, in both
  directions, and among the wrist's joints (the last three of an arm of five or
  more): a belt, a parallelogram or a ball-screw spline couples joints next to each
  other, a wrist's gear train couples its three axes; a coupling across the arm
  (joint 1 driving joint 5) has no mechanism, and every extra candidate costs the
  others power under Holm's correction.
"""

from __future__ import annotations

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel
from armcal.effects.library import EffectSpec, coupling, moment_terms, with_products
from armcal.effects.measurement import bending_regressors, gravity_torque_function, moment_regressors
from armcal.kinematics.compiler import KinematicModel
from armcal.spec.sections import Diagnose

OPT_IN = ("joint_bending",)  # types tried only when diagnose.candidates names them
INDEPENDENT = 1e-6  # norm a unit deflection pattern must keep off those before it to be a product of its own
SILENT = 1e-9  # a pattern below this fraction of the joint's largest is no deflection at all


def independent_terms(patterns: np.ndarray, terms: tuple[str, ...]) -> tuple[str, ...]:
    """The terms whose (N,) columns of ``patterns`` are independent of the columns kept before them."""
    norms = np.linalg.norm(patterns, axis=0)
    if not len(terms) or norms.max() == 0:
        return ()
    kept, basis = [], np.zeros((len(patterns), 0))
    for term, column, norm in zip(terms, patterns.T, norms):
        if norm <= SILENT * norms.max():
            continue
        rest = column / norm - basis @ (basis.T @ (column / norm))
        rest -= basis @ (basis.T @ rest)
        if np.linalg.norm(rest) > INDEPENDENT:
            kept.append(term)
            basis = np.column_stack([basis, rest / np.linalg.norm(rest)])
    return tuple(kept)


def compliance_candidates(kinematics: KinematicModel, data: Measurements) -> list[EffectSpec]:
    """Per joint, one compliance times the torque of the robot's declared masses, or without them the mass-moment
    compliance with the products the poses of ``data`` tell apart (module docstring)."""
    q = np.nan_to_num(data.q)
    if kinematics.masses:
        torque = np.array(gravity_torque_function(kinematics).map(len(q))(q.T, kinematics.parameters.nominal)).T
        spread = np.ptp(torque, axis=0)
        return [EffectSpec("joint_compliance", joint=j + 1) for j in range(kinematics.dof) if spread[j] > SILENT * spread.max()]
    frames = kinematics.link_frames_batch(q)
    out = []
    for joint, kind in enumerate(kinematics.joint_types, start=1):
        every = moment_terms(joint, kinematics.dof, kind == "revolute")
        terms = independent_terms(moment_regressors(frames, joint, every), every)
        if terms:
            out.append(with_products("joint_compliance", joint, terms))
    return out


def bending_candidates(kinematics: KinematicModel, data: Measurements) -> list[EffectSpec]:
    """Per revolute joint, the bending with the products whose tilt patterns over the poses are independent."""
    frames = kinematics.link_frames_batch(np.nan_to_num(data.q))
    out = []
    for joint, kind in enumerate(kinematics.joint_types, start=1):
        if kind != "revolute":
            continue
        every = moment_terms(joint, kinematics.dof)
        patterns = bending_regressors(frames, joint, every)
        terms = independent_terms(patterns.reshape(-1, len(every)), every)
        if terms:
            out.append(with_products("joint_bending", joint, terms))
    return out


def coupling_pairs(dof: int) -> list[tuple[int, int]]:
    """(from, joint) pairs proposed: neighbours both ways, and the wrist's joints among themselves."""
    wrist = set(range(dof - 2, dof + 1)) if dof >= 5 else set()
    return [(i, j) for j in range(1, dof + 1) for i in range(1, dof + 1) if i != j and (abs(i - j) == 1 or {i, j} <= wrist)]


def candidates(
    kinematics: KinematicModel, device: DeviceModel, data: Measurements, in_model: list[EffectSpec], settings: Diagnose
) -> list[EffectSpec]:
    """Candidate effects for ``data``, leaving out those in the model and those the settings exclude."""
    out: list[EffectSpec] = []
    free = {e.name for e in kinematics.parameters.entries if e.free}
    compliance = {c.joint: c for c in compliance_candidates(kinematics, data)}
    allowed = set(settings.candidates) if settings.candidates else None
    bending = {c.joint: c for c in bending_candidates(kinematics, data)} if allowed and "joint_bending" in allowed else {}
    coupled = coupling_pairs(kinematics.dof)
    for joint, name in enumerate(kinematics.joint_names, start=1):
        if f"{name}.k" not in free:  # six_parameter's free encoder scale is this effect already
            out.append(EffectSpec("encoder_scale", joint=joint))
        out += [EffectSpec("gear_harmonic", joint=joint, order=h) for h in range(1, settings.harmonic_orders + 1)]
        if joint in compliance:
            out.append(compliance[joint])
        if joint in bending:
            out.append(bending[joint])
        out += [coupling(joint, i) for i, j in coupled if j == joint]
        if "dir" in data.extras:
            out.append(EffectSpec("backlash", joint=joint))
    if "temperature" in data.extras:
        out.append(EffectSpec("thermal_drift", source="temperature"))
    elif "t" in data.extras:
        out.append(EffectSpec("thermal_drift", source="time"))
    out += device.candidate_effects({e.name for e in device.parameters.entries if e.free})
    taken = {e.id for e in in_model}
    return [c for c in out if c.id not in taken and (c.type not in OPT_IN if allowed is None else c.type in allowed)]
