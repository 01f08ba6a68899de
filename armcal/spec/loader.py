"""Load a spec from YAML, keeping the line and column of every key and value.

ruamel.yaml's round-trip loader is safe (it builds no Python objects from tags)
and records positions; pydantic errors are mapped back to those positions and
rewritten as plain sentences. All problems are reported at once.
"""

from __future__ import annotations

import difflib
import re
import hashlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import ValidationError
from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap, CommentedSeq
from ruamel.yaml.error import MarkedYAMLError, YAMLError

from armcal.support import units
from armcal.support.errors import Issue, SpecError, shown_key, shown_value
from armcal.support.fileio import read_input
from armcal.spec.checks import check_spec
from armcal.spec.document import Spec
from armcal.kinematics.params import joint_kind
from armcal.spec.schema import allowed_keys

MAX_NODES = 200_000  # guards against alias ("billion laughs") expansion
DISCRIMINATORS = ("type", "convention")

Loc = tuple[str | int, ...]


@dataclass(frozen=True)
class LoadedSpec:
    """A validated spec with where it came from."""

    spec: Spec
    path: Path
    text: str
    sha256: str


@dataclass
class _Document:
    """Plain data of a YAML document plus positions (1-based) of values and keys."""

    data: Any
    values: dict[Loc, tuple[int, int]]
    keys: dict[Loc, tuple[int, int]]


def load_spec(path: str | Path) -> LoadedSpec:
    """Read, parse and validate a spec file; raise SpecError listing every problem."""
    path = Path(path)
    return spec_from_bytes(read_input(path, "spec"), path)


def spec_from_bytes(raw: bytes, path: Path) -> LoadedSpec:
    """Parse and validate a spec's bytes (read from ``path``, or from git as ``path@rev``); SpecError lists every problem."""
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SpecError([Issue(path, None, None, "", f"the file is not UTF-8 text (byte {exc.start})")]) from None
    document = parse_yaml(text, path)
    spec = validate(document, path)
    return LoadedSpec(spec=spec, path=path, text=text, sha256=hashlib.sha256(raw).hexdigest())


_QUOTED = re.compile(r"\"[^\"\n]*\"|'[^'\n]*'")
_PARSER_TOKEN = re.compile(r"[^\w\s]{1,3}|<[a-z ]{1,20}>")  # what the parser names itself: ',' or '<stream end>'


def _parser_words(message: str) -> str:
    """The YAML parser's message without what it quotes from the file (a duplicate key's values, a character): a
    duplicate key is named when it looks like a key (errors.shown_key), nothing else quoted is shown."""
    duplicate = re.search(r'found duplicate key "(.*?)" with value', message)
    if duplicate:
        return f"{message[:duplicate.start()]}found duplicate key {shown_key(duplicate.group(1), quoted=True)}"
    return _QUOTED.sub(lambda quoted: quoted.group(0) if _PARSER_TOKEN.fullmatch(quoted.group(0)[1:-1])
                       else f"({len(quoted.group(0)) - 2} characters, not shown)", message)


def parse_yaml(text: str, path: Path) -> _Document:
    """Parse YAML text into plain data with positions; syntax errors become a located issue."""
    yaml = YAML(typ="rt")
    try:
        root = yaml.load(text)
    except MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        message = " ".join(filter(None, [exc.context, exc.problem])) or "invalid YAML"
        line, column = (mark.line + 1, mark.column + 1) if mark else (None, None)
        raise SpecError([Issue(path, line, column, "", f"YAML syntax error: {_parser_words(message)}")]) from None
    except YAMLError as exc:
        raise SpecError([Issue(path, None, None, "", f"YAML error: {_parser_words(str(exc))}")]) from None
    except RecursionError:
        raise SpecError([Issue(path, None, None, "", "the YAML is nested too deeply (hundreds of levels); a spec needs a few")]) from None
    except ValueError as exc:  # e.g. an integer of more digits than Python converts
        raise SpecError([Issue(path, None, None, "", f"a value cannot be read: {str(exc).split(';')[0][:120]}")]) from None
    if not isinstance(root, CommentedMap):
        raise SpecError([Issue(path, 1, 1, "", "a spec must be a mapping with robot, device and procedure sections")])
    document = _Document(data=None, values={(): (root.lc.line + 1, root.lc.col + 1)}, keys={})
    budget = [MAX_NODES]
    try:
        document.data = _plain(root, (), document, budget)
    except RecursionError:
        raise SpecError([Issue(path, None, None, "", "the YAML is nested too deeply (hundreds of levels); a spec needs a few")]) from None
    except _TooLarge:
        raise SpecError(
            [Issue(path, None, None, "", f"the YAML expands to more than {MAX_NODES} values (anchors and aliases?)")]
        ) from None
    return document


