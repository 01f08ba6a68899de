"""Read a data file against its spec: every problem named by file, row (line) and column."""

from __future__ import annotations

import csv
import difflib
import io
import math
import re
from pathlib import Path

import numpy as np

from armcal.dataio.columns import Layout, joint_columns, layout
from armcal.dataio.measurements import Measurements
from armcal.devices import device_model
from armcal.support.errors import Issue, SpecError
from armcal.support.fileio import read_input, spreadsheet_text
from armcal.spec.document import Spec
from armcal.kinematics.params import joint_kind
from armcal.support.units import factor, is_number, parse_number

MAX_ISSUES = 20
MAX_SAMPLES = 200_000  # rows of one data file (100,000 ball-bar samples take about 0.7 GiB at the fit)
DECIMAL_COMMA = re.compile(r"\d,\d")


class _Problems:
    def __init__(self, path: Path):
        self.path = path
        self.issues: list[Issue] = []

    def add(self, line: int, column: int | None, field: str, message: str) -> None:
        if len(self.issues) < MAX_ISSUES:
            self.issues.append(Issue(self.path, line, column, field, message))

    def raise_if_any(self) -> None:
        if self.issues:
            raise SpecError(self.issues)


def data_text(path: Path) -> str:
    """A data file's text (UTF-8, a BOM allowed), read within the limits of fileio.read_input and MAX_SAMPLES."""
    raw = read_input(path, "data")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise SpecError([Issue(path, line, None, "", "the file is not UTF-8 text (save it as UTF-8: Latin-1 or UTF-16 files are not read)")]) from None
    return _bounded(path, text)


def _bounded(path: Path, text: str) -> str:
    """A table's text without its BOM, within MAX_SAMPLES rows."""
    text = text.removeprefix("\ufeff")
    if text.count("\n") > MAX_SAMPLES + 1:
        raise SpecError([Issue(path, MAX_SAMPLES + 2, None, "", f"more than {MAX_SAMPLES} samples; split the campaign into files of fewer")])
    return text


def _table(path: Path, text: str | None = None) -> tuple[list[str], list[list[str]]]:
    """Header and rows of the data file at ``path`` (or of its ``text``, already decoded)."""
    text = data_text(path) if text is None else _bounded(path, text)
    lines = text.splitlines()
    if not lines or not lines[0].strip():
        raise SpecError([Issue(path, 1, None, "", "the file is empty; a header row is expected")])
    if ";" in lines[0] and "," not in lines[0]:
        raise SpecError(
            [Issue(path, 1, None, "", "columns are separated by ';': armcal reads comma-separated files with '.' as decimal mark")]
        )
    reader, rows, start = csv.reader(io.StringIO(text), strict=True), [], 1
    try:
        for row in reader:
            rows.append(row)
            start = reader.line_num + 1
    except csv.Error as exc:
        hint = ": an unclosed quote?" if "end of data" in str(exc) else ""
        raise SpecError([Issue(path, start, None, "", f"not a CSV row the reader can take ({exc}{hint})")]) from None
    return [h.strip(SPACES) for h in rows[0]], rows[1:]


COLUMN_NAME = re.compile(r"[A-Za-z0-9_. -]{1,40}")  # what a header cell may be to be quoted in a message; no cell ever is
SPACES = " \t"  # what is trimmed around a cell: ASCII spaces and tabs only (a no-break space is no part of a number)


def _header(header: list[str], cols: Layout, problems: _Problems) -> Layout:
    seen: set[str] = set()
    for index, name in enumerate(header, start=1):
        quotable = COLUMN_NAME.fullmatch(name) is not None  # else the file is no data file: none of it is echoed
        shown = f"'{name}'" if quotable else f"{index} (a header of {len(name)} characters that is no column name, not shown)"
        if name in seen:
            problems.add(1, index, name if quotable else "", f"column {shown} appears twice")
        seen.add(name)
        if name not in cols.known:
            close = difflib.get_close_matches(name, list(cols.known), n=1) if quotable else []
            hint = f" Did you mean '{close[0]}'?" if close else f" Known columns: {', '.join(cols.known)}."
            problems.add(1, index, name if quotable else "", f"unknown column {shown}.{hint}")
    missing = [c for c in cols.required if c not in seen]
    if missing:
        problems.add(1, None, "", f"missing column{'s' if len(missing) > 1 else ''}: {', '.join(missing)}")
    problems.raise_if_any()
    return cols


