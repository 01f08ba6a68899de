"""Errors by audience.

``UserError`` and ``SpecError`` are mistakes a user can fix (the CLI prints them
and exits 1); anything else is a bug in armcal and keeps its traceback. ``with_article``
words their messages.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

SHOWN = 40  # characters of a value read from a file that a message may show
_KEY = re.compile(r"[A-Za-z0-9_.-]{1,40}")


def either(names: list[str]) -> str:
    """a, b or c."""
    return " or ".join(filter(None, (", ".join(names[:-1]), names[-1])))


def with_article(word: str) -> str:
    """'an angle', 'a length': ``word`` with the indefinite article a message needs."""
    return f"{'an' if word[:1].lower() in 'aeiou' else 'a'} {word}"


def shown_text(text: str, what: str = "a value") -> str:
    """A text read from a file (a robot's name or serial, a value) as a message shows it: itself when it is short
    printable text (at most SHOWN characters, no control, escape or format characters), else described, never
    quoted: 'a name of 325 characters (not shown)'. Every message that echoes a value read from a file uses this (or
    shown_key / shown_value), so no file passes escape sequences to the terminal or floods it."""
    text = str(text)
    if len(text) <= SHOWN and text.isprintable():
        return text
    return _described(text, what, "" if text.isprintable() else " with control characters")


def shown_key(key: Any, quoted: bool = False) -> str:
    """A key read from a file (a spec's unknown key) as a message shows it: itself when it looks like a key (at most
    SHOWN characters of letters, digits, '_', '.' and '-'), else described: 'a key of 307 characters (not shown)'."""
    if isinstance(key, int) or _KEY.fullmatch(str(key)):
        return f"'{key}'" if quoted else str(key)
    return _described(str(key), "a key")


def shown_value(value: Any) -> str:
    """A value read from a spec as a message shows it: a text quoted ('abc') by shown_text's rule, a number or
    another value as Python writes it when that is at most SHOWN printable characters, else described."""
    if isinstance(value, str):
        shown = shown_text(value)
        return f"'{value}'" if shown == value else shown
    kind = {"list": "list", "tuple": "list", "dict": "mapping"}.get(type(value).__name__, "number")
    try:
        text = repr(value)
    except ValueError:  # an integer of thousands of digits
        return f"a {kind} too long to show"
    return text if len(text) <= SHOWN and text.isprintable() else f"a {kind} too long to show"


def _described(text: str, what: str, note: str = "") -> str:
    return f"{what} of {len(text)} character{'s' if len(text) != 1 else ''}{note} (not shown)"


class UserError(Exception):
    """A mistake in the user's input, with one clear message."""


@dataclass(frozen=True)
class Issue:
    """One located problem in an input file."""

    file: Path
    line: int | None  # 1-based
    column: int | None  # 1-based
    field: str  # dotted path of the field, e.g. "robot.joints[2].a"
    message: str

    def __str__(self) -> str:
        where = str(self.file)
        if self.line is not None:
            where += f":{self.line}"
            if self.column is not None:
                where += f":{self.column}"
        field = f" {self.field}:" if self.field else ""
        return f"{where}:{field} {self.message}"


class SpecError(UserError):
    """One or more located problems in a spec or data file."""

    def __init__(self, issues: list[Issue]):
        self.issues = issues
        count = f"{len(issues)} problem{'s' if len(issues) != 1 else ''}"
        super().__init__(f"{count} found:\n" + "\n".join(f"  {i}" for i in issues))

    def __reduce__(self):  # crosses process boundaries (worker pools) whole
        return (SpecError, (self.issues,))