class _TooLarge(Exception):
    pass


def _record(positions: dict, loc: Loc, mark: tuple[int, int] | None) -> None:
    """Store a 0-based (line, column) from ruamel as 1-based; some nodes have none."""
    if mark is not None:
        positions[loc] = (mark[0] + 1, mark[1] + 1)


def _plain(node: Any, loc: Loc, document: _Document, budget: list[int]) -> Any:
    budget[0] -= 1
    if budget[0] < 0:
        raise _TooLarge
    if isinstance(node, CommentedMap):
        out = {}
        for key in node:
            key_loc = (*loc, str(key))
            mark = (node.lc.data or {}).get(key)  # None for a key merged in (<<: *anchor): located at its mapping
            _record(document.keys, key_loc, mark[0:2] if mark else None)
            _record(document.values, key_loc, mark[2:4] if mark else None)
            out[str(key)] = _plain(node[key], key_loc, document, budget)
        return out
    if isinstance(node, CommentedSeq):
        out_list = []
        for i, item in enumerate(node):
            _record(document.values, (*loc, i), node.lc.item(i))
            out_list.append(_plain(item, (*loc, i), document, budget))
        return out_list
    if hasattr(node, "value") and not isinstance(node, (int, float, str, bool)):
        return node.value  # tagged scalars: keep the plain value, never construct objects
    if isinstance(node, str):
        return str(node)
    if isinstance(node, bool):
        return bool(node)
    if isinstance(node, int):
        return int(node)
    if isinstance(node, float):
        return float(node)
    return node


def validation_context(data: dict) -> dict:
    """Units and joint kinds read ahead from the raw data, used while converting quantities."""
    robot = data.get("robot") if isinstance(data.get("robot"), dict) else {}
    spec_units = robot.get("units") if isinstance(robot.get("units"), dict) else {}
    joints = robot.get("joints") if isinstance(robot.get("joints"), list) else []
    valid = {"length": units.LENGTH_UNITS, "angle": units.ANGLE_UNITS}
    return {
        "units": {k: v for k, v in spec_units.items() if k in valid and isinstance(v, str) and v in valid[k]},
        "joint_kinds": [joint_kind(j.get("type", "revolute") if isinstance(j, dict) else "revolute") for j in joints],
    }


def validate(document: _Document, path: Path) -> Spec:
    """Validate plain data as a Spec; map every error to file, line, column and field."""
    try:
        spec = Spec.model_validate(document.data, context=validation_context(document.data))
    except ValidationError as exc:
        issues = [_issue(error, document, path) for error in exc.errors()]
        raise SpecError(_sorted(issues)) from None
    problems = check_spec(spec)
    if problems:
        raise SpecError(_sorted([_located(loc, message, document, path) for loc, message in problems]))
    return spec


def missing_data_files(loaded: LoadedSpec) -> list[Issue]:
    """The data files a spec names that are not there (yet): `armcal run` needs them, `armcal simulate` writes them."""
    data = loaded.spec.data
    if data is None:
        return []
    message = "no such file beside the spec (paths are relative to its folder); `armcal run` needs it, `armcal simulate` writes simulated data"
    return located_issues(loaded, [
        (("data", key), f"{name}: {message}")
        for key, name in (("calibration", data.calibration), ("validation", data.validation))
        if name and not (loaded.path.parent / name).is_file()
    ])


def located_issues(loaded: LoadedSpec, messages: list[tuple[Loc, str]]) -> list[Issue]:
    """Each (field, message) about a loaded spec as an issue at the field's line and column (warnings of validate)."""
    if not messages:
        return []
    document = parse_yaml(loaded.text, loaded.path)
    return [_located(loc, message, document, loaded.path) for loc, message in messages]


def _sorted(issues: list[Issue]) -> list[Issue]:
    return sorted(issues, key=lambda i: (i.line or 0, i.column or 0, i.field))


