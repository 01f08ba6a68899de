"""docs/tutorials/trailblazer.py on the real Trailblazer data (../shared/data/hilti-trailblazer; skipped when absent).

The held-out file is predicted from the nominal robot too, and that figure has an oracle that does not come from
armcal: yourdfpy's forward kinematics of the URDF itself (its mimic joints moved by yourdfpy), the frame of the held-out
file fitted to its stationing points by a rigid registration (Kabsch, tests/rigid_fit.py), the evaluation points
predicted with it. The calibrated run must then exit 0, converge, keep every correlation within [-1, 1], list no
implausible value (every robot length within robot.tolerance, 10 mm, of the drawing) and predict better than the
nominal robot.
"""

import importlib.util
import json

import numpy as np
import pytest
from conftest import ROOT, SHARED_DATA
from rigid_fit import kabsch

import urdf_oracle

SOURCE = SHARED_DATA / "hilti-trailblazer"
pytestmark = pytest.mark.skipif(not SOURCE.exists(), reason="../shared/data/hilti-trailblazer is not beside this checkout")
HELD_OUT = "pallet"


def _tutorial():
    spec = importlib.util.spec_from_file_location("trailblazer", ROOT / "docs" / "tutorials" / "trailblazer.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    tutorial = _tutorial()
    return tutorial, tutorial.study([HELD_OUT], tmp_path_factory.mktemp("trailblazer"))[HELD_OUT]


def test_the_calibration_is_plausible_and_predicts_better_than_the_drawing(study):
    _, figures = study
    assert figures["status"] == "converged"
    assert figures["implausible"] == []
    assert figures["largest_correlation"] <= 1.0
    assert figures["calibrated_rms"] < figures["nominal_rms"]
    assert figures["calibrated_rms_3d"] < figures["nominal_rms_3d"]


def test_the_nominal_prediction_matches_the_urdf_registered_on_the_stationing_points(study):
    tutorial, figures = study
    rows = tutorial.readings(SOURCE / "datasets" / f"{HELD_OUT}.yaml")
    model = urdf_oracle.load(SOURCE / "trailblazer.urdf")
    assert tuple(model.actuated_joint_names) == tutorial.JOINTS  # the data's order: yourdfpy moves the mimics
    Q = np.array([r["q"] for r in rows])
    prism = urdf_oracle.poses(model, Q, ["prism"], "base_link")["prism"][:, :3, 3]  # mm
    measured = np.array([r["prism"] for r in rows]) * 1000.0
    register = np.array([r["register"] for r in rows])
    T = kabsch(prism[register], measured[register])
    error = measured[~register] - (prism[~register] @ T[:3, :3].T + T[:3, 3])
    assert figures["held_out_points"] == int((~register).sum())
    assert figures["nominal_rms"] == pytest.approx(float(np.sqrt(np.mean(error**2))), rel=1e-6)
    assert figures["nominal_rms_3d"] == pytest.approx(float(np.sqrt(np.mean(np.sum(error**2, axis=1)))), rel=1e-6)
