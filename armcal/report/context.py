"""The certificate's context: plain, already formatted values built from the Results model (results.json) by its
attributes (no logic in templates)."""

from __future__ import annotations

import base64
import math

from armcal.evaluate.multiple_testing import ALPHA
from armcal.identify.uncertainty import NOISE_CHECK_LEVEL
from armcal.report.numbers import AT_THE_NOISE, counted, decimals, fixed, given, improvement, measured, p_value, powers_of_ten, ratio, significant, task_noise
from armcal.results.plausibility import WHY, status_words
from armcal.results.schema import (TASK_TITLES, AcceptanceResult, Campaign, Candidate, Diagnosis, EffectResult, Evaluation, FeaturesResult,
                                   FlatDirection, GridIndex, GridTaskResult, HistoryEntry, IsoPose, IsoTaskResult, NoiseEstimate, ParallelAxesInfo,
                                   ParameterChange, ParameterResult, Plausibility, Residuals, Residuals3D, ResidualModelResult, Results, RobotInfo,
                                   SimulatedData, SpecInfo, TaskSkipped)
from armcal.support.units import ANGLE_UNITS, LENGTH_UNITS, factor

PLOT_TITLES = {
    "residual_histogram.svg": "Residuals after calibration, with the Gaussian of the noise model",
    "residual_vs_joint.svg": "Residual magnitude against each joint's reading (before and after the diagnosis)",
    "residual_vs_torque.svg": "Residual magnitude against the gravity torque about each joint",
    "residual_per_key.svg": "Residual RMS per target, pivot pairing or station, design model and calibrated",
    "residual_vs_longitude.svg": "Residual magnitude along the longitudes of the hemispherical shells (Goswami Fig. 3)",
    "residual_vs_t.svg": "Residual magnitude against time",
    "residual_vs_temperature.svg": "Residual magnitude against temperature",
}


FULL_TURN = {unit: 2 * math.pi / factor("angle", unit) for unit in ANGLE_UNITS}
WIDE_PLOTS = {"residual_vs_joint.svg", "residual_vs_torque.svg"}  # panels per joint; the others print smaller


class Shown:
    """The certificate's units and resolution: every length in one unit (report.unit, else the spec's), shown to the
    decimal of the instrument's noise per reading where a value has no uncertainty of its own (report/numbers.py)."""

    def __init__(self, unit: str | None, reading_unit: str, noise_sigma: float | None):
        self.unit = unit or "mm"
        self.reading_unit = reading_unit
        self.noise_sigma = noise_sigma  # in reading_unit
        self.noise = self.length(noise_sigma, reading_unit) if noise_sigma else None
        self.places = decimals(self.noise)

    @classmethod
    def of(cls, results: Results) -> "Shown":
        """The units and resolution of ``results``' certificate (report.unit, the device's unit and noise)."""
        return cls(results.report.unit, results.device.unit, results.device.noise_sigma)

    def length(self, value: float | None, unit: str) -> float | None:
        """``value`` in ``unit`` as the certificate's unit if ``unit`` is a length; unchanged otherwise."""
        if value is None or unit not in LENGTH_UNITS:
            return value
        return value * factor("length", unit) / factor("length", self.unit)

    def unit_of(self, unit: str) -> str:
        """The unit a value in ``unit`` is shown in; a dimensionless ratio says so."""
        return self.unit if unit in LENGTH_UNITS else "1 (ratio)" if unit == "1" else unit

    def reading(self, value: float | None) -> str:
        """A residual statistic (reading unit) at the instrument's resolution, in the certificate's unit."""
        return fixed(self.length(value, self.reading_unit), self.places)


def _stats_rows(residuals: Residuals, shown: Shown) -> list[dict]:
    rows = []
    for name, pair in (("calibration", residuals.calibration), ("validation", residuals.validation)):
        if pair is None:
            continue
        for moment, s in (("before", pair.before), ("after", pair.after)):
            rows.append(
                {
                    "data": f"{name}, {'design model' if moment == 'before' else 'calibrated model'}",
                    "n": str(s.n),
                    "rms": shown.reading(s.rms),
                    "mean": shown.reading(s.mean),
                    "std": shown.reading(s.std),
                    "max": shown.reading(s.max_abs),
                    "factor": ratio(pair.before.rms, s.rms, shown.noise_sigma) if moment == "after" else "",
                }
            )
    return rows


