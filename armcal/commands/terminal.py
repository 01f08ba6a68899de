"""Plain-text views of a spec for the terminal: what validate and fk print."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from armcal.support.errors import UserError, shown_text
from armcal.evaluate.grid import RADIAL
from armcal.kinematics.compiler import compile_robot
from armcal.kinematics.parallel_axes import parallel_axes
from armcal.kinematics.transforms import pose_from_matrix
from armcal.identify.precision import WEAK
from armcal.report.numbers import counted, improvement, median_improvement, p_value, task_noise
from armcal.results.breakdown import before_data, table_lines
from armcal.results.plausibility import WHY, status_words
from armcal.results.schema import TASK_TITLES, TaskSkipped
from armcal.spec import LoadedSpec
from armcal.kinematics.params import joint_kind
from armcal.support.units import from_internal, to_internal


NOISE_VERDICTS = {
    "residuals_too_large": "the residuals exceed the noise model (p < 1 %): check whether the model lacks an effect "
    "(the diagnosis), whether the declared noise is too small, and whether a parameter the spec holds should be free; "
    "the uncertainties are scaled by chi2/dof",
    "residuals_too_small": "the residuals are smaller than the noise model allows (chi2 in its lower 1 %): the declared "
    "noise is too large, so the uncertainties are overstated; check the device's noise in the spec",
}


def spec_summary(loaded: LoadedSpec) -> str:
    """One paragraph: robot, parameters, device and procedure of a valid spec."""
    spec = loaded.spec
    robot = spec.robot
    parameters = spec_parameters(spec)
    table = before_data(parameters.entries)
    free = sum(row["free"] for row in table.values())
    lines = [
        f"{loaded.path}: valid (sha256 {loaded.sha256[:12]})",
        f"  robot      {shown_text(robot.name, 'a name')}, serial {shown_text(robot.serial, 'one')}: {robot.dof} joints, convention {robot.convention}",
        f"  parameters {len(parameters)} ({free} free, {len(parameters) - free} held by the spec); `armcal run` splits the free ones"
        " into identified and not identifiable (from the data), and adds the effects its diagnosis finds:",
        *table_lines(table, "             "),
        f"  units      {robot.units.length}, {robot.units.angle}",
        f"  device     {spec.device.type}",
        f"  procedure  {spec.procedure.type}" + (f", validation {spec.validation.type}" if spec.validation else ""),
    ]
    for axes in parallel_axes(robot.chain()):
        done = [f"Hayati's {axes.name}.beta added (free, 0)"] if axes.beta_added else []
        done += [f"{axes.name}.d held"] if axes.d_held else []
        lines.append(f"  parallel   axes {axes.joint} and {axes.joint + 1}" + (": " + ", ".join(done) if done else ""))
    return "\n".join(lines)


def spec_parameters(spec):
    """Every parameter a run of the spec starts with: the robot's, the instrument's, the declared effects'."""
    from armcal.devices import device_model
    from armcal.effects.library import from_spec
    from armcal.effects.measurement import EffectSet
    from armcal.identify.problem import combined_parameters

    return combined_parameters(compile_robot(spec.robot.chain()), device_model(spec), EffectSet(tuple(from_spec(e) for e in spec.effects)))


def parse_joint_values(loaded: LoadedSpec, text: str) -> np.ndarray:
    """Joint values 'v1,v2,...' in the spec's units -> internal units, checked against the limits."""
    robot = loaded.spec.robot
    parts = [p for p in text.replace(" ", "").split(",") if p]
    if len(parts) != robot.dof:
        raise UserError(f"--q needs {robot.dof} joint values, got {len(parts)}")
    values = []
    for i, (part, joint) in enumerate(zip(parts, robot.joints), start=1):
        kind = joint_kind(joint.type)
        unit = robot.units.of(kind)
        try:
            value = to_internal(part, kind, unit)
        except ValueError as exc:
            raise UserError(f"--q joint {i}: {exc}") from None
        low, high = joint.limits
        if not low <= value <= high:
            limits = ", ".join(f"{from_internal(v, kind, unit):g}" for v in joint.limits)
            raise UserError(f"--q joint {i} = {part} lies outside its limits [{limits}] {unit}")
        values.append(value)
    return np.array(values)


