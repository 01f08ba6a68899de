"""Issue 17, item 2's Must-show, measured (slow: ~8 min): benchmarks/plan_vs_random.py's study on 100 robots.

UR10 and KR 6 R900 with a tracker at N = 15, 30, 60, the KR 6 R900 with a ball-bar at N = 60, 120, 240
(docs/plan.md has the table and why the ball-bar cannot be identified from 15 or 30 poses). What holds: N
planned poses beat N random poses in every case and are worth 1.1 to 2.2 N random ones. What the issue hoped
for and the study refutes: N planned poses reach the accuracy of 3N random poses (3N random are 1.45 to 1.8
times as accurate); the measured gains are asserted instead, with margins. Everything is seeded: the numbers
are the benchmark's.
"""

from __future__ import annotations

import importlib.util

import pytest
from conftest import ROOT

pytestmark = pytest.mark.slow
RUNS = 100


def _benchmark():
    spec = importlib.util.spec_from_file_location("plan_vs_random", ROOT / "benchmarks" / "plan_vs_random.py")
    study = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(study)
    return study


def worth(row: dict) -> float:
    """How many times N random poses the N planned are worth (the benchmark's log-log interpolation)."""
    return _benchmark().worth(row)


@pytest.fixture(scope="module")
def table():
    return _benchmark().run(RUNS)


def test_planned_poses_beat_as_many_random_poses(table):
    assert len(table) == 9
    for row in table:
        assert row["D"] < row["random"], row  # measured ratios 0.40 (ball-bar, N = 60) to 0.94


def test_planned_poses_are_worth_more_random_poses_but_not_three_times_as_many(table):
    """The measured gain, with margins: N planned poses are worth 1.12 to 2.16 N random ones (docs/plan.md); 3N random
    poses are 1.45 to 1.80 times as accurate as N planned ones, so the issue's "3N" is not claimed."""
    for row in table:
        assert worth(row) > 1.05, row  # measured 1.12 (KR 6 tracker, N = 60) to 2.16 (ball-bar, N = 60)
        assert row["D"] > 1.3 * row["random3"], row  # measured D / random 3N 1.45 to 1.80