def _difference(parameter: ParameterResult) -> float:
    """Identified minus nominal; for an angle the shorter way round (-179.99 against 180 is 0.01, not -359.99)."""
    difference = parameter.value - parameter.nominal
    turn = FULL_TURN.get(parameter.unit)
    return difference if turn is None else (difference + turn / 2) % turn - turn / 2


def _parameter_rows(parameters: list[ParameterResult], shown: Shown) -> list[dict]:
    """Identified values to the decimal of their expanded uncertainty; held ones as the spec gave them."""
    rows = []
    for p in parameters:
        to = lambda value: shown.length(value, p.unit)  # noqa: E731
        expanded = to(2 * p.std) if p.std is not None else None
        if p.free and expanded is not None:
            value = lambda v: measured(v, expanded)  # noqa: E731
        else:
            value = lambda v: significant(v, 12)  # noqa: E731  (12 digits: a unit conversion's last bits)
        rows.append(
            {
                "name": p.name,
                "unit": shown.unit_of(p.unit),
                "nominal": value(to(p.nominal)),
                "value": value(to(p.value)),
                "difference": value(to(_difference(p))),
                "expanded": measured(expanded, expanded) if expanded is not None else "",
                "mark": "identified" if p.free else "held",
            }
        )
    return rows


def _decision(candidates: list[Candidate], alpha: float | None) -> str:
    """How a round decided, in words: the score tests, Holm's step-down over the distinguishable candidates at the
    family-wise level, and where the smallest p-value stands against its threshold (diagnose/score.py)."""
    tested = sorted(c.p_value for c in candidates if c.distinguishable)
    if not tested:
        return "no candidate could be told apart from the geometry"
    rule = f"score test of each candidate (chi-square on its columns), Holm's step-down over {counted(len(tested), 'distinguishable candidate')}"
    if alpha is None:
        return rule
    threshold = alpha / len(tested)
    verdict = "below" if tested[0] <= threshold else "not below"
    return (f"{rule} at a family-wise {given(alpha)}: the smallest, {p_value(tested[0])}, is {verdict} its threshold "
            f"{given(alpha)} / {len(tested)} = {significant(threshold, 2)}")


def _diagnosis(diagnosis: Diagnosis, shown: Shown) -> dict:
    rms = lambda pair: f"{shown.reading(pair.calibration)} / {shown.reading(pair.validation)} {shown.unit_of(shown.reading_unit)}"  # noqa: E731
    rounds = []
    for i, r in enumerate(diagnosis.rounds, start=1):
        parameters = []
        for p in r.accepted.parameters if r.accepted else ():
            u = shown.length(2 * p.std, p.unit) if p.std is not None else None
            parameters.append(f"{p.name} = {measured(shown.length(p.value, p.unit), u)} +- {measured(u, u)} {shown.unit_of(p.unit)} (k=2)")
        top = sorted((c for c in r.candidates if c.distinguishable), key=lambda c: c.p_value)[:3]
        rounds.append(
            {
                "number": str(i),
                "outcome": r.note,
                "parameters": parameters,
                "smallest": ", ".join(f"{c.id} (S {c.statistic:.1f} on {c.dof} dof, {p_value(c.p_value)})" for c in top) or "none",
                "decision": _decision(r.candidates, diagnosis.alpha),
                "not_distinguishable": ", ".join(c.id for c in r.candidates if not c.distinguishable) or "none",
                "before": rms(r.rms_before),
                "after": rms(r.rms_after),
            }
        )
    partly = [r.accepted for r in diagnosis.rounds if r.partly_explained and r.accepted]
    return {
        "rounds": rounds,
        "unexplained": diagnosis.unexplained,
        "added": ", ".join(_effect_name(e) for e in diagnosis.added_effects) or "none",
        "partly": ", ".join(_effect_name(e) for e in partly),
        "chosen_on": diagnosis.chosen_on or "the data given (not recorded)",
    }