def _number(text: str, kind: str, spec: Spec) -> float:
    """A cell's number in internal units, by units.parse_number's strict rule; the ValueError says what is wrong
    without the cell's content."""
    try:
        value = parse_number(text)
    except ValueError:
        comma = "," in text and is_number(text.replace(",", "."))
        raise ValueError("not a number (a decimal comma? armcal reads '.')" if comma else
                         "not a number (armcal reads ASCII digits with an optional sign, '.' and exponent, e.g. -1.5e-3)") from None
    if not math.isfinite(value):
        raise ValueError("not a finite number (nan or an infinity)")
    if kind in ("length", "angle"):
        value *= factor(kind, getattr(spec.robot.units, kind))
        if not math.isfinite(value):
            raise ValueError(f"too large: infinite in {'mm' if kind == 'length' else 'rad'}, armcal's internal unit")
    elif kind == "direction" and value not in (1.0, -1.0):
        raise ValueError("a direction is +1 or -1")
    return value


def _valid_names(spec: Spec, device) -> dict[str, set[str]]:
    return {"target": set(spec.robot.targets), **device.key_names(spec.robot)}


def _parse(path: Path, spec: Spec, device, cols: Layout, header: list[str], rows: list[list[str]], problems: _Problems,
           verbatim: tuple[str, ...] = ()):
    """Numeric columns (internal units, NaN if empty) and text columns of every row, checked; text stripped of
    surrounding spaces, but in the columns ``verbatim``."""
    index = {name: i for i, name in enumerate(header)}
    names = _valid_names(spec, device)
    links = device.target_aliases(spec.robot)
    values = {c: np.full(len(rows), np.nan) for c, k in cols.known.items() if k != "text" and c in index}
    text = {c: [""] * len(rows) for c, k in cols.known.items() if k == "text" and c in index}
    for r, row in enumerate(rows):
        line = r + 2
        if len(row) != len(header):
            hint = " (decimal commas? armcal reads '.' as the decimal mark)" if len(row) > len(header) and DECIMAL_COMMA.search(",".join(row)) else ""
            problems.add(line, None, "", f"{len(row)} fields, but the header has {len(header)}{hint}")
            continue
        on_robot = "target" not in index or spreadsheet_text(row[index["target"]].strip(SPACES)) not in device.off_robot_targets
        for column, kind in cols.known.items():
            if column not in index:
                continue
            raw = row[index[column]].strip(SPACES)
            if kind == "text":  # as armcal writes it (fileio.spreadsheet_safe), its leading quote removed
                raw = spreadsheet_text(row[index[column]] if column in verbatim else raw)
                raw = links.get(raw, raw) if column == "target" and raw not in names["target"] else raw
                text[column][r] = raw
                if column in names and raw not in names[column]:
                    allowed = ", ".join(sorted(n for n in names[column] if n)) or "none"
                    known = "one of" if column in device.vocabulary_columns else "the spec's"
                    problems.add(line, index[column] + 1, column, f"not a known {column} ({known}: {allowed})")
            elif raw == "":
                if column in cols.required and not (column.startswith("q") and not on_robot):
                    problems.add(line, index[column] + 1, column, "empty value")
            else:
                try:
                    values[column][r] = _number(raw, kind, spec)
                except ValueError as exc:
                    problems.add(line, index[column] + 1, column, str(exc))
        if on_robot:
            _check_limits(spec, values, index, r, problems)
    if "sample" in text:
        _unique_samples(text["sample"], index["sample"] + 1, problems)
    problems.raise_if_any()
    return values, text


def _check_limits(spec: Spec, values: dict, index: dict, r: int, problems: _Problems) -> None:
    for i, joint in enumerate(spec.robot.joints, start=1):
        if f"q{i}" not in values:  # a table whose joint columns are optional (compensate's seeds)
            continue
        value = values[f"q{i}"][r]
        low, high = joint.limits
        if not np.isnan(value) and not low <= value <= high:
            kind = joint_kind(joint.type)
            unit = getattr(spec.robot.units, kind)
            shown = value / factor(kind, unit)
            problems.add(r + 2, index[f"q{i}"] + 1, f"q{i}", f"{shown:g} {unit} lies outside joint {i}'s limits")


