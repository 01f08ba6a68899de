"""Why the residuals exceed the noise model: likely causes ranked by the evidence of the run, each with its spec key.

When the noise check fails after the fit (chi2/dof too large, p below
NOISE_CHECK_LEVEL), three kinds of evidence are at hand:

- parameters the spec holds (``vary: false``) that the data could move: for each
  group held together (a target's or a pivot's position, the robot's base, a
  joint's beta, the bar's length) its Jacobian columns at the solution are
  projected off the free ones, and the chi2 the linearised refit would remove is
  ||Q_c' r||^2 (r weighted by the declared sigmas; the score test of
  diagnose/score.py, in chi2 units): freeing the group would bring chi2/dof to
  (chi2 - drop) / (dof - k). A held beta where consecutive axes are parallel is
  named as Hayati's (kinematics/parallel_axes.py);
- the diagnosis' candidates that were significant but not accepted, or that the
  geometry absorbs (not distinguishable);
- the declared noise itself: if the model is complete, the instrument's sigma is
  sqrt(chi2/dof) times the declared one.

Groups whose drop is significant (score test, Bonferroni over the groups at
NOISE_CHECK_LEVEL) are listed by drop, then the candidates, then the noise.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import chdtrc

from armcal.diagnose.score import ABSORBED
from armcal.identify.uncertainty import NOISE_CHECK_LEVEL
from armcal.kinematics.parallel_axes import PARALLEL_DEG
from armcal.kinematics.params import parameter_group
from armcal.spec.locations import yaml_path

SHOWN = 4  # held groups named at most


def spec_key(name: str, spec) -> tuple[tuple, str]:
    """The spec location (loader loc) and the dotted key of a parameter name, e.g. robot.joints[0].beta (j1)."""
    path = yaml_path(name, spec)
    key = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in path).lstrip(".")
    if path[:2] == ["robot", "joints"]:
        key += f" ({spec.robot.joint_names()[path[2]]})"
    return tuple(path), key


def held_groups(parameters, held: set[str], device) -> dict[str, tuple[str, list[int]]]:
    """The spec-held, non-effect parameters of ``parameters`` by group (a target's x, y, z together), each with the
    group's label (the robot's groups from kinematics/params.py, the instrument's from its ``device`` model)."""
    groups: dict[str, tuple[str, list[int]]] = {}
    for i, e in enumerate(parameters.entries):
        if e.name in held and e.role != "effect":
            key, label = (device.parameter_group(e.name) if e.role == "device" else parameter_group(e)) or (e.name, e.name)
            groups.setdefault(key, (label, []))[1].append(i)
    return groups


def likely_causes(loaded, calibration, device) -> list[dict]:
    """The ranked causes of a failed noise check (module docstring), ``device`` the instrument's model; [] when the
    check passes."""
    identified = calibration.identified
    result = identified.least_squares
    uncertainty = result.uncertainty
    if uncertainty.verdict != "residuals_too_large" or identified.features is not None:
        return []
    spec = loaded.spec
    problem = calibration.problem
    parameters = problem.parameters
    names = parameters.names
    r, J = problem.evaluate(identified.theta)
    chi2, dof = float(r @ r), max(uncertainty.dof, 1)
    s2 = chi2 / dof
    base = [names.index(n) for n in result.identifiability.base]
    basis = np.linalg.qr(J[:, base])[0] if base else np.zeros((len(r), 0))
    held = {n for n, reason in result.identifiability.fixed if reason == "fixed in the spec"}
    groups = held_groups(parameters, held, device)
    joint_names = spec.robot.joint_names()
    causes = []
    tests = []
    for label, columns in groups.values():
        drop, k = _drop(J[:, columns], basis, r)
        if k:
            tests.append((label, columns, drop, k, float(chdtrc(k, drop / s2))))
    for label, columns, drop, k, p in sorted(tests, key=lambda t: -t[2]):
        if p > NOISE_CHECK_LEVEL / max(len(tests), 1) or len(causes) >= SHOWN:
            continue
        loc, key = spec_key(names[columns[0]], spec)
        fields = ", ".join(names[c].rpartition(".")[2] for c in columns)
        what = _what(label, names[columns[0]], spec, joint_names)
        causes.append({
            "kind": "held_by_spec",
            "parameters": [names[c] for c in columns],
            "spec_key": key.rsplit(".", 1)[0] + f".{{{fields}}}" if len(columns) > 1 else key,
            "line": _line(loaded, loc[:-1] if len(columns) > 1 else loc),
            "chi2_drop": drop,
            "dof": k,
            "p_value": p,
            "chi2_dof_after": (chi2 - drop) / max(dof - k, 1),
            "text": f"{what} held by the spec: freeing {fields} would lower chi2/dof to {(chi2 - drop) / max(dof - k, 1):.3g}"
                    f" (score {drop / s2:.3g} on {k} dof); give it as a plain number or vary: true",
        })
    if len(causes) > 1:
        columns = [c for cause in causes for c in (names.index(n) for n in cause["parameters"])]
        drop, k = _drop(J[:, columns], basis, r)
        causes.append({"kind": "held_by_spec_together", "parameters": [names[c] for c in columns], "spec_key": "", "line": None,
                       "chi2_drop": drop, "dof": k, "p_value": float(chdtrc(k, drop / s2)), "chi2_dof_after": (chi2 - drop) / max(dof - k, 1),
                       "text": f"all {len(causes)} freed together: chi2/dof {(chi2 - drop) / max(dof - k, 1):.3g}"})
    causes += _candidate_causes(calibration)
    causes.append(_noise_cause(loaded, s2))
    return causes


def _drop(columns: np.ndarray, basis: np.ndarray, r: np.ndarray) -> tuple[float, int]:
    """chi2 removed by freeing ``columns`` (linearised, off the free columns ``basis``) and its degrees of freedom."""
    norms = np.linalg.norm(columns, axis=0)
    projected = columns - basis @ (basis.T @ columns)
    kept = (np.linalg.norm(projected, axis=0) > ABSORBED * np.maximum(norms, 1e-300)) & (norms > 0)
    if not kept.any():
        return 0.0, 0
    q, R = np.linalg.qr(projected[:, kept])
    rank = int(np.sum(np.abs(np.diag(R)) > 1e-9 * np.abs(R).max()))
    q = q[:, :rank] if rank < q.shape[1] else q
    return float(np.sum((q.T @ r) ** 2)), rank


def _what(label: str, first: str, spec, joint_names: list[str]) -> str:
    """A group named as the user knows it: its ``label`` ('target s1's position'), or "Hayati's beta of parallel axes 2
    and 3"."""
    head, _, field = first.rpartition(".")
    if head in joint_names and field == "beta":
        i = joint_names.index(head)
        joint = spec.robot.joints[i]
        if i + 1 < len(joint_names) and abs(math.sin(joint.alpha.value)) <= math.sin(math.radians(PARALLEL_DEG)):
            return f"Hayati's beta of the parallel axes {i + 1} and {i + 2} ({first}; convention mdh, or leave beta out in dh)"
    return label


def _candidate_causes(calibration) -> list[dict]:
    """The diagnosis' last round: significant candidates it did not accept, and those the geometry absorbs."""
    diagnosis = calibration.diagnosis
    if diagnosis is None or not diagnosis.rounds:
        return []
    last = diagnosis.rounds[-1]
    out = []
    for test in last.tests:
        if test.significant and (last.accepted is None or test.effect != last.accepted):
            out.append({"kind": "candidate_not_accepted", "parameters": [], "spec_key": "effects", "line": None, "chi2_drop": test.statistic,
                        "dof": test.dof, "p_value": test.p_value, "chi2_dof_after": None,
                        "text": f"{effect_label(test.effect)}: significant (score {test.statistic:.3g} on {test.dof} dof) but not confirmed "
                                f"by the held-out folds ({last.note}); declare it under effects: if you know the mechanism"})
    absorbed = [effect_label(t.effect) for t in last.tests if not t.distinguishable]
    if absorbed:
        out.append({"kind": "candidates_not_distinguishable", "parameters": [], "spec_key": "effects", "line": None, "chi2_drop": 0.0,
                    "dof": 0, "p_value": 1.0, "chi2_dof_after": None,
                    "text": f"not distinguishable from the geometry on these poses: {', '.join(absorbed[:6])}"
                            + (f" and {len(absorbed) - 6} more" if len(absorbed) > 6 else "")
                            + "; other poses (procedure) could tell them apart"})
    return out


def effect_label(effect) -> str:
    parts = [effect.type] + ([f"joint {effect.joint}"] if effect.joint else []) + ([f"order {effect.order}"] if effect.order else [])
    parts += [f"{effect.kind.part_key} {effect.part}"] if effect.part else []
    return " ".join(parts)


def _noise_cause(loaded, s2: float) -> dict:
    """The declared noise, if the model is complete: sqrt(chi2/dof) times too small."""
    device = loaded.spec.device
    fields = device.noise_fields()
    field = fields[0] if fields else "noise"
    return {"kind": "declared_noise", "parameters": [], "spec_key": f"device.{field}", "line": _line(loaded, ("device", field)),
            "chi2_drop": None, "dof": None, "p_value": None, "chi2_dof_after": 1.0,
            "text": f"the declared noise (device.{field}): if the model is complete the readings scatter {math.sqrt(s2):.3g} times "
                    f"more than declared; check the instrument's noise, or estimate it from the data (device.estimate_noise: true)"}


def _line(loaded, loc) -> int | None:
    from armcal.spec.loader import spec_line

    return spec_line(loaded, loc)