def _learned(model: ResidualModelResult | None, shown: Shown) -> dict | None:
    """The learned residual model's section: its verdict, then per coordinate and 3D the held-out RMS of the physical
    model against physical + learned (k-fold folds, then, for an accepted model, the validation data), in the
    certificate's unit."""
    if model is None:
        return None
    value = lambda v, unit: fixed(shown.length(v, unit), shown.places if unit in LENGTH_UNITS else 4)  # noqa: E731
    rows = []
    judged = [("calibration poses, k-fold (held out)", model.held_out)]  # the test; a model not accepted is applied nowhere else
    for label, figures in judged + ([("validation (held out)", model.validation)] if model.accepted else []):
        if figures is None:
            continue
        for c in figures.per_coordinate:
            rows.append({"data": label, "coordinate": c.coordinate, "unit": shown.unit_of(c.unit),
                         "physical": value(c.physical, c.unit), "learned": value(c.learned, c.unit)})
        if figures.rms_3d_physical is not None:
            rows.append({"data": label, "coordinate": "3D distance", "unit": shown.unit_of("mm"),
                         "physical": value(figures.rms_3d_physical, "mm"), "learned": value(figures.rms_3d_learned, "mm")})
    verdict = "accepted" if model.accepted else "not accepted: the physical model stands alone and no correction is applied"
    outside = [f"{f.outside} of {f.readings} {label} readings" for label, f in (("k-fold held-out", model.held_out), ("validation", model.validation)) if f]
    hyper = "; ".join(
        f"{h.coordinate} at {h.at}: signal std {value(h.signal_std, h.unit)}, noise std {value(h.noise_std, h.unit)} {shown.unit_of(h.unit)}, "
        f"length scales {', '.join(f'{significant(v, 2)} {u}' for v, u in zip(h.length_scales, model.joint_units))}, "
        f"{h.training_readings} training readings"
        for h in model.hyperparameters
    )
    return {
        "verdict": verdict,
        "test": f"held-out change {model.z:+.1f} standard errors (accepted below -{model.threshold:g}), {model.folds} folds along joint {model.folds_along_joint}",
        "rows": rows,
        "outside": ", ".join(outside),
        "fraction": f"{model.outside_fraction:g}",
        "hyperparameters": hyper,
        "carried": model.carried,
    }


def _effect_name(effect: EffectResult) -> str:
    return effect.type + (f" joint {effect.joint}" if effect.joint else "")


def _distance_rows(block: Residuals3D | None, shown: Shown) -> list[dict]:
    """Per-pose 3D distance statistics, before and after, for calibration and validation (results in mm)."""
    rows = []
    for name, pair in (("calibration", block.calibration), ("validation", block.validation)) if block else ():
        for moment, s in (("before", pair.before), ("after", pair.after)) if pair else ():
            label = f"{name}, {'design model' if moment == 'before' else 'calibrated model'}"
            at = lambda value: fixed(shown.length(value, block.unit), shown.places)  # noqa: E731
            rows.append({"data": label, "n": str(s.n), "mean": at(s.mean), "rms": at(s.rms), "max": at(s.max)})
    return rows


def _index_rows(rows: list[GridIndex] | list[IsoPose], label: str, shown: Shown, centre, centre_unit: str) -> list[dict]:
    """A task's index rows (results.json's free-form evaluation block): values in the certificate's unit at the
    instrument's resolution, the factor where it means something (report/numbers.improvement); a row whose values
    read as an earlier row's says so."""
    out, first = [], {}
    for r in rows:
        unit, name = r.unit, getattr(r, label)
        noise = task_noise(shown.noise_sigma, shown.reading_unit, unit, centre, centre_unit)
        places = decimals(shown.length(noise, unit), shown.places)
        design, calibrated = fixed(shown.length(r.design, unit), places), fixed(shown.length(r.calibrated, unit), places)
        twin = first.setdefault((unit, design, calibrated), name)
        out.append({
            "index": name + (f" (other points; equal to {twin}'s at these decimals)" if twin != name else ""),
            "unit": shown.unit_of(unit),
            "design": design,
            "calibrated": calibrated,
            "factor": improvement(r.design, r.calibrated, noise),
        })
    return out


def _grid(grid: GridTaskResult | None, shown: Shown) -> list[dict]:
    return _index_rows(grid.indices, "index", shown, grid.centre, grid.unit or "mm") if grid else []


