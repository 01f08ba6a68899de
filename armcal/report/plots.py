"""Residual plots as SVG, drawn from the evidence block of results.json (no model needed)."""

from __future__ import annotations

import io
import math
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.backends.backend_svg import RendererSVG  # noqa: E402
from matplotlib.transforms import Bbox  # noqa: E402

from armcal.report.numbers import significant  # noqa: E402
from armcal.results.schema import BinnedSeries, Evidence  # noqa: E402
from armcal.support.units import LENGTH_UNITS, factor  # noqa: E402


STYLE = {"font.size": 8, "svg.fonttype": "none", "figure.dpi": 100}  # while drawing only; the caller's rcParams stay as they were
SVG_DPI = 72  # what matplotlib lays an SVG out at, whatever the figure's dpi
SVG_SALT = "armcal"  # element ids from hashes of this and the content, not random: the same plot gives the same bytes
SERIES_STYLE = {"before": dict(color="0.6", marker="o", ms=3, lw=1), "after": dict(color="black", marker="o", ms=3, lw=1)}


def svg(figure) -> str:
    """The figure as SVG text, reproducible: fixed ids, no date; cropped to what is drawn (``bbox_inches="tight"``'s
    box, measured without its extra drawing pass: every figure is drawn once, a quarter less time)."""
    buffer = io.StringIO()
    with plt.rc_context({"svg.hashsalt": SVG_SALT}):
        figure.savefig(buffer, format="svg", bbox_inches=_drawn_box(figure), metadata={"Date": None})
    plt.close(figure)
    return buffer.getvalue()


def _drawn_box(figure) -> Bbox:
    """The box (inches) of everything ``figure`` draws, with savefig's padding, measured as an SVG file lays it out
    (72 dots an inch)."""
    figure.dpi = SVG_DPI
    renderer = RendererSVG(figure.get_figwidth(), figure.get_figheight(), io.StringIO(), image_dpi=SVG_DPI)
    return figure.get_tightbbox(renderer).padded(matplotlib.rcParams["savefig.pad_inches"])


def _panels(count: int):
    columns = min(3, count)
    rows = math.ceil(count / columns)
    figure, axes = plt.subplots(rows, columns, figsize=(3.0 * columns, 2.4 * rows), squeeze=False)
    figure.subplots_adjust(hspace=0.75, wspace=0.45)  # room for titles and labels; savefig trims the margins
    for extra in axes.flat[count:]:
        extra.set_visible(False)
    return figure, list(axes.flat)


SPARSE = 5  # a bin with fewer samples than this is drawn open: its mean rests on a few samples


def _series(axis, binned: BinnedSeries) -> None:
    """Each series of a binned panel; 'before' only where the diagnosis changed something (else it hides under
    'final'); bins of fewer than SPARSE samples drawn open and grey, with their count."""
    unchanged = binned.before == binned.after
    centres = [math.nan if x is None else x for x in binned.x]  # null as results.json holds nan
    for name, values in binned.series.items():
        if name == "before" and unchanged:
            continue
        style = SERIES_STYLE.get(name, dict(lw=2))
        label = {"before": "before diagnosis", "after": "final" if not unchanged else "final (the diagnosis added nothing)"}.get(name, f"{name} (fitted)")
        axis.plot(centres, values, label=label, **style)
    sparse = [i for i, n in enumerate(binned.count) if n < SPARSE]
    if sparse:
        xs, ys = [centres[i] for i in sparse], [binned.after[i] for i in sparse]
        axis.plot(xs, ys, ls="none", marker="o", ms=5, mfc="white", mec="0.5", label=f"bin of fewer than {SPARSE} samples (count beside)")
        for x, y, i in zip(xs, ys, sparse):
            axis.annotate(str(binned.count[i]), (x, y), textcoords="offset points", xytext=(3, 3), fontsize=5, color="0.4")
    axis.axhline(0.0, color="0.8", lw=0.5)