def forward_kinematics_report(loaded: LoadedSpec, q_text: str, target: str | None) -> str:
    """The nominal pose of the tool (or a target) at one configuration, in the spec's units."""
    robot = loaded.spec.robot
    model = compile_robot(robot.chain())
    q = parse_joint_values(loaded, q_text)
    if target is not None and target not in model.targets:
        raise UserError(f"unknown target '{target}'; targets: {', '.join(model.targets) or 'none'}")
    T = model.target_poses(target, q)[0] if target else model.tool_poses(q)[0]
    length, angle = robot.units.length, robot.units.angle
    x, y, z, rz, ry, rx = pose_from_matrix(T)
    position = ", ".join(f"{from_internal(v, 'length', length):.4f}" for v in (x, y, z))
    angles = ", ".join(f"{from_internal(v, 'angle', angle):.4f}" for v in (rz, ry, rx))
    rows = "\n".join("    [" + "  ".join(f"{v:11.6f}" for v in row[:3]) + f"  {from_internal(row[3], 'length', length):12.4f} ]" for row in T[:3])
    return (
        f"{target or 'tool'} pose of {robot.name} (nominal) at q = [{q_text}]\n"
        f"  position ({length}):              {position}\n"
        f"  rotation Rz, Ry, Rx ({angle}):     {angles}\n"
        f"  matrix (rotation | position in {length}):\n{rows}"
    )


VARIANCE_VERDICTS = {
    "consistent": "consistent with the declared {declared:.4g} {unit}",
    "declared_too_small": "the declared {declared:.4g} {unit} is too small ({p}): the instrument or the model is worse than declared",
    "declared_too_large": "the declared {declared:.4g} {unit} is too large ({p})",
}


def noise_lines(noise) -> list[str]:
    """The noise estimated from the data, one line per group, each against its declared sigma."""
    lines = [f"  noise from the data ({noise.method.split(' (')[0]}, {counted(noise.rounds, 'round')}"
             + ("" if noise.converged else ", NOT converged") + "):"]
    for g in noise.groups:
        line = f"    {g.group}: sigma {g.sigma:.4g} +- {g.std:.2g} {g.unit} per reading ({g.readings} readings)"
        if g.test is not None:
            line += "; " + VARIANCE_VERDICTS[g.test.verdict].format(declared=g.declared, unit=g.unit, p=p_value(g.test.p_value))
        lines.append(line)
    return lines


IMPLAUSIBLE_SHOWN = 10  # values listed on the terminal; results.json and the certificate hold them all


def implausible_lines(r) -> list[str]:
    """One line per identified robot value beyond its tolerance (results/plausibility.py)."""
    if r.plausibility is None or not r.plausibility.implausible:
        return []
    p = r.plausibility
    where = "robot.tolerance" if p.from_spec else "the default; set robot.tolerance"
    lines = [f"  implausible: {counted(len(p.implausible), 'identified robot value')} beyond {p.length:g} {p.length_unit} / "
             f"{p.angle:g} {p.angle_unit}{'' if p.scale is None else f' / {p.scale:g} (encoder scales)'} of nominal ({where})"]
    for v in p.implausible[:IMPLAUSIBLE_SHOWN]:
        std = f", std {v.std:.3g} {v.unit}" if v.std is not None else ""
        lines.append(f"    {v.name}: {v.value:.6g} {v.unit}, {v.deviation:+.4g} {v.unit} from nominal {v.nominal:.6g}{std}: {WHY[v.why]}")
    if len(p.implausible) > IMPLAUSIBLE_SHOWN:
        lines.append(f"    and {len(p.implausible) - IMPLAUSIBLE_SHOWN} more (results.json: plausibility)")
    return lines