def _features(block: FeaturesResult | None, shown: Shown) -> dict | None:
    """Stone's feature identification: each joint's features with their accuracy (6.11-6.13), pseudo-DH table."""
    if block is None:
        return None
    units = block.units
    length = lambda v: shown.length(v, units.length)  # noqa: E731
    return {
        "units": {"length": shown.unit, "angle": units.angle},
        "joints": [
            {
                "joint": str(j.joint),
                "radius": measured(length(j.radius), length(j.centre_sigma)),
                "range": fixed(j.range_deg, 1),
                "plane": measured(j.plane_sigma, j.plane_sigma),
                "centre": measured(length(j.centre_sigma), length(j.centre_sigma)),
            }
            for j in block.joints
        ],
        "table": [
            {"joint": str(row.joint), "theta_offset": fixed(row.theta_offset, 4), "d": fixed(length(row.d), 4), "a": fixed(length(row.a), 4),
             "alpha": fixed(row.alpha, 4)}
            for row in block.pseudo_dh
        ],
        "rms_features": shown.reading(block.residuals.s_model_features.rms),
        "rms_least_squares": shown.reading(block.residuals.least_squares.rms),
    }


def _iso(iso: IsoTaskResult | None, shown: Shown) -> dict | None:
    if iso is None:
        return None
    cube = iso.cube  # results before armcal placed the cube have none
    rows = _index_rows(iso.poses, "pose", shown, cube.centre if cube else None, cube.unit if cube else "mm")
    where = ""
    if cube:
        at = lambda v: significant(shown.length(v, cube.unit))  # noqa: E731
        where = f"centre ({', '.join(at(v) for v in cube.centre)}) {shown.unit}, side {at(cube.side)} {shown.unit}: {cube.placement}"
    return {"rows": rows, "tcp": iso.tool_centre_point, "frame": iso.task_frame, "cube": where}


def _evaluated(block: GridTaskResult | IsoTaskResult | TaskSkipped | None):
    """A task's block where it was evaluated, else None (not asked for, or skipped)."""
    return None if isinstance(block, TaskSkipped) else block


def _skipped_tasks(evaluation: Evaluation) -> list[dict]:
    """The evaluation tasks the spec asked for that were not evaluated, with the reason."""
    return [{"name": TASK_TITLES[task], "why": block.skipped} for task, block in evaluation.tasks() if isinstance(block, TaskSkipped)]


def _plots(diagnosis: Diagnosis, svgs: dict[str, str]) -> list[dict]:
    plots = []
    masses = diagnosis.evidence.torque_masses if diagnosis.evidence else None
    for name in diagnosis.plots:
        if name in svgs:
            data = base64.b64encode(svgs[name].encode("utf-8")).decode("ascii")
            size = "" if name in WIDE_PLOTS else "small"
            title = PLOT_TITLES.get(name, name) + (f", torque of {masses}" if name == "residual_vs_torque.svg" and masses else "")
            plots.append({"title": title, "source": f"data:image/svg+xml;base64,{data}", "size": size})
    return plots


def _flat_direction(flat: FlatDirection) -> str:
    """A flat direction in words: how flat (s_k / s_1) and the parameters it moves."""
    moved = ", ".join(f"{name} {component:+.2f}" for name, component in flat.parameters)
    return f"singular value {significant(flat.ratio, 2)} of the largest, along {moved}"


def _parallel_note(axes: ParallelAxesInfo) -> str:
    """How a pair of parallel dh axes is modelled: Hayati's beta added, d held."""
    i, j = axes.joints
    done = [f"Hayati's {axes.added} added"] if axes.added else []
    done += [f"{axes.held} held"] if axes.held else []
    return f"axes {i} and {j} parallel" + (": " + ", ".join(done) if done else "")


VARIANCE_VERDICTS = {"consistent": "consistent", "declared_too_small": "declared too small", "declared_too_large": "declared too large"}


def _estimated_noise(noise: NoiseEstimate | None, shown: Shown) -> dict | None:
    """The noise estimated from the data: per group sigma +- u, its 95 % interval, and the test against the declared."""
    if noise is None:
        return None
    rows = []
    for g in noise.groups:
        test = g.test
        at = lambda v: shown.length(v, g.unit)  # noqa: E731
        u, unit = at(g.std), shown.unit_of(g.unit)
        rows.append({
            "group": g.group,
            "sigma": f"{measured(at(g.sigma), u)} +- {measured(u, u)} {unit}",
            "interval": f"{measured(at(g.interval[0]), u)} - {measured(at(g.interval[1]), u)} {unit}",
            "readings": str(g.readings),
            "declared": f"{significant(at(g.declared))} {unit}" if g.declared is not None else "auto (none declared)",
            "test": f"{VARIANCE_VERDICTS[test.verdict]} ({p_value(test.p_value)})" if test else "-",
        })
    return {"method": noise.method, "rounds": counted(noise.rounds, "round"), "converged": noise.converged, "rows": rows,
            "level": f"{NOISE_CHECK_LEVEL:.0%}"}


