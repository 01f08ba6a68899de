"""calibrated.yaml: the input spec with the fitted model written in, comments kept.

The spec is edited with ruamel's round-trip loader, so its layout and comments
stay. Every value the fitted model uses is written (in the spec's units, to 15
significant digits): the identified ones, and those the fit held at a start value
other than the spec's (the instrument registration, Hayati's beta). A parameter
the spec leaves free but the fit held (redundant at the design point) is written
with ``vary: false``, so the calibrated spec reproduces the fit and its base set.
Data paths are re-pointed from the output folder, and a header comment says where
the values came from.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

from pydantic import TypeAdapter, ValidationError
from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap, CommentedSeq

from armcal import __version__
from armcal.effects.library import to_spec_dict
from armcal.kinematics.params import parameter_set
from armcal.spec.document import Spec
from armcal.spec.learned import section_of
from armcal.spec.loader import spec_from_bytes
from armcal.support.errors import SpecError
from armcal.support.fileio import INPUT_LIMITS, KiB
from armcal.spec.locations import yaml_path
from armcal.support.units import from_internal, snapped

SIGNIFICANT = 15  # a 2 m transform to 2e-12 mm: the readings reproduced far below any noise


def _set(root: CommentedMap, path: list, value: float, held: bool = False, std: float | None = None) -> None:
    """Write a value at ``path``; ``held``: as {value, vary: false}; with its standard uncertainty: {value, std}."""
    node = root
    for part in path[:-1]:
        node = node[part]
    last = path[-1]
    current = node.get(last) if isinstance(node, dict) else None
    if isinstance(current, CommentedMap) and current.anchor.value is not None:  # shared by a YAML alias: write this one only
        current = _unshared(current)
        node[last] = current
    extra = [("vary", False)] if held else []
    extra += [("std", std)] if std is not None else []
    if isinstance(current, dict):
        current["value"] = value
        current.update(extra)
        if std is None:
            current.pop("std", None)  # an earlier calibration's: not this value's
    elif extra:
        entry = CommentedMap([("value", value), *extra])
        entry.fa.set_flow_style()
        node[last] = entry
    else:
        node[last] = value


def _drop_earlier_std(root: CommentedMap, spec: Spec, identified: set[str]) -> None:
    """Remove the ``std`` an earlier calibration wrote on the chain's parameters this run did not identify."""
    for name in parameter_set(spec.robot.chain()).names:
        if name in identified:
            continue
        node = root
        try:
            for key in yaml_path(name, spec):
                node = node[key]
        except (KeyError, IndexError, TypeError):  # a parameter the spec leaves out
            continue
        if isinstance(node, dict):
            node.pop("std", None)


def _learned_section(learned: dict) -> CommentedMap:
    """The residual_model section, a row of joint values and the short lists on one line each, at full precision (the
    round trip reproduces the run's predictions); inputs that repeat an earlier coordinate's (a target's base_x, base_y,
    base_z: the same readings) are written once, and aliased (*inputs): the section stays within a spec's size limit."""

    def flow(values: list) -> CommentedSeq:
        row = CommentedSeq(values)
        row.fa.set_flow_style()
        return row

    written: list[tuple[list, CommentedSeq]] = []
    coordinates = CommentedSeq()
    for c in learned["coordinates"]:
        inputs = next((seq for rows, seq in written if rows == c["inputs"]), None)
        if inputs is None:
            inputs = CommentedSeq(flow(row) for row in c["inputs"])
            inputs.yaml_set_anchor(f"inputs_{len(written) + 1}", always_dump=True)
            written.append((c["inputs"], inputs))
        coordinates.append(CommentedMap([("coordinate", c["coordinate"]), ("at", c["at"]), ("inputs", inputs), ("targets", flow(c["targets"])),
                                         ("signal_variance", c["signal_variance"]), ("length_scales", flow(c["length_scales"])),
                                         ("noise_variance", c["noise_variance"])]))
    return CommentedMap([("kind", learned["kind"]), ("outside_fraction", learned["outside_fraction"]), ("joint_units", flow(learned["joint_units"])),
                         ("coordinates", coordinates)])


def _unshared(mapping: CommentedMap) -> CommentedMap:
    """A copy of an anchored mapping, in the same style, that no alias refers to."""
    copy = CommentedMap(mapping.items())
    if mapping.fa.flow_style():
        copy.fa.set_flow_style()
    return copy