def weak_lines(r) -> list[str]:
    """The robot values held because the data determine them too poorly (identify/precision.py), with their stds."""
    weak = [(f.name, f.reason.removeprefix(WEAK + ": ")) for f in r.identifiability.fixed if f.reason.startswith(WEAK)]
    if not weak:
        return []
    lines = [f"  held at nominal, {WEAK} (values the data determine too poorly to fit; measure poses that move them):"]
    lines += [f"    {name}: {why}" for name, why in weak[:IMPLAUSIBLE_SHOWN]]
    if len(weak) > IMPLAUSIBLE_SHOWN:
        lines.append(f"    and {len(weak) - IMPLAUSIBLE_SHOWN} more (results.json: identifiability.fixed)")
    return lines


def run_summary(outcome) -> str:
    """What `armcal run` prints: status, identifiability, residuals before/after, files written."""
    r = outcome.results
    unit = r.device.unit
    cal = r.residuals.calibration
    lines = [
        f"{shown_text(r.robot.name, 'a name')} ({shown_text(r.robot.serial, 'a serial')}): {status_words(r.status, r.plausibility)} ({r.solver.reason}, {counted(r.solver.iterations, 'iteration')})",
        *implausible_lines(r),
        f"  identified {r.identifiability.rank} of {r.identifiability.n_parameters} parameters, "
        f"condition number {r.identifiability.condition_number:.3g}",
        *(table_lines(r.identifiability.breakdown) if r.identifiability.breakdown else []),
        *weak_lines(r),
        f"  calibration RMS {cal.before.rms:.4g} -> {cal.after.rms:.4g} {unit} (x{r.improvement_factor.calibration:.3g})",
    ]
    if r.residuals.validation is not None:
        val = r.residuals.validation
        lines.append(f"  validation  RMS {val.before.rms:.4g} -> {val.after.rms:.4g} {unit} (x{r.improvement_factor.validation:.3g})")
    if r.noise is not None:
        lines += noise_lines(r.noise)
    lines.append(f"  noise check chi2/dof = {r.noise_check.chi2 / r.noise_check.dof:.3g} ({p_value(r.noise_check.p_value)})"
                 + (" (with the estimated sigmas: 1 wherever every group is estimated)" if r.noise is not None else ""))
    if r.noise_check.verdict != "consistent":
        lines.append(f"  {NOISE_VERDICTS[r.noise_check.verdict]}")
    lines += cause_lines(r, r.spec.path)
    for flat in r.identifiability.flat_directions:
        moved = ", ".join(name for name, _ in flat.parameters)
        lines.append(f"  flat direction at the solution: singular value {flat.ratio:.2g} of the largest, along {moved}")
    lines += held_out_lines(r)
    lines += residual_model_lines(r)
    if r.identifiability.unidentifiable:
        lines.append(f"  not identifiable from these data: {', '.join(r.identifiability.unidentifiable)}")
    lines += task_lines(r)
    lines += conformity_lines(r)
    lines += [f"  warning: {w}" for w in r.warnings]
    written = ["results.json", "calibrated.yaml", "certificate.html"] + (["certificate.pdf"] if (outcome.out_dir / "certificate.pdf").exists() else [])
    lines.append(f"  wrote {', '.join(written)} in {outcome.out_dir}")
    return "\n".join(lines)


