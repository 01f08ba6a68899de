"""Issue 17, item 2's Must-show, measured (slow: ~8 min): benchmarks/plan_vs_random.py's study on 100 robots.

UR10 and KR 6 R900 with a tracker at N = 15, 30, 60, the KR 6 R900 with a ball-bar at N = 60, 120, 240
(docs/plan.md has the table and why the ball-bar cannot be identified from 15 or 30 poses). What holds: N
planned poses beat N random poses in every case. What the issue hoped for and the study refutes: N planned
poses reach the accuracy of 3N random poses; that test is a strict expected failure, so it reports the day
it starts to pass. Everything is seeded: the numbers are the benchmark's.
"""

from __future__ import annotations

import importlib.util

import pytest
from conftest import ROOT

pytestmark = pytest.mark.slow
RUNS = 100


@pytest.fixture(scope="module")
def table():
    spec = importlib.util.spec_from_file_location("plan_vs_random", ROOT / "benchmarks" / "plan_vs_random.py")
    study = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(study)
    return study.run(RUNS)


def test_planned_poses_beat_as_many_random_poses(table):
    assert len(table) == 9
    for row in table:
        assert row["D"] < row["random"], row  # measured ratios 0.40 (ball-bar, N = 60) to 0.94


@pytest.mark.xfail(strict=True, reason="measured: N planned poses are worth 1.1-2.2 N random ones; D / random 3N = 1.45-1.80 (docs/plan.md)")
def test_planned_poses_reach_three_times_as_many_random_poses(table):
    for row in table:
        assert row["D"] <= row["random3"], row
