"""The certificate's context: plain, already formatted values built from results.json (no logic in templates)."""

from __future__ import annotations

import base64
import math

from armcal.evaluate.multiple_testing import ALPHA
from armcal.identify.uncertainty import NOISE_CHECK_LEVEL
from armcal.results.plausibility import WHY, status_words
from armcal.results.schema import TASK_TITLES
from armcal.units import ANGLE_UNITS, factor

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


def number(value: float | None, decimals: int = 4) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if value != 0 and (abs(value) >= 1e6 or abs(value) < 10 ** -(decimals + 1)):
        return f"{value:.{max(decimals - 1, 2)}e}"
    return f"{value:.{decimals}f}"


def decimals_for(uncertainty: float | None, default: int = 5) -> int:
    """Enough decimals to show the expanded uncertainty with two significant digits."""
    if not uncertainty or not math.isfinite(uncertainty):
        return default
    return int(min(8, max(2, 1 - math.floor(math.log10(abs(uncertainty))))))


def _stats_rows(results: dict) -> list[dict]:
    rows = []
    for name in ("calibration", "validation"):
        pair = results["residuals"][name]
        if pair is None:
            continue
        factor = results["improvement_factor"][name]
        for moment in ("before", "after"):
            s = pair[moment]
            rows.append(
                {
                    "data": f"{name}, {'design model' if moment == 'before' else 'calibrated model'}",
                    "n": str(s["n"]),
                    "rms": number(s["rms"]),
                    "mean": number(s["mean"]),
                    "std": number(s["std"]),
                    "max": number(s["max_abs"]),
                    "factor": number(factor, 1) if moment == "after" else "",
                }
            )
    return rows


def _difference(parameter: dict) -> float:
    """Identified minus nominal; for an angle the shorter way round (-179.99 against 180 is 0.01, not -359.99)."""
    difference = parameter["value"] - parameter["nominal"]
    turn = FULL_TURN.get(parameter["unit"])
    return difference if turn is None else (difference + turn / 2) % turn - turn / 2


def _parameter_rows(results: dict) -> list[dict]:
    rows = []
    for p in results["parameters"]:
        expanded = 2 * p["std"] if p["std"] is not None else None
        decimals = decimals_for(expanded)
        rows.append(
            {
                "name": p["name"],
                "unit": p["unit"],
                "nominal": number(p["nominal"], decimals),
                "value": number(p["value"], decimals),
                "difference": number(_difference(p), decimals),
                "expanded": number(expanded, decimals) if expanded is not None else "",
                "mark": "" if p["free"] else "held",
            }
        )
    return rows


def _diagnosis(results: dict) -> dict:
    diagnosis = results["diagnosis"]
    unit = results["device"]["unit"]
    rounds = []
    for i, r in enumerate(diagnosis["rounds"], start=1):
        accepted = r["accepted"]
        parameters = []
        if accepted:
            for p in accepted["parameters"]:
                u = 2 * p["std"] if p["std"] is not None else None
                parameters.append(f"{p['name']} = {number(p['value'], decimals_for(u))} +- {number(u, decimals_for(u))} {p['unit']} (k=2)")
        top = [c for c in r["candidates"] if c["distinguishable"]][:3]
        rounds.append(
            {
                "number": str(i),
                "outcome": r["note"],
                "parameters": parameters,
                "strongest": ", ".join(f"{c['id']} (S {c['statistic']:.1f}, p {c['p_value']:.2g})" for c in top) or "none",
                "not_distinguishable": ", ".join(c["id"] for c in r["candidates"] if not c["distinguishable"]) or "none",
                "before": f"{number(r['rms_before']['calibration'])} / {number(r['rms_before']['validation'])} {unit}",
                "after": f"{number(r['rms_after']['calibration'])} / {number(r['rms_after']['validation'])} {unit}",
            }
        )
    partly = [r["accepted"] for r in diagnosis["rounds"] if r.get("partly_explained") and r["accepted"]]
    return {
        "rounds": rounds,
        "unexplained": diagnosis["unexplained"],
        "added": ", ".join(_effect_name(e) for e in diagnosis["added_effects"]) or "none",
        "partly": ", ".join(_effect_name(e) for e in partly),
        "chosen_on": diagnosis.get("chosen_on") or "the data given (not recorded)",
    }


def _effect_name(effect: dict) -> str:
    return effect["type"] + (f" joint {effect['joint']}" if effect["joint"] else "")


def _distance_rows(results: dict) -> list[dict]:
    """Per-pose 3D distance statistics, before and after, for calibration and validation."""
    block = results.get("residuals_3d")
    rows = []
    for name in ("calibration", "validation"):
        pair = (block or {}).get(name)
        for moment in ("before", "after") if pair else ():
            s = pair[moment]
            label = f"{name}, {'design model' if moment == 'before' else 'calibrated model'}"
            rows.append({"data": label, "n": str(s["n"]), "mean": number(s["mean"]), "rms": number(s["rms"]), "max": number(s["max"])})
    return rows