def task_lines(r) -> list[str]:
    """Each evaluation task the spec asks for: where it stood and what calibration gained, or why it was skipped."""
    lines = []
    for task, name in TASK_TITLES.items():
        block = getattr(r.evaluation, task)
        if block is None:
            continue
        if isinstance(block, TaskSkipped):
            lines.append(f"  {name}: skipped: {block.skipped}")
        elif task == "grid_task":
            noise = lambda unit: task_noise(r.device.noise_sigma, r.device.unit, unit, block.centre, block.unit)  # noqa: E731
            factors = [improvement(row.design, row.calibrated, noise(row.unit)) for row in block.indices]
            lines.append(f"  {name}: {len(factors)} indices, {median_improvement(factors)}; {block.placement}")
        else:
            cube, worst = block.cube, lambda key: max(getattr(row, key) for row in block.poses)  # noqa: E731
            lines.append(f"  {name} (side {cube.side:.4g} {cube.unit}): AP at P1-P5 at most {worst('design'):.4g} -> "
                         f"{worst('calibrated'):.4g} {cube.unit}; {cube.placement}")
    return lines


def conformity_lines(r) -> list[str]:
    """The acceptance verdict, the history given and whether the data are simulated, as the certificate states them."""
    lines = []
    a = r.acceptance
    if a is not None:
        guard = f" = tolerance {a.tolerance:.4g} - U {a.expanded_uncertainty:.2g}" if a.decision_rule == "guarded" else ""
        lines.append(f"  acceptance: {a.verdict.upper()} ({a.statistic} {a.value:.4g} {a.unit}, limit {a.acceptance_limit:.4g}{guard} {a.unit}, {a.decision_rule} rule)")
    if r.history:
        changed = sum(len(h.significant) for h in r.history)
        lines.append(f"  history: {len(r.history)} earlier calibration(s) of this serial, {changed} significant parameter change(s)")
    if r.simulated is not None and (r.simulated.calibration or r.simulated.validation):
        lines.append("  SIMULATED DATA (truth.json beside the data): not a calibration of a physical robot")
    return lines


def study_summary(study) -> str:
    """What `armcal montecarlo` prints: per point the spread of the indices under both controllers, the trend."""
    s = study.summary
    sweep = s["sweep"]
    lines = [f"Monte-Carlo study: {s['runs']} robots per point, {s['method']}, {s['backend']}, {s['elapsed_s']:.1f} s"]
    grid = s["grid"]
    centre = ", ".join(f"{v:.4g}" for v in grid["centre"])
    lines.append(f"  grid: centre ({centre}) {grid['unit']}, scale {grid['scale']:.3g}; {grid['placement']}")
    radial = lambda point, controller: [r[controller]["std"] for r in point["indices"] if r["index"] in RADIAL]  # noqa: E731
    unit = s["points"][0]["indices"][0]["unit"]
    header = f"  {sweep['variable'] + ' (' + sweep['unit'] + ')' if sweep else 'point':>24s}  radial error std ({unit}), vertices 1/4/5/8: design | calibrated"
    lines.append(header)
    for point in s["points"]:
        label = f"{point['value']:g}" if sweep else "spec"
        design, calibrated = (" ".join(f"{v:.4f}" for v in radial(point, c)) for c in ("design", "calibrated"))
        failed = s["runs"] - point["converged"]
        lines.append(f"  {label:>24s}  {design} | {calibrated}" + (f"  ({failed} fits not converged)" if failed else ""))
    if s["trend"] and s["trend"]["median_slope"] is None:
        lines.append("  trend: no index varies from robot to robot (no errors, no noise?); nothing to fit")
    elif s["trend"]:
        t = s["trend"]
        lines.append(
            f"  trend of the {t['controller']} indices' std: slope {t['median_slope']:.2f} (median of 34; lengths {t['length_slope']:.2f},"
            f" orientations {t['orientation_slope']:.2f}, radial {t['radial_slope']:.2f});"
            f" {t['source']} found {t['expected_slope']:g}"
        )
    if s.get("unobserved"):
        which = "absolute orientation indices (vertices 1/4/5/8)" if len(s["unobserved"]["indices"]) == 4 else "orientation indices (absolute and relative)"
        lines.append(f"  {which}, calibrated: {s['unobserved']['reason']}")
    if s.get("accuracy_vs_poses"):
        lines += _accuracy_lines(s["accuracy_vs_poses"])
    lines.append(f"  wrote {', '.join(p.name for p in study.files)} in {study.out_dir}")
    return "\n".join(lines)


