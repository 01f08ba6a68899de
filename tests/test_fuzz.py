"""Fuzzing: mutated specs and data files end in a located user error (or load), never in a traceback."""

import copy
import functools
import io
import time

import numpy as np
import yaml
from conftest import HANG, ROOT, shipped_specs
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from ruamel.yaml import YAML

from armcal.dataio.reader import read_measurements
from armcal.support.errors import SpecError, UserError
from armcal.spec import load_spec

SPECS = shipped_specs()
# the same examples on every machine and run (no random seed per run, no database of earlier finds replayed)
FUZZ = dict(deadline=None, derandomize=True, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
BAD_VALUES = st.one_of(
    st.text(max_size=12),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.floats(allow_nan=True, allow_infinity=True),
    st.none(),
    st.booleans(),
    st.lists(st.integers(), max_size=3),
    st.dictionaries(st.text(max_size=5), st.integers(), max_size=2),
    st.sampled_from(["3 furlong", "1e308 mm", "-5 deg", "nan", "inf rad", "12 cm cm", "", "!!python/object:os.system"]),
)


def _paths(node, prefix=()):
    """Every path to a value in plain YAML data."""
    yield prefix
    if isinstance(node, dict):
        for key, value in node.items():
            yield from _paths(value, (*prefix, key))
    elif isinstance(node, list):
        for i, value in enumerate(node):
            yield from _paths(value, (*prefix, i))


@functools.cache
def _parsed(which: int):
    """A shipped spec's text and its plain data (parsed once, copied for each mutation)."""
    text = SPECS[which].read_text()
    return text, YAML(typ="safe").load(text)


def _ascii_only(node) -> bool:
    if isinstance(node, dict):
        return all(_ascii_only(k) and _ascii_only(v) for k, v in node.items())
    if isinstance(node, list):
        return all(_ascii_only(v) for v in node)
    return not isinstance(node, str) or node.isascii()


def _dumped(data) -> str:
    """The data as ruamel's safe dumper writes them (sorted keys, innermost mappings in flow style). libyaml's
    emitter (PyYAML's CSafeDumper, ten times faster) writes the same text, except that it escapes characters such
    as private-use ones that ruamel writes raw, and does not break a flow collection longer than the line width
    onto a second line as ruamel does: those data go through ruamel, so the loader still reads such texts."""
    if _ascii_only(data):
        text = yaml.dump(data, Dumper=yaml.CSafeDumper, default_flow_style=None, allow_unicode=True, width=80)
        if max(map(len, text.splitlines()), default=0) <= 80:
            return text
    out = io.StringIO()
    YAML(typ="safe").dump(data, out)
    return out.getvalue()


def _mutate(data, path, action, value):
    parent = data
    for part in path[:-1]:
        parent = parent[part]
    last = path[-1]
    if action == "replace":
        parent[last] = value
    elif action == "delete" and isinstance(parent, dict):
        del parent[last]
    elif action == "unknown" and isinstance(parent, dict):
        parent[f"{last}_extra"] = value
    elif action == "duplicate" and isinstance(parent, list):
        parent.append(parent[last])


def _load(text: str, tmp_path):
    path = tmp_path / "fuzz.yaml"
    path.write_text(text)
    started = time.perf_counter()
    try:
        load_spec(path)
    except SpecError as exc:
        assert exc.issues and all(issue.line is not None or "YAML" in issue.message for issue in exc.issues), exc
        assert all(issue.message for issue in exc.issues)
    assert time.perf_counter() - started < HANG  # a hang guard (nested aliases, huge numbers), not a speed goal


@settings(max_examples=400, **FUZZ)
@given(
    which=st.integers(min_value=0, max_value=len(SPECS) - 1),
    pick=st.integers(min_value=0, max_value=10**6),
    action=st.sampled_from(["replace", "delete", "unknown", "duplicate", "truncate"]),
    value=BAD_VALUES,
)
def test_mutated_specs_fail_with_located_messages(tmp_path, which, pick, action, value):
    text, original = _parsed(which)
    if action == "truncate":
        _load(text[: pick % len(text)], tmp_path)
        return
    data = copy.deepcopy(original)
    paths = [p for p in _paths(data) if p]
    _mutate(data, paths[pick % len(paths)], action, value)
    _load(_dumped(data), tmp_path)


def test_hostile_yaml(tmp_path):
    bomb = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(f"{c}: &{c} [*{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}]\n" for p, c in zip("abcdefgh", "bcdefghi"))
    for text in (bomb, "!!python/object/apply:os.system ['true']\n", "robot: {name: [}", "\x00\x01", "---\n...\n", "- a\n- b\n"):
        _load(text, tmp_path)


DATA = ROOT / "examples" / "theodolite"


@settings(max_examples=200, **FUZZ)
@given(
    row=st.integers(min_value=0, max_value=10**6),
    column=st.integers(min_value=0, max_value=20),
    action=st.sampled_from(["cell", "truncate", "drop_column", "semicolons", "decimal_comma", "blank_line", "extra_field"]),
    value=st.one_of(st.text(max_size=8), st.sampled_from(["nan", "inf", "-inf", "", "1e999", "ghost", "t9"])),
)
def test_mutated_data_fail_with_file_row_and_column(tmp_path, row, column, action, value):
    spec = load_spec(DATA / "spec.yaml").spec
    lines = (DATA / "calibration.csv").read_text().splitlines()[:40]
    r = 1 + row % (len(lines) - 1)
    fields = lines[r].split(",")
    c = column % len(fields)
    if action == "cell":
        fields[c] = value.replace(",", ";").replace("\n", " ")
        lines[r] = ",".join(fields)
    elif action == "truncate":
        lines[r] = lines[r][: row % max(len(lines[r]), 1)]
        lines = lines[: r + 1]
    elif action == "drop_column":
        lines = [",".join(f for i, f in enumerate(line.split(",")) if i != c) for line in lines]
    elif action == "semicolons":
        lines = [line.replace(",", ";") for line in lines]
    elif action == "decimal_comma":
        lines[r] = lines[r].replace(".", ",")
    elif action == "blank_line":
        lines.insert(r, "")
    else:
        lines[r] += ",1"
    path = tmp_path / "data.csv"
    path.write_text("\n".join(lines) + "\n")
    try:
        data = read_measurements(path, spec)
    except SpecError as exc:
        assert all(issue.line is not None and issue.message for issue in exc.issues)
        return
    except UserError:
        return
    assert len(data) > 0 and np.isfinite(np.concatenate([v[~np.isnan(v)] for v in data.readings.values()])).all()