def _rows(path: Path, spec: Spec, device, make_layout, text: str | None = None, verbatim: tuple[str, ...] = ()) -> tuple[Layout, dict, dict, int]:
    problems = _Problems(path)
    header, rows = _table(path, text)
    cols = _header(header, make_layout(header), problems)
    if not rows:
        raise SpecError([Issue(path, 2, None, "", "the file has a header but no data rows")])
    values, text = _parse(path, spec, device, cols, header, rows, problems, verbatim)
    return cols, values, text, len(rows)


def read_measurements(path: Path, spec: Spec) -> Measurements:
    """Measurements of a data file, in internal units; SpecError lists the problems found."""
    path = Path(path)
    device = device_model(spec)
    cols, values, text, count = _rows(path, spec, device, lambda header: layout(spec, header, device))
    n = spec.robot.dof
    extras = {c: values[c] for c in values if c in ("t", "temperature") or c.startswith("rod_")}
    readings = {c: values[c] for c in values if c not in extras and not c.startswith(("q", "dir"))}
    if "dir1" in values:
        extras["dir"] = np.stack([values.get(f"dir{i}", np.zeros(count)) for i in range(1, n + 1)], axis=1)
    return Measurements(
        keys=tuple(device.key_of(key) for key in _keys(cols, text, count)),
        q=np.stack([values[f"q{i}"] for i in range(1, n + 1)], axis=1),
        readings=readings,
        extras=extras,
        rows=np.arange(2, count + 2),
        source=path,
        sample=tuple(text["sample"]) if "sample" in text else None,
        register=np.array([use == "register" for use in text["use"]]) if "use" in text else None,
    )


def read_joint_file(path: Path, spec: Spec) -> np.ndarray:
    """Joint values (N, n) from a pose list with columns q1..qN (and optionally sample)."""
    return read_pose_file(path, spec)[0]


def read_pose_file(path: Path, spec: Spec) -> tuple[np.ndarray, tuple | None]:
    """Joint values (N, n) of a pose list and, for an instrument that reads each pose on one key, that key.

    Columns q1..qN, optionally sample; such an instrument's pose list also has its key columns (a ball-bar's
    pivot, sphere and optionally extension: the bar each pose is measured with, as ``armcal plan`` writes them).
    Other instruments read every pose on each of their keys: their keys are None.
    """
    device = device_model(spec)
    joints = joint_columns(spec)
    keyed = device.keyed_poses
    keys = {c: "text" for c in device.key_columns} if keyed else {}
    optional = {"sample": "text", **({c: "text" for c in device.optional_key_columns} if keyed else {})}
    columns = Layout(device.key_columns if keyed else (), {**joints, **keys}, optional, device.optional_key_columns if keyed else ())
    cols, values, text, count = _rows(Path(path), spec, device, lambda header: columns)
    return np.stack([values[c] for c in joints], axis=1), _keys(cols, text, count) if keyed else None


def read_table(path: Path, text: str, spec: Spec, make_layout, verbatim: tuple[str, ...] = ()) -> tuple[dict, dict, int]:
    """(numeric columns in internal units, NaN where empty; text columns; rows) of a table other than measured data,
    such as compensate's targets, by the rules of a data file: ``make_layout(header)`` says its columns, an unknown,
    doubled or missing column, a short or long row, a cell that is no finite number, a joint value outside its limits
    is a located problem; no content but an accepted column name is quoted. Text columns ``verbatim`` keep their spaces."""
    _, values, text_columns, count = _rows(Path(path), spec, device_model(spec), make_layout, text, verbatim)
    return values, text_columns, count


def _unique_samples(samples: list[str], column: int, problems: _Problems) -> None:
    first: dict[str, int] = {}
    for r, sample in enumerate(samples):
        if sample in first:
            problems.add(r + 2, column, "sample", f"the sample repeats line {first[sample]}'s")
        else:
            first[sample] = r + 2


def _keys(cols: Layout, text: dict[str, list[str]], count: int) -> tuple:
    """Each sample's key: its key columns' names, then its optional key columns' (None where empty or left out)."""
    required = zip(*(text[c] for c in cols.key_columns))
    optional = zip(*(text.get(c, [""] * count) for c in cols.optional_keys)) if cols.optional_keys else ((),) * count
    return tuple((*k, *(v or None for v in o)) for k, o in zip(required, optional))