def _accuracy_lines(curve: dict) -> list[str]:
    """The predicted held-out accuracy of N planned poses beside N and 3N random ones."""
    shown = lambda v: "not identified" if v is None else f"{v:.4g}"  # noqa: E731
    lines = [f"  held-out accuracy ({curve['unit']}, mean of {curve['robots']} robots): {curve['definition']}",
             f"  {'poses N':>10s}  {'planned (D)':>14s}  {'random N':>14s}  {'random 3N':>14s}"]
    for k, count in enumerate(curve["counts"]):
        lines.append(f"  {count:>10d}  {shown(curve['planned']['D'][k]):>14s}  {shown(curve['random']['1'][k]):>14s}  {shown(curve['random']['3'][k]):>14s}")
    return lines


def counted(count: int, noun: str) -> str:
    """'1 spec', '2 specs'."""
    return f"{count} {noun}{'' if count == 1 else 's'}"


def batch_summary(outcomes: list[dict]) -> str:
    """What `armcal batch` prints: one line per spec."""
    unexplained = sum(bool(o.get("unexplained")) for o in outcomes)
    lines = [f"{counted(len(outcomes), 'spec')}: {sum(o['exit_code'] == 0 for o in outcomes)} converged"]
    lines[0] += f", {unexplained} with residuals unexplained" if unexplained else ""
    for o in outcomes:
        if o["status"] in ("error", "internal_error"):
            lines.append(f"  {o['spec']}: {o['error']}" + (" (traceback in the fleet summary)" if o["status"] == "internal_error" else ""))
            continue
        before, after = o["calibration_rms"]
        held = f", validation {o['validation_rms'][0]:.4g} -> {o['validation_rms'][1]:.4g}" if o["validation_rms"] else ""
        unexplained = ", residuals unexplained" if o.get("unexplained") else ""
        lines.append(f"  {o['spec']}: {o['robot']} {o['status']}{unexplained}, RMS {before:.4g} -> {after:.4g} {o['unit']}{held}; {o['out_dir']}")
        if o.get("noise_verdict", "consistent") != "consistent":
            lines.append(f"    {NOISE_VERDICTS[o['noise_verdict']]}")
    return "\n".join(lines)


def _reason_of(label: str) -> str:
    """'c1-s1: joint limit (j2)' -> 'joint limit'."""
    return label.split(": ", 1)[-1].split(" (")[0]


def simulation_summary(loaded: LoadedSpec, campaign) -> str:
    """What `armcal simulate` prints after the files: per data set the samples, the planned poses dropped by reason
    and where (latitude, longitude), the readings the simulated robot lost, and the spec keys behind each reason."""
    from armcal.procedures.shells import DROP_REASONS

    spec = loaded.spec
    lines, reasons = [], {}
    for name, data in (("calibration", campaign.calibration), ("validation", campaign.validation)):
        if data is None:
            continue
        dropped, lost = campaign.dropped.get(name, {}), campaign.lost.get(name, {})
        planned = len(data) + sum(dropped.values()) + sum(lost.values())
        line = f"  {name}: {len(data)} samples of {planned} planned"
        if dropped:
            line += f"; {sum(dropped.values())} planned poses dropped"
        if lost:
            line += f"; {sum(lost.values())} readings lost on the simulated robot"
        lines.append(line)
        totals: dict[str, int] = {}
        for label, count in dropped.items():
            totals[label.split(": ", 1)[-1]] = totals.get(label.split(": ", 1)[-1], 0) + count
        if totals:
            lines.append("    dropped: " + ", ".join(f"{count} {why}" for why, count in sorted(totals.items(), key=lambda kv: -kv[1])))
        where = campaign.where.get(name, {})
        for label, count in dropped.items():
            places = where.get(label, [])
            pairing, _, why = label.rpartition(": ")
            lines.append(f"      {pairing + ': ' if pairing else ''}{count} {why}" + (f" ({'; '.join(places)})" if places else ""))
            reasons.setdefault(_reason_of(label), DROP_REASONS.get(_reason_of(label)))
        if lost:
            unit = spec.robot.units.length
            what, reason, keys = spec.device.out_of_range(lambda v: f"{from_internal(v, 'length', unit):g} {unit}")
            lines.append(f"    lost: {sum(lost.values())} readings {what} on the simulated robot, planned within it on the nominal "
                         f"model: the robot's errors moved them out ({', '.join(f'{k} {n}' for k, n in lost.items())})")
            reasons.setdefault(reason, keys)
    if any(reasons.values()):  # a reason without spec keys (a random keyed pose out of reach) has nothing to look at
        lines.append("  look at: " + "; ".join(f"{why} -> {keys}" for why, keys in reasons.items() if keys))
    return "\n".join(lines)