FACTOR_RULE = f"A factor is shown where the design model's figure exceeds the noise of one reading, '{AT_THE_NOISE}' where it does not."
TASK_FACTOR_RULE = (FACTOR_RULE + " Where the calibrated figure is within the noise, the factor reads '> N', N = design figure / "
                    "noise: what an instrument of that noise could confirm. For an angle the noise is the angle the instrument's noise per reading subtends at the task's "
                    "distance from the robot base. A row that reads as an earlier one says so: other points whose errors agree to the decimals shown.")


def _resolution(shown: Shown) -> str:
    """Where the residual statistics' decimal comes from."""
    if shown.noise is None:
        return ""
    return (f"Values without an uncertainty of their own are shown to the decimal of the noise of one reading, "
            f"{measured(shown.noise, shown.noise)} {shown.unit_of(shown.reading_unit)} (two significant digits).")


NOT_GIVEN = "not given in the spec"
TRACEABILITY_ROWS = (("Maker", "maker"), ("Model", "model"), ("Serial number", "serial"), ("Last calibrated", "calibrated"),
                     ("Its calibration certificate", "certificate"), ("Maximum permissible error (maker's statement)", "mpe"))
STATISTICS = {
    "validation_rms": "RMS of the held-out residuals per reading (a point's coordinate, a bar length, a range), calibrated model",
    "validation_max": "largest |residual| of a held-out reading (a point's coordinate, a bar length, a range), calibrated model",
    "validation_rms_3d": "RMS of the held-out 3D distances per pose, calibrated model",
    "validation_max_3d": "largest held-out 3D distance of a pose, calibrated model",
}
SIMPLE_RULE = ("simple acceptance (ILAC-G8:2019 4.2.1): pass when the figure is at most the tolerance; its uncertainty is not "
               "taken into account (at the limit the risk of a false pass is up to 50 %)")
GUARDED_RULE = ("guarded acceptance (ILAC-G8:2019 4.2.3), guard band w = U: pass when the figure is at most the tolerance less U. "
                "U = k u, u the Type A standard uncertainty of the RMS from the finite sample of n held-out poses (poses "
                "independent, delta method), k Student's t for 95 % with n - 1 degrees of freedom; U does not include the instrument's own calibration uncertainty (MPE above)")


def _traceability(campaign: Campaign) -> list[tuple[str, str]]:
    """The instrument's identity and calibration, each field as the spec gives it or 'not given in the spec'."""
    given = campaign.traceability
    return [(label, getattr(given, key, None) or NOT_GIVEN) for label, key in TRACEABILITY_ROWS]


def _not_given(spec: SpecInfo) -> list[tuple[str, str]]:
    """A row per placeholder (spec.placeholders): what the spec does not give, as the traceability rows say it."""
    return [(p.stands_for[0].upper() + p.stands_for[1:], f"{NOT_GIVEN}: armcal's stand-in ({p.field}) is unchanged")
            for p in spec.placeholders]


def _serial(robot: RobotInfo, spec: SpecInfo) -> str:
    """The robot's serial as the spec gives it, or the stand-in marked as not given."""
    stand_in = any(p.field == "robot.serial" for p in spec.placeholders)
    return f"{robot.serial} ({NOT_GIVEN}: armcal's stand-in)" if stand_in else robot.serial


def _temperature(campaign: Campaign) -> str:
    temperature = campaign.temperature
    if not temperature:
        return "not recorded (the data have no temperature column)"
    return f"{temperature[0]:.2f} - {temperature[1]:.2f} °C (lowest - highest reading of the data's temperature column, calibration and validation data)"


