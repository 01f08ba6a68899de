"""Shared fixtures: paths of the shipped specs and compiled reference robots.

The tests mirror armcal's tree (tests/identify/ tests armcal/identify/...); the tests of the whole
tool (CLI, pipeline, documentation, safety) stay here. A test may take its cases from a test of
another folder by module name: every folder is on the import path.
"""

import ctypes
import logging
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import warnings
from contextlib import contextmanager
from pathlib import Path

import armcal  # noqa: F401 - before numpy, as the CLI: its one-thread BLAS settings hold here as in the workers it spawns
import numpy as np
import pytest

from typer.testing import CliRunner

from armcal.cli import app
from armcal.kinematics.compiler import compile_robot
from armcal.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent
TESTS = ROOT / "tests"
SPECS = ROOT / "specs"
sys.path.extend(str(folder) for folder in sorted(TESTS.iterdir()) if folder.is_dir() and any(folder.glob("test_*.py")))
SHARED_DATA = ROOT.parent / "shared" / "data"


EXAMPLE_DATA = ("spec.yaml", "calibration.csv", "validation.csv")
HANG = 60.0  # s: a wait that only a hang reaches, however loaded the machine (no test has a shorter wall-clock limit)


def copy_example(name: str, folder: Path, files: tuple[str, ...] = EXAMPLE_DATA) -> Path:
    """The files of examples/<name> among ``files`` copied into ``folder`` (tests never write into the repository)."""
    for file in files:
        if (ROOT / "examples" / name / file).exists():
            shutil.copy(ROOT / "examples" / name / file, Path(folder) / file)
    return Path(folder)


def armcal_process(*args, cwd: Path = ROOT, timeout: float = 300, env: dict | None = None) -> subprocess.CompletedProcess:
    """`python -m armcal ARGS` in a process of its own from ``cwd``, output captured: for what only a process
    shows (its own environment, a hang cut by ``timeout``, a first import)."""
    return subprocess.run([sys.executable, "-m", "armcal", *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=timeout, env=env)


# Python's own filters for a script (python -W default shows the rest): what `python -m armcal` prints
IGNORED_WARNINGS = (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning)


class CommandTimeout(BaseException):
    """A command ran past its time limit: a hang (BaseException: no handler of the command's catches it)."""


def armcal_cli(*args, cwd: Path = ROOT, timeout: float = 300) -> subprocess.CompletedProcess:
    """`armcal ARGS` as `python -m armcal ARGS` runs it from ``cwd`` (the project's folder), in this process: exit code,
    stdout and stderr as a pipe gets them (Python's warnings and log records, and what C code and child processes
    write to the descriptors, included; help wrapped for a pipe); an exception the CLI lets escape fails the test,
    and so does a command running past ``timeout`` seconds. The working folder and the environment are restored
    after (a command may set variables). ARMCAL_TEST_PROCESS=1 runs each in a process of its own instead
    (docs/development.md)."""
    if os.environ.get("ARMCAL_TEST_PROCESS"):
        return armcal_process(*args, cwd=cwd, timeout=timeout)
    folder, environment = os.getcwd(), dict(os.environ)
    records = _CurrentStderr(logging.WARNING)  # Python's last-resort handler, which pytest's own handlers displace
    os.chdir(cwd)
    logging.getLogger().addHandler(records)
    try:
        with _descriptors() as written, _time_limit(timeout), warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("default")
            for category in IGNORED_WARNINGS:
                warnings.simplefilter("ignore", category)
            width = max(min(shutil.get_terminal_size().columns, 80) - 2, 50)  # click's help width on a pipe
            result = CliRunner().invoke(app, [str(arg) for arg in args], catch_exceptions=False, prog_name="armcal", terminal_width=width)
    finally:
        logging.getLogger().removeHandler(records)
        os.chdir(folder)
        os.environ.clear()
        os.environ.update(environment)
    shown = "".join(warnings.formatwarning(w.message, w.category, w.filename, w.lineno) for w in caught)
    return subprocess.CompletedProcess(["armcal", *map(str, args)], result.exit_code, result.stdout + written["out"], result.stderr + shown + written["err"])


class _CurrentStderr(logging.StreamHandler):
    """Log records written to whatever sys.stderr is when they come (the runner's, during a command)."""

    def emit(self, record: logging.LogRecord) -> None:
        self.setStream(sys.stderr)
        super().emit(record)


@contextmanager
def _descriptors():
    """What reaches file descriptors 1 and 2 meanwhile (C code, child processes), as text: {"out": ..., "err": ...}."""
    written, files, saved = {}, [tempfile.TemporaryFile(), tempfile.TemporaryFile()], [os.dup(1), os.dup(2)]
    sys.stdout.flush(), sys.stderr.flush()
    for descriptor, file in zip((1, 2), files):
        os.dup2(file.fileno(), descriptor)
    try:
        yield written
    finally:
        ctypes.CDLL(None).fflush(None)  # C's buffered output, which a process flushes at its exit
        for descriptor, file, name in zip((1, 2), files, ("out", "err")):
            os.dup2(saved[descriptor - 1], descriptor)
            os.close(saved[descriptor - 1])
            file.seek(0)
            written[name] = file.read().decode(errors="replace")
            file.close()


@contextmanager
def _time_limit(seconds: float):
    """Raise CommandTimeout in this (the main) thread once ``seconds`` have passed."""

    def expire(*_):
        raise CommandTimeout(f"the command ran longer than {seconds} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def shipped_specs() -> list[Path]:
    return sorted([*SPECS.glob("*.yaml"), *(ROOT / "examples").glob("*/spec.yaml")])


@pytest.fixture(scope="session")
def puma_models():
    """The PUMA 560 of Table 6-2 compiled in the three conventions."""
    return {name: compile_robot(load_spec(SPECS / f"{name}.yaml").spec.robot.chain()) for name in ("puma560_dh", "puma560_smodel", "puma560_six")}


def random_configurations(model, count: int, seed: int = 0) -> np.ndarray:
    """Joint configurations uniformly within the joint limits."""
    return np.random.default_rng(seed).uniform(model.limits[:, 0], model.limits[:, 1], (count, model.dof))