def residual_model_lines(r) -> list[str]:
    """The learned residual model's verdict and held-out figures (diagnose.residual_model; results.json's residual_model)."""
    m = r.residual_model
    if m is None:
        return []
    test = f"held-out change {m.z:+.1f} standard errors, needs below -{m.threshold:g}, {m.folds} folds along joint {m.folds_along_joint}"
    if not m.accepted:
        return [f"  learned residual model (gp): not accepted ({test}): the physical model stands alone"]
    lines = [f"  learned residual model (gp): accepted ({test})"]
    for label, f in (("held-out (k-fold)", m.held_out), ("validation", m.validation)):
        if f is None:
            continue
        if f.rms_3d_physical is not None:
            figure = f"3D RMS {f.rms_3d_physical:.4g} -> {f.rms_3d_learned:.4g} mm"
        else:
            figure = ", ".join(f"{c.coordinate} RMS {c.physical:.4g} -> {c.learned:.4g} {c.unit}" for c in f.per_coordinate)
        lines.append(f"    {label}: {figure} (physical -> physical + learned); {f.outside} of {f.readings} readings outside the "
                     "calibrated region, not corrected")
    lines.append(f"    {m.carried}")
    return lines


def held_out_lines(r) -> list[str]:
    """Why the held-out data are predicted worse than the noise, when they are (evaluate/held_out_check.py)."""
    check = r.held_out_check
    if check is None or check.verdict == "consistent":
        return []
    head = (f"  held-out check: the held-out residuals are {check.rms_over_noise:.3g} noise sigmas RMS; noise and the parameters' "
            f"uncertainty predict {check.expected_rms_over_noise:.3g} (chi2 {check.chi2:.4g} on {check.dof}, {p_value(check.p_value)})")
    if check.verdict == "parameter_uncertainty":
        flat = [name for f in r.identifiability.flat_directions for name, _ in f.parameters]
        along = f" (the flat direction: {', '.join(dict.fromkeys(flat))})" if flat else ""
        return [head, f"    {check.parameter_share:.0%} of it is the parameters' own uncertainty: the calibration poses leave them poorly "
                      f"determined{along}. Add poses that move them (armcal plan SPEC --extend CALIBRATION.csv), or hold values "
                      "known from a measurement (vary: false) [procedure, robot.targets, device]"]
    causes = ["the instrument moved between the two data sets (data.instrument_moved: true)"]
    weak = [f.name for f in r.identifiability.fixed if f.reason.startswith(WEAK)]
    if weak:
        causes.insert(0, f"a value held at nominal as {WEAK} differs from the robot's: {', '.join(weak)} (give its measured "
                         "value, or add poses that move it: armcal plan SPEC --extend CALIBRATION.csv)")
    if r.noise_check.verdict == "residuals_too_large":  # the calibration data exceed the declared noise already
        causes.insert(0, f"the declared noise is too small: the calibration residuals exceed it too (noise check chi2/dof = "
                         f"{r.noise_check.chi2 / r.noise_check.dof:.3g}) [device.noise]")
    if check.held_out_only:
        causes.append(f"a value only the held-out data use, held at its spec value: {', '.join(check.held_out_only)} (its spec key)")
    causes.append("an effect the calibration poses cannot see (held-out poses outside the calibrated region: procedure, validation)")
    return [head, "    more than the calibrated model explains; likely causes: " + "; ".join(causes)]


