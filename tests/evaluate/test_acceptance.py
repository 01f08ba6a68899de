"""Acceptance that holds out: candidates judged on the calibration data (the validation set never chooses), an
improvement larger than its own sampling noise, unexplained whenever the final fit fails the noise check, and the
per-pose 3D figures users compare, recomputed from residuals.csv."""

import csv
from dataclasses import replace

import numpy as np
import pytest
from conftest import copy_example
from test_diagnosis import TRACKER, _data, _spec

from armcal.diagnose.loop import Context, contiguous_folds, holds_out, run_diagnosis
from armcal.devices.registry import vocabulary
from armcal.effects.library import EffectSpec
from armcal.effects.types.joint_coupling import coupling
from armcal.effects.measurement import EffectSet
from armcal.commands.run import run
from armcal.spec.sections import Diagnose, Fit

TWO_EFFECTS = "    - {type: gear_harmonic, joint: 2, order: 1, sin: 0.004 deg, cos: 0.002 deg}\n    - {type: backlash, joint: 3, half_width: 0.004 deg}\n"


def test_the_paired_test_against_its_normal_approximation():
    """Mean change of -2.5 standard errors holds out, -1.5 does not; a rise never does."""
    rng = np.random.default_rng(0)
    before = rng.chisquare(3, 400)
    noise = rng.normal(size=400)
    noise = (noise - noise.mean()) / noise.std(ddof=1)  # exactly zero mean, unit sample std
    for shift, expected in ((-2.5, True), (-1.5, False), (+3.0, False)):
        after = before + noise + shift / np.sqrt(400)
        held, z = holds_out(before, after)
        assert held is expected and z == pytest.approx(shift, abs=1e-9)


def test_the_validation_set_does_not_choose(tmp_path):
    """With k-fold (the default), validation readings a metre off change nothing the diagnosis decides."""
    loaded = _spec(tmp_path, TRACKER, f"simulate:\n  seed: 9\n  effects:\n{TWO_EFFECTS}")
    kinematics, device, calibration, validation = _data(loaded, tmp_path)
    spoiled = replace(validation, readings={k: v + 1000.0 for k, v in validation.readings.items()})
    kept = run_diagnosis(kinematics, device, calibration, validation, [], Fit(), Diagnose())
    other = run_diagnosis(kinematics, device, calibration, spoiled, [], Fit(), Diagnose())
    assert [e.id for e in kept.added] == [e.id for e in other.added] and kept.chosen_on == "kfold"
    assert {(e.type, e.joint) for e in kept.added} == {("gear_harmonic", 2), ("backlash", 3)}
    np.testing.assert_array_equal(kept.fit.theta, other.fit.theta)


def test_a_joint_effect_is_cross_validated_over_contiguous_ranges_of_its_joint(tmp_path):
    """Folds along joint j hold out contiguous ranges of q_j (every pose of fold k below every pose of fold k+1),
    equal in size to one pose; a coupling follows its driving joint, an instrument's effect the interleaved folds."""
    loaded = _spec(tmp_path, TRACKER, "simulate: {seed: 9}\n")
    kinematics, device, calibration, validation = _data(loaded, tmp_path)
    context = Context(kinematics, device, calibration, validation, EffectSet(), Fit(), Diagnose(), False)
    poses = np.unique(np.round(calibration.q, 9), axis=0)
    for joint in range(1, kinematics.dof + 1):
        fold = context.folds[joint]
        assert np.ptp(np.bincount(fold)) <= 1
        ranges = [(poses[fold == k, joint - 1].min(), poses[fold == k, joint - 1].max()) for k in range(5)]
        assert all(high < low for (_, high), (low, _) in zip(ranges, ranges[1:]))
    circle_point = np.r_[np.zeros(75), np.linspace(-1.0, 1.0, 15)]  # a joint still in 75 of 90 poses, then its circle
    np.testing.assert_array_equal(contiguous_folds(circle_point, 5), np.arange(90) % 5)
    assert EffectSpec(vocabulary()["gear_harmonic"], joint=2, order=3).followed_joint == 2
    assert coupling(3, 2).followed_joint == 2
    assert EffectSpec(vocabulary()["sensor_scale"]).followed_joint is None


def test_a_round_limit_with_residuals_left_is_unexplained_and_partly_explained(tmp_path):
    loaded = _spec(tmp_path, TRACKER, f"simulate:\n  seed: 9\n  effects:\n{TWO_EFFECTS}")
    kinematics, device, calibration, validation = _data(loaded, tmp_path)
    diagnosis = run_diagnosis(kinematics, device, calibration, validation, [], Fit(), Diagnose(max_rounds=1))
    assert len(diagnosis.added) == 1 and diagnosis.unexplained  # the second effect is still in the residuals
    complete = run_diagnosis(kinematics, device, calibration, validation, [], Fit(), Diagnose())
    assert not complete.unexplained and not any(r.partly_explained for r in complete.rounds)


def test_3d_statistics_and_residuals_csv_agree_with_an_independent_recomputation(tmp_path):
    copy_example("hidden_harmonic", tmp_path)
    results = run(tmp_path / "spec.yaml", tmp_path / "out", pdf=False).results
    with open(tmp_path / "out" / "residuals.csv") as stream:
        rows = list(csv.DictReader(stream))
    assert {r["data"] for r in rows} == {"calibration", "validation"}
    for name in ("calibration", "validation"):
        for moment in ("before", "after"):
            pose = {}
            for r in rows:
                if r["data"] == name:
                    pose.setdefault(r["line"], []).append(float(r[f"residual_{moment}"]) * 10.0)  # cm -> mm
            distances = np.sqrt([sum(v * v for v in values) for values in pose.values()])
            stats = getattr(getattr(results.residuals_3d, name), moment)
            assert stats.n == len(distances)
            assert stats.mean == pytest.approx(distances.mean(), rel=1e-6)
            assert stats.rms == pytest.approx(np.sqrt(np.mean(distances**2)), rel=1e-6)
            assert stats.max == pytest.approx(distances.max(), rel=1e-6)
        per_coordinate = getattr(results.residuals, name).after.rms
        assert per_coordinate == pytest.approx(np.sqrt(np.mean([float(r["residual_after"]) ** 2 for r in rows if r["data"] == name])) * 10, rel=1e-6)
