"""Plots of a Monte-Carlo study, drawn from montecarlo.json alone.

Like Stone's Figures 7-4 to 7-8: the standard deviation of the four vertex
radial errors against the swept value (log-log, with the slope he found), and
the spread of every index under both controllers at each point.
"""

from __future__ import annotations

import numpy as np
from matplotlib.ticker import NullFormatter

from armcal.evaluate.grid import RADIAL, index_kind
from armcal.report.plan_plots import PLAN_CURVE, accuracy_plot
from armcal.report.plots import STYLE, plt, svg


SPREAD, TREND = "montecarlo_spread.svg", "montecarlo_trend.svg"


@plt.rc_context(STYLE)
def study_plots(summary: dict) -> dict[str, str]:
    """The study's plots by file name (the trend only for a sweep with spreads to fit)."""
    plots = {SPREAD: spread(summary)}
    if summary["trend"] is not None and summary["trend"]["radial_slope"] is not None:
        plots[TREND] = radial_trend(summary)
    curve = summary.get("accuracy_vs_poses")
    if curve is not None:
        plots[PLAN_CURVE] = accuracy_plot(curve, curve["unit"], f"held-out accuracy, mean of {curve['robots']} simulated robots")
    return plots


def radial_trend(summary: dict) -> str:
    """Radial error std at vertices 1, 4, 5, 8 against the swept value, with Stone's trend as a dashed line."""
    sweep, found = summary["sweep"], summary["trend"]
    values = np.array(sweep["values"], dtype=float)
    figure, axis = plt.subplots(figsize=(4.5, 3.0))
    spreads = []
    for name in RADIAL:
        spread = np.array([next(r for r in p["indices"] if r["index"] == name)[found["controller"]]["std"] for p in summary["points"]])
        spreads.append(spread)
        axis.plot(values, spread, marker="o", ms=3, lw=1, label=name)
    unit = summary["points"][0]["indices"][0]["unit"]
    middle = np.exp(np.mean(np.log(spreads)))
    guide = middle * (values / np.exp(np.mean(np.log(values)))) ** found["expected_slope"]
    axis.plot(values, guide, "k--", lw=1, label=f"slope {found['expected_slope']:g} ({found['source']})")
    axis.set_xscale("log")
    axis.set_yscale("log")
    axis.set_xticks(values, [f"{v:g}" for v in values], minor=False)
    axis.xaxis.set_minor_formatter(NullFormatter())
    axis.set_xlabel(f"{sweep['variable']} ({sweep['unit']})")
    axis.set_ylabel(f"std of radial error ({unit}), {found['controller']} control")
    axis.set_title(f"median slope over 34 indices {found['median_slope']:.2f}", fontsize=8)
    axis.legend(frameon=False, fontsize=6)
    return svg(figure)


def spread(summary: dict) -> str:
    """Standard deviation of each index, design-model vs calibrated control, at each point."""
    names = [row["index"] for row in summary["points"][0]["indices"]]
    figure, axes = plt.subplots(1, 2, figsize=(9.0, 5.0))
    figure.subplots_adjust(wspace=0.6)
    for axis, kind in zip(axes, ("length", "angle")):
        rows = [i for i, name in enumerate(names) if index_kind(name) == kind]
        positions = np.arange(len(rows))
        for k, point in enumerate(summary["points"]):
            label = "" if point["value"] is None else f" at {point['value']:g}"
            for controller, marker in (("design", "s"), ("calibrated", "o")):
                stds = [point["indices"][i][controller]["std"] for i in rows]
                axis.plot(stds, positions, marker=marker, ls="none", ms=3, alpha=0.4 + 0.6 * (k + 1) / len(summary["points"]),
                          color="0.55" if controller == "design" else "black", label=f"{controller}{label}" if k in (0, len(summary["points"]) - 1) else None)
        unobserved = set((summary.get("unobserved") or {}).get("indices", ()))  # the data cannot calibrate these (montecarlo.json says why)
        axis.set_yticks(positions, [names[i] + (" (not observed)" if names[i] in unobserved else "") for i in rows], fontsize=6)
        axis.set_xscale("log")
        axis.set_xlabel(f"std over {summary['runs']} robots ({summary['points'][0]['indices'][rows[0]]['unit']})")
        axis.legend(frameon=False, fontsize=6)
    return svg(figure)