def calibrated_yaml(
    spec_text: str,
    spec: Spec,
    identified: dict[str, tuple[float, str, bool, float | None]],  # internal value, kind, held, std in the spec's unit
    source: Path,
    out_dir: Path,
    note: str,
    added_effects: list = (),
    noise: dict[str, tuple[float, str]] | None = None,
    learned: dict | None = None,
) -> str:
    """The spec text with ``identified`` {name: (internal value, kind, held, std)} written in, the effects
    the diagnosis added [(EffectSpec, {field: (internal value, kind)})] appended to ``effects:``, the noise
    estimated from the data {device field: (internal sigma, kind)} written as the device's sigmas (no longer estimated),
    and the learned residual model the run accepted as ``residual_model`` (one the spec held is the run's no more: dropped)."""
    yaml = YAML(typ="rt")
    yaml.preserve_quotes = True
    yaml.width = 4096  # keep flow-style rows on one line as the user wrote them
    root = yaml.load(spec_text)
    shown = lambda value, kind: float(f"{from_internal(value, kind, spec.robot.units.of(kind)):.{SIGNIFICANT}g}")  # noqa: E731
    for name, (value, kind, held, std) in identified.items():
        _set(root, yaml_path(name, spec), shown(snapped(value), kind), held, None if std is None else float(f"{std:.3g}"))
    _drop_earlier_std(root, spec, set(identified))
    if added_effects:
        effects = root.setdefault("effects", CommentedSeq())
        for effect, values in added_effects:
            effects.append(to_spec_dict(effect, {field: shown(snapped(v), kind) for field, (v, kind) in values.items()}))
    if noise:
        device = root["device"]
        for field, (sigma, kind) in noise.items():
            device[field] = shown(sigma, kind)
        if set(noise) == set(spec.device.estimated_fields()):  # every estimated field now holds its estimate
            for key in ("estimate_noise", "noise_groups"):
                device.pop(key, None)
    root.pop("residual_model", None)
    if learned is not None:
        root["residual_model"] = _learned_section(learned)
    if spec.data is not None and "data" in root:
        for key in ("calibration", "validation"):
            if root["data"].get(key):
                target = (source.parent / root["data"][key]).resolve()
                root["data"][key] = os.path.relpath(target, out_dir.resolve())
    root.yaml_set_start_comment(note)
    out = io.StringIO()
    yaml.dump(root, out)
    return out.getvalue()


def _plain_sigmas(spec: Spec, estimates: dict[str, tuple[float, str]] | None) -> dict[str, tuple[float, str]] | None:
    """The estimates whose device field takes one sigma; a noise model (a sonic digitizer's a s + b) keeps estimating."""
    if not estimates:
        return None
    fields = type(spec.device).model_fields
    plain = {}
    for field, estimate in estimates.items():
        try:
            TypeAdapter(fields[field].annotation).validate_python(1.0)
        except ValidationError:
            continue
        plain[field] = estimate
    return plain or None


def calibrated_text(loaded, results, calibrated, out_dir: Path) -> tuple[str, str | None]:
    """(calibrated.yaml of a run: the fitted model's values written in, added effects appended, the accepted learned
    residual model as its residual_model section; why that section is left out where it would not be read back, else None)."""
    problem, theta = calibrated.problem, calibrated.identified.theta
    index = problem.parameters.index
    added = calibrated.diagnosis.added if calibrated.diagnosis else []
    added_names = {p.name for e in added for p in e.parameters()}
    base = set(calibrated.identified.least_squares.identifiability.base)
    reported = {r.name for r in results.parameters} - added_names
    identified, held = {}, []
    std = {r.name: r.std for r in results.parameters}  # the spec's units, as results.json and the certificate give them
    for entry, value in zip(problem.parameters.entries, theta):
        if entry.name not in reported:
            continue
        redundant = entry.role != "effect" and entry.free and entry.name not in base and calibrated.identified.features is None
        if value != entry.nominal or entry.name in base or redundant:
            written = None if redundant or entry.role == "effect" else std[entry.name]  # an effect's field is a plain number
            identified[entry.name] = (float(value), entry.kind, redundant, written)
        held += [entry.name] if redundant else []
    new_effects = [(e, {p.name.rsplit(".", 1)[1]: (float(theta[index(p.name)]), p.kind) for p in e.parameters()}) for e in added]
    noise = _plain_sigmas(loaded.spec, calibrated.noise.spec_values()) if calibrated.noise else None
    learned = section_of(results.residual_model.model_dump() if results.residual_model else None)
    note = (
        f"Calibrated by armcal {__version__} on {results.created} from {loaded.path.name} "
        f"(sha256 {loaded.sha256[:12]}), run {results.run_id}, status {results.status}."
        + (f"\nHeld (vary: false) as the fit held them, not identifiable at the design point: {', '.join(held)}." if held else "")
        + (f"\nThe device's {', '.join(noise)} estimated from the calibration data (results.json: noise)." if noise else "")
    )
    written = lambda model, line: calibrated_yaml(loaded.text, loaded.spec, identified, loaded.path, out_dir, note + line,  # noqa: E731
                                                  new_effects, noise, model)
    if learned is None:
        return written(None, ""), None
    text = written(learned, "\nresidual_model: the learned residual model the run accepted (read by export and compensate; a run learns its own).")
    why = unreadable(text, out_dir / "calibrated.yaml")
    if why is None:
        return text, None
    return written(None, f"\nThe learned residual model the run accepted is in results.json only: {why}."), why


def unreadable(text: str, path: Path) -> str | None:
    """Why a calibrated spec holding a residual_model section would not be read back by export and compensate (the
    size limit of a spec file, the YAML's values, the section's checks), else None."""
    raw = text.encode("utf-8")
    limit = INPUT_LIMITS["spec"]
    if len(raw) > limit:
        return f"with it calibrated.yaml would have {len(raw) // KiB} KiB, more than the {limit // KiB} KiB a spec file may have"
    try:
        spec_from_bytes(raw, path)
    except SpecError as exc:
        mine = [issue for issue in exc.issues if not issue.field or issue.field.startswith("residual_model")]
        if mine:
            return f"with it calibrated.yaml would not be read back ({mine[0].field or 'the file'}: {mine[0].message})"
    return None
