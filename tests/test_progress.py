"""A stage that takes longer than a second is said while it runs, and its time when it ends; a short one says nothing
(issue 18: a terminal line whenever something takes longer than a second)."""

import time

import pytest

from armcal.support.progress import LONG, stage


HANG = 60.0  # s: only a stage that never says anything waits this long (a loaded machine is slow, not this slow)


def test_a_long_stage_is_said_while_it_runs_and_timed_when_it_ends(capsys):
    with stage("fitting the moon"):
        time.sleep(LONG)
        said, waited = "", 0.0
        while not said and waited < HANG:  # said before the stage ended, however late the timer's thread runs
            time.sleep(0.05)
            waited += 0.05
            said = capsys.readouterr().err
        assert said == "armcal: fitting the moon ...\n"
    took = capsys.readouterr().err
    assert took.startswith("armcal: fitting the moon: ") and took.endswith(" s\n")
    assert float(took.split(": ")[-1][:-3]) >= LONG - 0.05


def test_a_short_stage_says_nothing(capsys):
    started = time.perf_counter()
    with stage("blinking"):
        pass
    took = time.perf_counter() - started
    time.sleep(LONG + 0.1)  # the timer of the short stage was cancelled: nothing comes later either
    if took >= LONG:
        pytest.skip(f"the machine stalled {took:.1f} s inside an empty stage: it was not short")
    assert capsys.readouterr().err == ""


def test_a_failing_stage_is_still_timed_and_raises(capsys):
    try:
        with stage("falling"):
            time.sleep(LONG + 0.1)
            raise ValueError("down")
    except ValueError as error:
        assert str(error) == "down"
    assert "armcal: falling: " in capsys.readouterr().err