def _grid(results: dict) -> list[dict]:
    grid = results["evaluation"].get("grid_task") or {}
    return [
        {
            "index": r["index"],
            "unit": r["unit"],
            "design": number(r["design"]),
            "calibrated": number(r["calibrated"]),
            "factor": number(r["improvement_factor"], 1),
        }
        for r in grid.get("indices", [])
    ]


def _features(results: dict) -> dict | None:
    """Stone's feature identification: each joint's features with their accuracy (6.11-6.13), pseudo-DH table."""
    block = results["evaluation"].get("s_model_features")
    if not block:
        return None
    units = block["units"]
    residuals = block["residuals"]
    return {
        "units": units,
        "joints": [
            {
                "joint": str(j["joint"]),
                "radius": number(j["radius"], 3),
                "range": number(j["range_deg"], 1),
                "plane": number(j["plane_sigma"], 5),
                "centre": number(j["centre_sigma"], 5),
            }
            for j in block["joints"]
        ],
        "table": [
            {k: (number(v, 4) if k != "joint" else str(v)) for k, v in row.items()} for row in block["pseudo_dh"]
        ],
        "rms_features": number(residuals["s_model_features"]["rms"]),
        "rms_least_squares": number(residuals["least_squares"]["rms"]),
    }


def _iso(results: dict) -> dict | None:
    iso = results["evaluation"].get("iso9283")
    if not iso or "poses" not in iso:
        return None
    rows = [{"pose": r["pose"], "unit": r["unit"], "design": number(r["design"]), "calibrated": number(r["calibrated"]), "factor": number(r["improvement_factor"], 1)} for r in iso["poses"]]
    cube = iso.get("cube")  # results before armcal placed the cube have none
    where = f"centre ({', '.join(number(v) for v in cube['centre'])}) {cube['unit']}, side {number(cube['side'])} {cube['unit']}: {cube['placement']}" if cube else ""
    return {"rows": rows, "tcp": iso["tool_centre_point"], "frame": iso["task_frame"], "cube": where}


def _skipped_tasks(results: dict) -> list[dict]:
    """The evaluation tasks the spec asked for that were not evaluated, with the reason."""
    return [{"name": TASK_TITLES[task], "why": block["skipped"]} for task, block in results["evaluation"].items() if task in TASK_TITLES and "skipped" in block]


def _plots(results: dict, svgs: dict[str, str]) -> list[dict]:
    plots = []
    masses = (results["diagnosis"].get("evidence") or {}).get("torque_masses")
    for name in results["diagnosis"].get("plots", []):
        if name in svgs:
            data = base64.b64encode(svgs[name].encode("utf-8")).decode("ascii")
            size = "" if name in WIDE_PLOTS else "small"
            title = PLOT_TITLES.get(name, name) + (f", torque of {masses}" if name == "residual_vs_torque.svg" and masses else "")
            plots.append({"title": title, "source": f"data:image/svg+xml;base64,{data}", "size": size})
    return plots


def _flat_direction(flat: dict) -> str:
    """A flat direction in words: how flat (s_k / s_1) and the parameters it moves."""
    moved = ", ".join(f"{name} {component:+.2f}" for name, component in flat["parameters"])
    return f"singular value {flat['ratio']:.2g} of the largest, along {moved}"


def _parallel_note(axes: dict) -> str:
    """How a pair of parallel dh axes is modelled: Hayati's beta added, d held."""
    i, j = axes["joints"]
    done = [f"Hayati's {axes['added']} added"] if axes["added"] else []
    done += [f"{axes['held']} held"] if axes["held"] else []
    return f"axes {i} and {j} parallel" + (": " + ", ".join(done) if done else "")


VARIANCE_VERDICTS = {"consistent": "consistent", "declared_too_small": "declared too small", "declared_too_large": "declared too large"}


def _estimated_noise(noise: dict | None) -> dict | None:
    """The noise estimated from the data: per group sigma +- u, its 95 % interval, and the test against the declared."""
    if not noise:
        return None
    rows = []
    for g in noise["groups"]:
        test = g["test"]
        rows.append({
            "group": g["group"],
            "sigma": f"{g['sigma']:.4g} +- {g['std']:.2g} {g['unit']}",  # as the terminal prints it
            "interval": f"{g['interval'][0]:.4g} - {g['interval'][1]:.4g} {g['unit']}",
            "readings": str(g["readings"]),
            "declared": f"{g['declared']:.4g} {g['unit']}" if g["declared"] is not None else "auto (none declared)",
            "test": f"{VARIANCE_VERDICTS[test['verdict']]} (p = {test['p_value']:.2g})" if test else "-",
        })
    return {"method": noise["method"], "rounds": str(noise["rounds"]), "converged": noise["converged"], "rows": rows,
            "level": f"{NOISE_CHECK_LEVEL:.0%}"}


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


