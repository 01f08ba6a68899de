"""Held-out accuracy against the number of poses, planned and random (evaluate/plan_accuracy.accuracy_curve).

Drawn from plain values (``AccuracyCurve.values()``), so a report can draw it from its JSON alone: the mean
over the simulated robots of each design, log-log, planned poses against random ones (N and 3N), with the
1/sqrt(N) slope that many random poses follow for reference. A design that identified no robot is left out (its
mean is None); when none did, the plot says so instead of drawing empty log axes.
"""

from __future__ import annotations

import numpy as np
from matplotlib.ticker import FormatStrFormatter, NullLocator

from armcal.report.plots import STYLE, plt, svg

PLAN_CURVE = "plan_accuracy.svg"


@plt.rc_context(STYLE)
def accuracy_plot(curve: dict, unit: str = "mm", title: str = "") -> str:
    """SVG of {"counts": [...], "planned": {criterion: [mean per count]}, "random": {factor: [mean per count]}}."""
    counts = np.asarray(curve["counts"], dtype=float)
    figure, axis = plt.subplots(figsize=(4.5, 3.0))
    drawn = np.asarray([v for means in (*curve["planned"].values(), *curve["random"].values()) for v in means], dtype=float)
    if not (np.isfinite(drawn) & (drawn > 0)).any():  # no design identified the model: nothing to draw on log axes
        axis.text(0.5, 0.5, "no design of these numbers of poses\nidentified the model: nothing to compare",
                  ha="center", va="center", transform=axis.transAxes, fontsize=8)
        axis.set_xticks([])
        axis.set_yticks([])
        axis.set_xlabel("N, poses planned (or drawn at random)")
        if title:
            axis.set_title(title, fontsize=8)
        return svg(figure)
    for criterion, means in curve["planned"].items():
        axis.plot(counts, means, marker="o", ms=3, lw=1.2, color="black" if criterion == "D" else "0.35", label=f"planned ({criterion}-optimal)")
    for factor, means in curve["random"].items():
        axis.plot(counts, means, marker="s", ms=3, lw=1, ls="--" if int(factor) > 1 else "-", color="tab:red" if int(factor) == 1 else "tab:orange",
                  label="random N" if int(factor) == 1 else f"random {factor}N")
    reference = np.asarray(next(iter(curve["random"].values())), dtype=float)
    if np.isfinite(reference[-1]):
        axis.plot(counts, reference[-1] * np.sqrt(counts[-1] / counts), color="0.7", lw=0.8, ls=":", label="1/sqrt(N)")
    axis.set_xscale("log")
    axis.set_yscale("log")
    axis.set_xticks(counts, [f"{c:g}" for c in counts])
    axis.xaxis.set_minor_locator(NullLocator())
    axis.yaxis.set_major_formatter(FormatStrFormatter("%g"))
    axis.yaxis.set_minor_formatter(FormatStrFormatter("%g"))
    axis.set_xlabel("N, poses planned (or drawn at random)")
    axis.set_ylabel(f"held-out accuracy, RMS ({unit})")
    if title:
        axis.set_title(title, fontsize=8)
    axis.legend(frameon=False, fontsize=6)
    return svg(figure)