SHARED_REASON = re.compile(r"\(([^()]{30,})\)")  # a long parenthesis: said once when several causes share it


def cause_lines(r, spec_path: str) -> list[str]:
    """The likely causes of residuals above the noise model, ranked, each with its spec key and line; a reason in
    parentheses that several causes share is given once, below them, by its letter."""
    causes = r.noise_check.causes
    if not causes:
        return []
    seen = [reason for cause in causes for reason in dict.fromkeys(SHARED_REASON.findall(cause.text))]
    shared = [reason for reason in dict.fromkeys(seen) if seen.count(reason) > 1]
    letters = {reason: chr(ord("a") + i) for i, reason in enumerate(shared[:26])}
    lines = [f"  likely causes of chi2/dof = {r.noise_check.chi2 / r.noise_check.dof:.3g}, by the evidence of this run (look at):"]
    for number, cause in enumerate(causes, start=1):
        text = SHARED_REASON.sub(lambda m: f"(reason {letters[m.group(1)]} below)" if m.group(1) in letters else m.group(0), cause.text)
        where = f" [{cause.spec_key}" + (f", {Path(spec_path).name}:{cause.line}" if cause.line else "") + "]" if cause.spec_key else ""
        lines.append(f"    {number}. {text}{where}")
    lines += [f"    reason {letter}: {reason}" for reason, letter in letters.items()]
    return lines


def where_run_reads(loaded: LoadedSpec, written: list) -> str:
    """After `armcal simulate`: the files are simulated (truth.json marks them), and whether `armcal run` reads them
    (the spec's data paths are relative to the spec) - if not, the data section that would point at them."""
    import os

    data = loaded.spec.data
    csvs = [Path(p) for p in written if Path(p).suffix == ".csv"]
    lines = [f"  simulated data: truth.json beside {'them' if len(csvs) > 1 else 'it'} marks {'these files' if len(csvs) > 1 else 'this file'} "
             "(armcal run reports SIMULATED DATA while they are unchanged). Measuring for real? Keep the layout, replace the readings, "
             "and put your times in the t column or delete it: the simulated t is fake (simulate.time_step apart)"]
    folder = loaded.path.parent.resolve()
    wanted = {"calibration": data.calibration if data else None, "validation": data.validation if data else None}
    relative = [os.path.relpath(p.resolve(), folder) for p in csvs]
    reads = [folder / w for w in wanted.values() if w]
    if data is not None and all(any(p.resolve() == r.resolve() for r in reads) for p in csvs):
        return "\n".join(lines + [f"  `armcal run {loaded.path}` reads them (the spec's data section points here)"])
    names = dict(zip(("calibration", "validation"), relative))
    section = "data: {" + ", ".join(f"{k}: {v}" for k, v in names.items()) + "}"
    if data is None:
        lines.append(f"  note: the spec has no data section, so `armcal run` reads nothing; add {section}")
    else:
        looked = ", ".join(f"data.{k} = {w} -> {folder / w}" for k, w in wanted.items() if w)
        lines.append(f"  note: `armcal run` does not read these files: it reads the spec's data paths, relative to the spec ({looked}). "
                     f"Point the spec at them with {section}, or simulate without --out (it writes where the spec points)")
    return "\n".join(lines)
