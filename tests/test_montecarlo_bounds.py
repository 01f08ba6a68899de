"""Counts a study or a fleet is given are bounded before any work (hostile report 30, items 7 and 8): --workers
of montecarlo and batch from 1 to 256; a --sweep of at most 20 values, each variant validated as a spec is (its
caps, e.g. points_per_joint at most 200000, which model_copy skipped). Exit 1, one message, no traceback, nothing
written, in seconds."""

import time

import pytest
from conftest import HANG, ROOT, armcal_process

from armcal.support.errors import UserError
from armcal.evaluate.sweeps import MAX_VALUES, parse_sweep, variant
from armcal.spec import load_spec
from armcal.commands.workers import MAX_PROCESSES

SONIC = ROOT / "examples" / "puma560_sonic" / "spec.yaml"  # Stone's circle-point procedure: every sweep applies


def _refused_at_once(*args, out, phrase: str) -> None:
    started = time.monotonic()
    done = armcal_process(*args, "--out", out, timeout=120)
    assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr
    assert done.stderr.strip().startswith("error: ") and phrase in done.stderr, done.stderr
    assert not out.exists(), "nothing is written"
    assert time.monotonic() - started < HANG


@pytest.mark.parametrize("workers", [0, -3, MAX_PROCESSES + 1, 10**12])
def test_workers_are_bounded_for_every_command(tmp_path, workers):
    phrase = f"--workers {workers}: give a number of local worker processes from 1 to {MAX_PROCESSES}"
    _refused_at_once("montecarlo", SONIC, "--runs", "3", "--workers", workers, out=tmp_path / "study", phrase=phrase)
    _refused_at_once("batch", SONIC, "--no-pdf", "--workers", workers, out=tmp_path / "fleet", phrase=phrase)


def test_a_sweep_is_bounded_in_values_and_each_variant_is_a_valid_spec(tmp_path):
    angles = ",".join(f"{0.01 * k:g}" for k in range(1, MAX_VALUES + 2))  # 21 distinct encoder error sigmas
    _refused_at_once("montecarlo", SONIC, "--runs", "2", "--sweep", f"sigma_e={angles}", out=tmp_path / "a",
                     phrase=f"--sweep sigma_e: {MAX_VALUES + 1} values, at most {MAX_VALUES}")
    _refused_at_once("montecarlo", SONIC, "--runs", "2", "--sweep", "points_per_joint=3,250000", out=tmp_path / "b",
                     phrase="--sweep points_per_joint: 250000 makes no valid spec (procedure.points_per_joint: Input "
                            "should be less than or equal to 200000)")


def test_the_variants_of_a_valid_sweep_are_the_spec_with_one_value_changed():
    """Validating a variant again changes nothing else: internal values stay internal (no second unit conversion)."""
    spec = load_spec(SONIC).spec
    for text, part, field in (("sigma_e=0.1,0.3", "simulate", "sigma_e"), ("noise_factor=1,2", "simulate", "noise_factor"),
                              ("points_per_joint=20,40", "procedure", "points_per_joint")):
        sweep = parse_sweep(text, spec)
        for value in sweep.values:
            changed = variant(spec, sweep.variable, value)
            section = getattr(spec, part)
            assert getattr(changed, part) == section.model_copy(update={field: type(getattr(section, field))(value)})
            assert changed.robot == spec.robot and changed.device == spec.device
    with pytest.raises(UserError, match="at most 20"):
        parse_sweep("noise_factor=" + ",".join(str(k) for k in range(1, 5001)), spec)