def _traceability(campaign: dict) -> list[tuple[str, str]]:
    """The instrument's identity and calibration, each field as the spec gives it or 'not given in the spec'."""
    given = campaign.get("traceability") or {}
    return [(label, given.get(key) or NOT_GIVEN) for label, key in TRACEABILITY_ROWS]


def _not_given(spec: dict) -> list[tuple[str, str]]:
    """A row per placeholder (spec.placeholders): what the spec does not give, as the traceability rows say it."""
    return [(p["stands_for"][0].upper() + p["stands_for"][1:], f"{NOT_GIVEN}: armcal's stand-in ({p['field']}) is unchanged")
            for p in spec.get("placeholders", [])]


def _serial(robot: dict, spec: dict) -> str:
    """The robot's serial as the spec gives it, or the stand-in marked as not given."""
    stand_in = any(p["field"] == "robot.serial" for p in spec.get("placeholders", []))
    return f"{robot['serial']} ({NOT_GIVEN}: armcal's stand-in)" if stand_in else robot["serial"]


def _temperature(campaign: dict) -> str:
    temperature = campaign["temperature"]
    if not temperature:
        return "not recorded (the data have no temperature column)"
    return f"{temperature[0]:.2f} - {temperature[1]:.2f} °C (lowest - highest reading of the data's temperature column, calibration and validation data)"


def _origin(simulated: dict | None) -> tuple[bool, str]:
    """Whether the data are armcal's simulation, and the data's origin in words."""
    if simulated is None:
        return False, "not recorded in these results"
    sets = [name for name in ("calibration", "validation") if simulated[name]]
    if sets:
        return True, f"SIMULATED by armcal ({' and '.join(sets)} data: the truth.json beside them names their SHA-256)"
    return False, "measured (no truth.json of armcal simulate matches the data files)"


def _acceptance(acceptance: dict | None) -> dict | None:
    """The statement of conformity in words: figure, tolerance, rule, U, verdict."""
    if acceptance is None:
        return None
    unit = acceptance["unit"]
    shown = lambda value: f"{number(value)} {unit}"  # noqa: E731
    guarded = acceptance["decision_rule"] == "guarded"
    verdict = acceptance["verdict"].upper()
    relation = "at most" if acceptance["verdict"] == "pass" else "above"
    return {
        "statistic": STATISTICS[acceptance["statistic"]],
        "value": shown(acceptance["value"]),
        "tolerance": shown(acceptance["tolerance"]),
        "rule": GUARDED_RULE if guarded else SIMPLE_RULE,
        "uncertainty": f"{shown(acceptance['expanded_uncertainty'])} (k = {acceptance['coverage_factor']:g})" if guarded else "not used (simple acceptance)",
        "limit": shown(acceptance["acceptance_limit"]) + (" (tolerance less U)" if guarded else " (the tolerance)"),
        "verdict": verdict,
        "statement": f"{verdict}: the figure {shown(acceptance['value'])} is {relation} the acceptance limit {shown(acceptance['acceptance_limit'])}.",
    }


def _change(change: dict) -> str:
    z = f"z = {change['z']:.1f}" if change["z"] is not None else "no uncertainty"
    return f"{change['name']} {number(change['old'])} -> {number(change['new'])} {change['unit']} ({z})"


def _implausible(results: dict) -> list[str]:
    """The identified robot values beyond their tolerance, one sentence each (results/plausibility.py)."""
    p = results.get("plausibility")
    if not p:
        return []
    source = "robot.tolerance" if p["from_spec"] else "default tolerance, the spec gives none"
    return [
        f"{v['name']} = {v['value']:.6g} {v['unit']}: {v['deviation']:+.4g} {v['unit']} from nominal {v['nominal']:.6g}, beyond "
        f"{v['tolerance']:g} {v['unit']} ({source})" + (f"; std {v['std']:.3g} {v['unit']}" if v["std"] is not None else "")
        + f": {WHY[v['why']]}"
        for v in p["implausible"]
    ]


def _history(results: dict) -> list[dict]:
    """Earlier calibrations of this robot, oldest first, with the parameters changed significantly since."""
    rows = []
    for h in results.get("history", []):
        validation = f"{number(h['rms_validation'])} {h['unit']}" if h["rms_validation"] is not None else "no held-out data"
        rows.append({
            "date": h["created"][:10],
            "certificate": h["certificate_number"],
            "run_id": h["run_id"] or "not recorded",
            "status": h["status"],
            "rms": f"{number(h['rms_calibration'])} {h['unit']} / {validation}",
            "changes": [_change(c) for c in h["significant"]] or [f"none of {h['compared']} parameters compared"],
        })
    return rows