def _origin(simulated: SimulatedData | None) -> tuple[bool, str]:
    """Whether the data are armcal's simulation, and the data's origin in words."""
    if simulated is None:
        return False, "not recorded in these results"
    sets = [name for name, is_simulated in (("calibration", simulated.calibration), ("validation", simulated.validation)) if is_simulated]
    if sets:
        return True, f"SIMULATED by armcal ({' and '.join(sets)} data: the truth.json beside them names their SHA-256)"
    return False, "measured (no truth.json of armcal simulate matches the data files)"


def _acceptance(acceptance: AcceptanceResult | None, shown: Shown) -> dict | None:
    """The statement of conformity in words: figure, tolerance, rule, U, verdict."""
    if acceptance is None:
        return None
    unit = acceptance.unit
    guarded = acceptance.decision_rule == "guarded"
    places = decimals(shown.length(acceptance.expanded_uncertainty, unit)) if guarded else shown.places  # GUM 7.2.6 where U is known
    at = lambda value: f"{fixed(shown.length(value, unit), places)} {shown.unit_of(unit)}"  # noqa: E731
    verdict = acceptance.verdict.upper()
    relation = "at most" if acceptance.verdict == "pass" else "above"
    return {
        "statistic": STATISTICS[acceptance.statistic],
        "value": at(acceptance.value),
        "tolerance": at(acceptance.tolerance),
        "rule": GUARDED_RULE if guarded else SIMPLE_RULE,
        "uncertainty": f"{at(acceptance.expanded_uncertainty)} (k = {acceptance.coverage_factor:g})" if guarded else "not used (simple acceptance)",
        "limit": at(acceptance.acceptance_limit) + (" (tolerance less U)" if guarded else " (the tolerance)"),
        "verdict": verdict,
        "statement": f"{verdict}: the figure {at(acceptance.value)} is {relation} the acceptance limit {at(acceptance.acceptance_limit)}.",
    }


def _change(change: ParameterChange, shown: Shown) -> str:
    z = f"z = {change.z:.1f}" if change.z is not None else "no uncertainty"
    at = lambda v: significant(shown.length(v, change.unit))  # noqa: E731
    return f"{change.name} {at(change.old)} -> {at(change.new)} {shown.unit_of(change.unit)} ({z})"


def _implausible(p: Plausibility | None, shown: Shown) -> list[str]:
    """The identified robot values beyond their tolerance, one sentence each (results/plausibility.py)."""
    if p is None:
        return []
    source = "robot.tolerance" if p.from_spec else "default tolerance, the spec gives none"
    lines = []
    for v in p.implausible:
        at = lambda x: significant(shown.length(x, v.unit))  # noqa: E731
        unit = shown.unit_of(v.unit)
        deviation = at(v.deviation)
        lines.append(
            f"{v.name} = {at(v.value)} {unit}: {'' if deviation.startswith('-') else '+'}{deviation} {unit} from nominal {at(v.nominal)}, "
            f"beyond {at(v.tolerance)} {unit} ({source})" + (f"; std {significant(shown.length(v.std, v.unit), 3)} {unit}" if v.std is not None else "")
            + f": {WHY[v.why]}"
        )
    return lines


def _history(history: list[HistoryEntry], shown: Shown) -> list[dict]:
    """Earlier calibrations of this robot, oldest first, with the parameters changed significantly since."""
    rows = []
    for h in history:
        at = lambda v: f"{fixed(shown.length(v, h.unit), shown.places)} {shown.unit_of(h.unit)}"  # noqa: E731
        validation = at(h.rms_validation) if h.rms_validation is not None else "no held-out data"
        rows.append({
            "date": h.created[:10],
            "certificate": h.certificate_number,
            "run_id": h.run_id or "not recorded",
            "status": h.status,
            "rms": f"{at(h.rms_calibration)} / {validation}",
            "changes": [_change(c, shown) for c in h.significant] or [f"none of {counted(h.compared, 'parameter')} compared"],
        })
    return rows