def in_unit(evidence: Evidence, unit: str) -> Evidence:
    """The evidence with its residuals in ``unit`` where they are lengths (the certificate's one length unit)."""
    if evidence.unit not in LENGTH_UNITS or unit == evidence.unit:
        return evidence
    k = factor("length", evidence.unit) / factor("length", unit)

    def scaled(binned: BinnedSeries | None) -> BinnedSeries | None:  # x and count as they are
        return None if binned is None else binned.model_copy(update={"series": {n: [k * e for e in v] for n, v in binned.series.items()}})

    h = evidence.histogram
    return evidence.model_copy(update={
        "unit": unit,
        "joints": [scaled(b) for b in evidence.joints],
        "gravity_torque": [scaled(b) for b in evidence.gravity_torque],
        "t": scaled(evidence.t),
        "temperature": scaled(evidence.temperature),
        "longitude": scaled(evidence.longitude),
        "keys": [key.model_copy(update={"rms_before": k * key.rms_before, "rms_after": k * key.rms_after}) for key in evidence.keys],
        "histogram": h.model_copy(update={"edges": [k * e for e in h.edges], "noise_sigma": k * h.noise_sigma, "mean": k * h.mean, "std": k * h.std}),
    })


def histogram(evidence: Evidence) -> str:
    h = evidence.histogram
    figure, axis = plt.subplots(figsize=(4.5, 2.8))
    centres = [(a + b) / 2 for a, b in zip(h.edges[:-1], h.edges[1:])]
    width = h.edges[1] - h.edges[0]
    axis.bar(centres, h.counts, width=width, color="0.75", edgecolor="0.4", label="final residuals")
    axis.plot(centres, h.expected, color="black", lw=1.5, label=f"noise model, sigma {significant(h.noise_sigma, 2)} {evidence.unit}")
    axis.set_xlabel(f"residual ({evidence.unit})")
    axis.set_ylabel("count")
    axis.locator_params(axis="x", nbins=7)
    axis.legend(frameon=False, fontsize=6, loc="upper left")
    return svg(figure)


def against(panels: list[BinnedSeries], unit: str, xlabels: list[str]) -> str:
    """Binned residuals (in ``unit``) against each joint's angle (position) or torque, one panel per joint."""
    figure, axes = _panels(len(panels))
    for axis, binned, xlabel in zip(axes, panels, xlabels):
        _series(axis, binned)
        axis.set_title(f"joint {binned.joint}")
        axis.set_xlabel(xlabel)
        axis.set_ylabel(f"|residual| ({unit})")
    entries = {}
    for axis in axes[: len(panels)]:
        for handle, label in zip(*axis.get_legend_handles_labels()):
            entries.setdefault(label, handle)
    figure.legend(list(entries.values()), list(entries), loc="lower center", bbox_to_anchor=(0.5, 0.98), ncol=len(entries), frameon=False, fontsize=6)
    return svg(figure)


def over(binned: BinnedSeries, unit: str, xlabel: str) -> str:
    figure, axis = plt.subplots(figsize=(4.5, 2.5))
    _series(axis, binned)
    axis.set_xlabel(xlabel)
    axis.set_ylabel(f"|residual| ({unit})")
    axis.legend(frameon=False, fontsize=6)
    return svg(figure)


def per_key(evidence: Evidence) -> str:
    keys = evidence.keys
    figure, axis = plt.subplots(figsize=(max(3.0, 0.45 * len(keys) + 1.5), 2.6))
    positions = range(len(keys))
    axis.bar([p - 0.2 for p in positions], [k.rms_before for k in keys], width=0.4, color="0.7", label="design model")
    axis.bar([p + 0.2 for p in positions], [k.rms_after for k in keys], width=0.4, color="0.2", label="calibrated")
    axis.set_xticks(list(positions), [k.key for k in keys], rotation=45, ha="right")
    axis.set_ylabel(f"RMS ({evidence.unit})")
    axis.legend(frameon=False, fontsize=6)
    return svg(figure)


@plt.rc_context(STYLE)
def draw_plots(evidence: Evidence, unit: str) -> dict[str, str]:
    """Every plot the evidence supports, residual lengths in ``unit``: file name -> SVG text."""
    evidence = in_unit(evidence, unit)
    plots = {
        "residual_histogram.svg": histogram(evidence),
        "residual_vs_joint.svg": against(evidence.joints, evidence.unit, evidence.joint_axes),
        "residual_per_key.svg": per_key(evidence),
    }
    if evidence.gravity_torque:
        torque = ["gravity torque (N m)"] * len(evidence.gravity_torque)  # from the masses the caption names
        plots["residual_vs_torque.svg"] = against(evidence.gravity_torque, evidence.unit, torque)
    for name, binned, label in (("t", evidence.t, "time (s)"), ("temperature", evidence.temperature, "temperature (degC)"),
                                ("longitude", evidence.longitude, "longitude on the shell (deg)")):
        if binned is not None:
            plots[f"residual_vs_{name}.svg"] = over(binned, evidence.unit, label)
    return plots
