"""Issue 17's claim where the robot works (slow: ~10 min on free cores, 24 min on two shared ones):
benchmarks/plan_in_region.py's study, ISO 9283 cube.

UR10 and KR 6 R900 with a tracker, N = 15, 30, 60, held-out poses in the ISO 9283 cube at the task's orientation
and at any orientation (docs/plan.md has the table and the definitions). What holds: the I-optimal plan for the
region beats N random poses (over the whole joint range and in the region) in every case, and the region-blind
D-optimal plan at the task's orientation (at any orientation the two are within a few per cent); for the KR 6
R900's cube (370 mm since the placement by search of issue 34, 192 mm before) at the task's orientation it is worth
2.2 to 2.5 times as many random poses and 0.67 to 0.68 times the D-plan's error. These measured gains are asserted
with margins. What the issue hoped for, N planned poses as accurate as 3N random ones, no row of twelve reaches
(I / 3N 1.12 +- 0.04 at the nearest): it is not claimed. Everything is seeded: the numbers are the benchmark's and
docs/plan.md's (100 robots).
"""

from __future__ import annotations

import importlib.util
import sys

import pytest
from conftest import ROOT

pytestmark = pytest.mark.slow
RUNS = 100


@pytest.fixture(scope="module")
def table():
    sys.path.insert(0, str(ROOT / "benchmarks"))
    spec = importlib.util.spec_from_file_location("plan_in_region", ROOT / "benchmarks" / "plan_in_region.py")
    study = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(study)
    return study, study.run(RUNS)


def test_the_region_plan_beats_the_blind_plan_and_as_many_random_poses(table):
    _, rows = table
    assert len(rows) == 12
    for row in rows:
        assert row["I"] < min(row["a1"], row["b1"]), row  # measured ratios 0.51 (KR 6, task, N = 15) to 0.96
        assert row["I"] < row["D"] * 1.05, row  # I / D 1.02 at most; 0.67-0.83 at the task orientation
        if row["case"].startswith("KR 6") and "task" in row["case"]:
            assert row["I"] < 0.72 * row["D"], row  # measured 0.67-0.68 (0.61-0.62 in the 192 mm cube)


def test_for_a_small_cube_at_the_task_orientation_a_plan_is_worth_more_than_twice_as_many_random_poses(table):
    study, rows = table
    for row in rows:
        if row["case"].startswith("KR 6") and "task" in row["case"]:
            assert study.worth(row["I"], row["a1"], row["a3"]) > 2.1, row  # measured 2.24 to 2.43 (370 mm cube; 2.69-2.75 in the 192 mm one)
            assert study.worth(row["I"], row["b1"], row["b3"]) > 2.1, row  # measured 2.34 to 2.51 (2.46-2.79)