def certificate_context(results: dict, plots: dict[str, str]) -> dict:
    """Every value the template shows, as text; ``plots`` (name -> SVG) as data URIs."""
    report, spec, robot, campaign = results["report"], results["spec"], results["robot"], results["campaign"]
    identifiability = results["identifiability"]
    noise = results["noise_check"]
    git = spec["git"]
    simulated, origin = _origin(results.get("simulated"))
    return {
        "number": report["certificate_number"],
        "simulated": simulated,
        "issued": results["created"][:10],
        "robot": {"name": robot["name"], "serial": _serial(robot, spec), "convention": robot["convention"], "dof": str(robot["dof"])},
        "people": [(label, report[key]) for label, key in (("Customer", "customer"), ("Operator", "operator"), ("Location", "location")) if report[key]],
        "notes": report["notes"] or "",
        "campaign": {
            "instrument": campaign["instrument"],
            "details": "; ".join(campaign["details"]),
            "procedure": campaign["procedure"],
            "validation_procedure": campaign["validation_procedure"] or "none",
            "samples": f"{campaign['calibration_samples']} calibration" + (f", {campaign['validation_samples']} validation" if campaign["validation_samples"] else ""),
            "origin": origin,
        },
        "traceability": _traceability(campaign),
        "not_given": _not_given(spec),
        "temperature": _temperature(campaign),
        "acceptance": _acceptance(results.get("acceptance")),
        "history": _history(results),
        "family_alpha": f"{ALPHA * 100:g} %",
        "spec": {
            "path": spec["path"],
            "sha256": spec["sha256"],
            "git": (f"{git['commit']}" + (" (the spec file differs from this commit)" if git["dirty"] else " (clean)")) if git else "not in a git repository",
        },
        "status": status_words(results["status"], results.get("plausibility")),
        "implausible": _implausible(results),
        "run_id": results.get("run_id") or "not recorded",
        "solver": f"{results['solver']['method']}, {results['solver']['reason']}, {results['solver']['iterations']} iterations",
        "identifiability": {
            "rank": f"{identifiability['rank']} of {identifiability['n_parameters']}",
            "condition": number(identifiability["condition_number"], 1),
            "fixed": [(f["name"], f["reason"]) for f in identifiability["fixed"] if f["reason"] != "fixed in the spec"],
            "spec_fixed": str(sum(1 for f in identifiability["fixed"] if f["reason"] == "fixed in the spec")),
            "unidentifiable": ", ".join(identifiability["unidentifiable"]) or "none",
            "design_point": identifiability.get("design_point", "nominal"),
            "flat": [_flat_direction(f) for f in identifiability.get("flat_directions", [])],
            "parallel": [_parallel_note(p) for p in identifiability.get("parallel_axes", [])],
            "breakdown": _breakdown_rows(identifiability.get("breakdown") or {}),
        },
        "unit": results["device"]["unit"],
        "parameters": _parameter_rows(results),
        "statistics": _stats_rows(results),
        "distances": _distance_rows(results),
        "distance_unit": (results.get("residuals_3d") or {}).get("unit", ""),
        "grid": _grid(results),
        "grid_tcp": (results["evaluation"].get("grid_task") or {}).get("tool_centre_point", ""),
        "grid_frame": (results["evaluation"].get("grid_task") or {}).get("task_frame", ""),
        "grid_placement": (results["evaluation"].get("grid_task") or {}).get("placement", ""),
        "skipped_tasks": _skipped_tasks(results),
        "features": _features(results),
        "iso": _iso(results),
        "diagnosis": _diagnosis(results),
        "plots": _plots(results, plots),
        "noise": {
            "chi2": f"{noise['chi2']:.1f} on {noise['dof']} degrees of freedom (p = {noise['p_value']:.3g})",
            "scaled": noise["covariance_scaled"],
        },
        "estimated_noise": _estimated_noise(results.get("noise")),
        "version": results["armcal_version"],
    }


def _breakdown_rows(table: dict) -> list[tuple[str, str, str, str, str]]:
    """The parameter counts as run prints them (results/breakdown.py): row, identified, not identifiable, held, total."""
    rows, totals = [], [0, 0, 0]
    for row, counts in table.items():
        values = [counts["identified"], counts["not_identifiable"], counts["held_by_spec"]]
        if sum(values):
            rows.append((row, *(str(v) for v in values), str(sum(values))))
            totals = [t + v for t, v in zip(totals, values)]
    return rows + [("total", *(str(v) for v in totals), str(sum(totals)))] if rows else []
