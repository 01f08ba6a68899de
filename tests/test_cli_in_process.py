"""armcal_cli (the command line run inside the test's process, tests/conftest.py) gives what `python -m armcal` gives
a pipe: the same exit code, stdout and stderr, for help, a user's mistake, a usage error and a command's output."""

import subprocess
import time

import pytest
from conftest import SPECS, CommandTimeout, armcal_cli, armcal_process


@pytest.mark.parametrize(
    "arguments",
    [
        ("--help",),
        ("montecarlo", "--help"),
        ("validate", "no-such-spec.yaml"),
        ("run", "--no-such-option"),
        ("fk", SPECS / "puma560_dh.yaml", "--q", "0,10,20,30,40,50"),
        ("validate", SPECS / "ur10.yaml", "specs"),
    ],
)
def test_in_process_and_own_process_give_the_same(arguments):
    inside, own = armcal_cli(*arguments), armcal_process(*arguments)
    assert (inside.returncode, inside.stdout, inside.stderr) == (own.returncode, own.stdout, own.stderr)


def test_what_a_child_process_writes_reaches_stderr(monkeypatch):
    import armcal.commands.terminal

    def summary_and_a_child(loaded):
        subprocess.run(["sh", "-c", "echo from-a-child >&2"], check=True)
        return "summary"

    monkeypatch.setattr(armcal.commands.terminal, "spec_summary", summary_and_a_child)
    shown = armcal_cli("validate", SPECS / "ur10.yaml")
    assert shown.returncode == 0 and "summary" in shown.stdout and "from-a-child" in shown.stderr


def test_a_command_that_hangs_fails_at_its_timeout(monkeypatch):
    import armcal.commands.terminal

    monkeypatch.setattr(armcal.commands.terminal, "spec_summary", lambda loaded: time.sleep(60))
    with pytest.raises(CommandTimeout):  # the summary would return after 60 s, with exit 0
        armcal_cli("validate", SPECS / "ur10.yaml", timeout=1)