def _data_loc(loc: Loc, data: Any) -> Loc:
    """Drop the parts of a pydantic loc that are not in the data (union and tag names)."""
    out: list[str | int] = []
    node = data
    for part in loc:
        if isinstance(node, dict) and part in node:
            out.append(part)
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
            out.append(part)
            node = node[part]
        elif isinstance(node, dict) and any(node.get(d) == part for d in DISCRIMINATORS):
            continue
        elif isinstance(part, str) and not isinstance(node, dict):
            continue  # a union member's name under a scalar
        else:
            out.append(part)  # a missing or unknown key: keep it, it names the field
            node = None
    return tuple(out)


def _field_name(loc: Loc) -> str:
    text = ""
    for part in loc:
        name = shown_key(part)  # a key the file gave, shown only when it looks like one
        text += f"[{part}]" if isinstance(part, int) else (f".{name}" if text else name)
    return text


def _position(loc: Loc, document: _Document, key: bool = False) -> tuple[int | None, int | None]:
    if key and loc in document.keys:
        return document.keys[loc]
    for end in range(len(loc), -1, -1):
        if loc[:end] in document.values:
            return document.values[loc[:end]]
    return (None, None)


def _located(loc: Loc, message: str, document: _Document, path: Path, key: bool = False) -> Issue:
    line, column = _position(loc, document, key)
    return Issue(path, line, column, _field_name(loc), message)


def _issue(error: dict, document: _Document, path: Path) -> Issue:
    loc = _data_loc(tuple(error["loc"]), document.data)
    kind = error["type"]
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        loc = (*loc, str(error.get("ctx", {}).get("discriminator", "")).strip("'"))
    return _located(loc, plain_message(error, loc, document.data), document, path, key=kind == "extra_forbidden")


def plain_message(error: dict, loc: Loc, data: Any = None) -> str:
    """Rewrite a pydantic error as a plain sentence."""
    kind, ctx, value = error["type"], error.get("ctx", {}), error.get("input")
    if kind == "extra_forbidden":
        name = str(loc[-1]) if loc else ""
        allowed = allowed_keys(loc[:-1], data)
        close = difflib.get_close_matches(name, allowed, n=1, cutoff=0.6)
        hint = f" Did you mean '{close[0]}'?" if close else (f" Allowed here: {', '.join(allowed)}." if allowed else "")
        return f"This field is unknown here. Remove it or check its spelling.{hint}"
    if kind == "missing":
        return "This field is required."
    if kind == "union_tag_invalid":
        return f"{shown_value(ctx.get('tag'))} is not a known {ctx.get('discriminator', '').strip(chr(39))}; use one of {ctx.get('expected_tags')}."
    if kind == "union_tag_not_found":
        return f"The field {ctx.get('discriminator')} is required here."
    if kind == "literal_error":
        return f"Expected {ctx.get('expected')}, got {shown_value(value)}."
    if kind in ("float_parsing", "float_type", "finite_number"):
        return f"Expected a number, got {shown_value(value)}."
    if kind in ("int_parsing", "int_type", "int_from_float"):
        return f"Expected a whole number, got {shown_value(value)}."
    if kind in ("bool_parsing", "bool_type"):
        return f"Expected true or false, got {shown_value(value)}."
    if kind == "string_type":
        return f"Expected text, got {shown_value(value)}."
    if kind in ("list_type", "tuple_type"):
        return f"Expected a list, got {shown_value(value)}."
    if kind in ("dict_type", "model_type", "model_attributes_type"):
        return f"Expected a mapping of keys to values, got {shown_value(value)}."
    if kind in ("too_short", "too_long"):
        bound = ctx.get("min_length") if kind == "too_short" else ctx.get("max_length")
        word = "at least" if kind == "too_short" else "at most"
        return f"Expected {word} {bound} entries, got {ctx.get('actual_length')}."
    if kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        words = {"greater_than": "above", "greater_than_equal": "at least", "less_than": "below", "less_than_equal": "at most"}
        limit = next(iter(ctx.values()), "")
        return f"Must be {words[kind]} {limit}, got {shown_value(value)}."
    if kind in ("value_error", "assertion_error"):
        message = str(ctx.get("error", error["msg"]))
        return message[:1].upper() + message[1:] + ("" if message.endswith(".") else ".")
    return error["msg"]


def spec_line(loaded: LoadedSpec, loc: Loc) -> int | None:
    """The line of a spec key (or of the nearest enclosing key the file has), for messages that point into the spec."""
    return _position(tuple(loc), parse_yaml(loaded.text, loaded.path))[0]
