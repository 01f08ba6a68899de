"""Errors by audience.

``UserError`` and ``SpecError`` are mistakes a user can fix (the CLI prints them
and exits 1); anything else is a bug in armcal and keeps its traceback. ``with_article``
words their messages.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


def either(names: list[str]) -> str:
    """a, b or c."""
    return " or ".join(filter(None, (", ".join(names[:-1]), names[-1])))


def with_article(word: str) -> str:
    """'an angle', 'a length': ``word`` with the indefinite article a message needs."""
    return f"{'an' if word[:1].lower() in 'aeiou' else 'a'} {word}"


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
