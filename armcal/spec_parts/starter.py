"""Building blocks of the starting specs `armcal new` writes (each instrument lays out its own sections)."""

from __future__ import annotations


def mm(value: float) -> str:
    """A length in mm as a spec writes it, to 0.1 mm."""
    return f"{round(value, 1):g}"


def flange_point(dof: int, name: str, x: float = 50.0, z: float = 100.0) -> str:
    """A robot target on the flange (the last link), flange frame."""
    return f"{name}: {{link: {dof}, x: {mm(x)}, y: 0, z: {mm(z)}}}   # on the flange, flange frame (mm)"


def random_poses(count: int, seed: int) -> list[str]:
    """A poses procedure of ``count`` random poses."""
    return ["  type: poses", f"  count: {count}   # random poses within the joint limits", f"  seed: {seed}"]
