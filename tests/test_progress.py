"""A stage that takes longer than a second is said while it runs, and its time when it ends; a short one says nothing
(issue 18: a terminal line whenever something takes longer than a second)."""

import time

from armcal.progress import LONG, stage


def test_a_long_stage_is_said_while_it_runs_and_timed_when_it_ends(capsys):
    with stage("fitting the moon"):
        time.sleep(LONG + 0.3)
        assert capsys.readouterr().err == "armcal: fitting the moon ...\n"  # said before the stage ended
    took = capsys.readouterr().err
    assert took.startswith("armcal: fitting the moon: ") and took.endswith(" s\n")
    assert float(took.split(": ")[-1][:-3]) >= LONG + 0.3 - 0.05


def test_a_short_stage_says_nothing(capsys):
    with stage("blinking"):
        time.sleep(0.05)
    time.sleep(LONG + 0.1)  # the timer of the short stage was cancelled: nothing comes later either
    assert capsys.readouterr().err == ""


def test_a_failing_stage_is_still_timed_and_raises(capsys):
    try:
        with stage("falling"):
            time.sleep(LONG + 0.1)
            raise ValueError("down")
    except ValueError as error:
        assert str(error) == "down"
    assert "armcal: falling: " in capsys.readouterr().err
