"""Many tests at once: Holm's step-down test keeps the family-wise probability of any false flag at ALPHA.

Used where a change is tested many times over (every parameter of two calibrations, every predicted position:
results/changes.py, evaluate/position_changes.py): with forty unchanged parameters tested one by one at 1 %, one
comparison in three would flag something by chance.
"""

from __future__ import annotations

ALPHA = 0.01  # family-wise probability of flagging anything unchanged


def holm(p_values: list[float]) -> list[bool]:
    """Which of a family of p-values Holm's step-down test rejects at family-wise ALPHA: the k-th smallest (from 0)
    against ALPHA / (m - k), stopping at the first that is not below it (Holm 1979)."""
    rejected = [False] * len(p_values)
    for rank, i in enumerate(sorted(range(len(p_values)), key=lambda i: p_values[i])):
        if p_values[i] > ALPHA / (len(p_values) - rank):
            break
        rejected[i] = True
    return rejected
