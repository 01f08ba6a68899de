"""Placeholders: the stand-ins `armcal new` and `armcal import-urdf` write for what only the user knows.

A generator lists each stand-in it wrote under the spec's ``placeholders``, with the fingerprint of the value as
written (16 hex digits of the SHA-256 of its canonical JSON). A field whose value still has that fingerprint is a
placeholder: `armcal validate` warns about it and `armcal run` states it "not given" on the certificate. Once the value
is edited, it is the user's and its entry is silent; a stand-in that is right as written is confirmed by removing its
entry. Nothing depends on comments, names or formatting: the values alone decide.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from armcal.support.errors import Issue
from armcal.spec.loader import LoadedSpec, located_issues, parse_yaml
from armcal.spec.sections import STANDS_FOR


def fingerprint(value: Any) -> str:
    """16 hex digits of the SHA-256 of ``value``'s canonical JSON (keys sorted; dates as text)."""
    canonical = json.dumps(value, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(canonical.encode("utf-8")).hexdigest()[:16]


def _value(data: dict, field: str) -> Any:
    """The value at a dotted field of the spec's plain data, None where there is none."""
    for key in field.split("."):
        data = data.get(key) if isinstance(data, dict) else None
    return data


def marker_lines(text: str, fields: list[str]) -> list[str]:
    """The ``placeholders:`` section a generator appends to the spec ``text`` it wrote, for its stand-in ``fields``."""
    data = parse_yaml(text, Path("generated spec")).data
    return [
        "# The stand-ins above, each with the fingerprint of its value as written: `armcal validate` warns about each one",
        "# still unchanged and the certificate states it not given. Replace them; remove a line to keep its value as it is.",
        "placeholders:",
        *(f"  {field}: {fingerprint(_value(data, field))}   # {STANDS_FOR[field]}" for field in fields),
    ]


def placeholders(loaded: LoadedSpec) -> list[tuple[str, Any]]:
    """(field, value) of each field of ``loaded`` that still holds the value a generator wrote, in the order listed."""
    data = parse_yaml(loaded.text, loaded.path).data
    values = [(field, _value(data, field), written) for field, written in loaded.spec.placeholders.items()]
    return [(field, value) for field, value, written in values if value is not None and fingerprint(value) == written]


def placeholder_warnings(loaded: LoadedSpec) -> list[Issue]:
    """One located warning per placeholder, saying what to give instead (`armcal validate`)."""
    return located_issues(loaded, [(tuple(field.split(".")), _message(field, value)) for field, value in placeholders(loaded)])


def placeholder_notes(loaded: LoadedSpec) -> list[str]:
    """The same warnings as `armcal run` lists them (results.json ``warnings``): field, then message."""
    return [f"{field}: {_message(field, value)}" for field, value in placeholders(loaded)]


def _message(field: str, value: Any) -> str:
    shown = f" ({json.dumps(value)})" if isinstance(value, str) else ""
    return (f"the stand-in armcal wrote{shown}, unchanged: give {STANDS_FOR[field]} (the certificate states it not given); "
            f"if it is right as it stands, remove '{field}' from placeholders")