def certificate_context(results: Results, plots: dict[str, str]) -> dict:
    """Every value the template shows, as text, from ``results``' attributes; ``plots`` (name -> SVG) as data URIs."""
    report, spec, robot, campaign = results.report, results.spec, results.robot, results.campaign
    identifiability = results.identifiability
    noise = results.noise_check
    git = spec.git
    grid = _evaluated(results.evaluation.grid_task)
    simulated, origin = _origin(results.simulated)
    shown = Shown.of(results)
    return {
        "number": report.certificate_number,
        "simulated": simulated,
        "issued": results.created[:10],
        "robot": {"name": robot.name, "serial": _serial(robot, spec), "convention": robot.convention, "dof": str(robot.dof)},
        "people": [(label, value) for label, value in (("Customer", report.customer), ("Operator", report.operator), ("Location", report.location)) if value],
        "notes": report.notes or "",
        "campaign": {
            "instrument": campaign.instrument,
            "details": "; ".join(campaign.details),
            "procedure": campaign.procedure,
            "validation_procedure": campaign.validation_procedure or "none",
            "samples": f"{campaign.calibration_samples} calibration" + (f", {campaign.validation_samples} validation" if campaign.validation_samples else ""),
            "origin": origin,
        },
        "traceability": _traceability(campaign),
        "not_given": _not_given(spec),
        "temperature": _temperature(campaign),
        "acceptance": _acceptance(results.acceptance, shown),
        "history": _history(results.history, shown),
        "family_alpha": f"{ALPHA * 100:g} %",
        "spec": {
            "path": spec.path,
            "sha256": spec.sha256,
            "git": (f"{git.commit}" + (" (the spec file differs from this commit)" if git.dirty else " (clean)")) if git else "not in a git repository",
        },
        "status": status_words(results.status, results.plausibility),
        "implausible": _implausible(results.plausibility, shown),
        "run_id": results.run_id or "not recorded",
        "solver": f"{results.solver.method}, {powers_of_ten(results.solver.reason)}, {counted(results.solver.iterations, 'iteration')}",
        "identifiability": {
            "rank": f"{identifiability.rank} of {identifiability.n_parameters}",
            "condition": fixed(identifiability.condition_number, 1),
            "fixed": [(f.name, powers_of_ten(f.reason)) for f in identifiability.fixed if f.reason != "fixed in the spec"],
            "spec_fixed": str(sum(1 for f in identifiability.fixed if f.reason == "fixed in the spec")),
            "unidentifiable": ", ".join(identifiability.unidentifiable) or "none",
            "design_point": identifiability.design_point,
            "flat": [_flat_direction(f) for f in identifiability.flat_directions],
            "parallel": [_parallel_note(p) for p in identifiability.parallel_axes],
            "breakdown": _breakdown_rows(identifiability.breakdown),
        },
        "unit": shown.unit_of(shown.reading_unit),
        "factor_rule": FACTOR_RULE,
        "task_factor_rule": TASK_FACTOR_RULE,
        "resolution": _resolution(shown),
        "parameters": _parameter_rows(results.parameters, shown),
        "statistics": _stats_rows(results.residuals, shown),
        "distances": _distance_rows(results.residuals_3d, shown),
        "distance_unit": shown.unit,
        "grid": _grid(grid, shown),
        "grid_tcp": (grid.tool_centre_point or "") if grid else "",
        "grid_frame": (grid.task_frame or "") if grid else "",
        "grid_placement": (grid.placement or "") if grid else "",
        "skipped_tasks": _skipped_tasks(results.evaluation),
        "features": _features(results.evaluation.s_model_features, shown),
        "iso": _iso(_evaluated(results.evaluation.iso9283), shown),
        "diagnosis": _diagnosis(results.diagnosis, shown),
        "learned": _learned(results.residual_model, shown),
        "plots": _plots(results.diagnosis, plots),
        "noise": {
            "chi2": f"{noise.chi2:.1f} on {noise.dof} degrees of freedom ({p_value(noise.p_value)})",
            "scaled": noise.covariance_scaled,
        },
        "estimated_noise": _estimated_noise(results.noise, shown),
        "version": results.armcal_version,
    }


def _breakdown_rows(table: dict[str, dict[str, int]]) -> list[tuple[str, str, str, str, str]]:
    """The parameter counts as run prints them (results/breakdown.py): row, identified, not identifiable, held, total."""
    rows, totals = [], [0, 0, 0]
    for row, counts in table.items():
        values = [counts["identified"], counts["not_identifiable"], counts["held_by_spec"]]
        if sum(values):
            rows.append((row, *(str(v) for v in values), str(sum(values))))
            totals = [t + v for t, v in zip(totals, values)]
    return rows + [("total", *(str(v) for v in totals), str(sum(totals)))] if rows else []
