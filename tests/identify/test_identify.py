"""Identification against known truth, Goswami's parameter counts, and honest uncertainties."""

import numpy as np
import pytest
import scipy.stats
from conftest import ROOT, SPECS
from identify_helpers import measure, restricted, setup, truth

from armcal.identify.fit import fit
from armcal.identify.identifiability import analyse
from armcal.identify.problem import build_problem, rows_within
from armcal.spec import load_spec
from armcal.spec.sections import Fit

FEWER_SHELL_POINTS = [("  longitudes: 23", "  longitudes: 10"), ("  longitudes: 28", "  longitudes: 10")]
CASES = {
    "sonic": ("puma560_dh.yaml", []),
    "ballbar": ("goswami_puma560.yaml", FEWER_SHELL_POINTS),
    "theodolite": ("puma560_theodolite.yaml", []),
    "tracker": ("puma560_six.yaml", []),
}


@pytest.fixture(scope="module", params=sorted(CASES))
def case(request):
    name, changes = CASES[request.param]
    return setup(SPECS / name, changes)


def test_identified_parameters_match_the_truth(case):
    """Errors consistent with the covariance (family-wise); chi^2 consistent with the noise; the held-out mean square
    within what the noise and the parameters' uncertainty explain."""
    rng = np.random.default_rng(11)
    theta_true = truth(case, rng)
    calibration = measure(case.kinematics, case.device, case.plans[0], theta_true, rng)
    validation = measure(case.kinematics, case.device, case.plans[1], theta_true, rng)
    problem = restricted(build_problem(case.kinematics, case.device, calibration), case.base)
    result = fit(problem, Fit())
    assert result.solver.converged
    error = result.theta[result.base] - theta_true[result.base]
    z = error / result.uncertainty.std
    # Family-wise over the p parameters: each |z| below the two-sided 0.1 % Bonferroni bound, and the
    # whole error vector consistent with chi2(p) under the estimated covariance (a single |z| of 3 among
    # 36 is expected one fit in ten, so a per-parameter 3-sigma bound is not a test of the fit).
    bound = scipy.stats.norm.isf(0.001 / (2 * len(z)))
    assert np.all(np.abs(z) < bound), dict(zip(result.identifiability.base, np.round(z, 2)))
    distance = float(error @ np.linalg.solve(result.uncertainty.covariance, error))
    assert scipy.stats.chi2.sf(distance, len(z)) > 0.001
    assert 0.001 < result.uncertainty.p_value < 0.999
    r, J = build_problem(case.kinematics, case.device, validation).evaluate(result.theta)
    assert np.mean(r**2) < validation_mean_square_quantile(J[:, result.base], result.uncertainty.covariance, 0.999)


def validation_mean_square_quantile(J: np.ndarray, covariance: np.ndarray, level: float) -> float:
    """Quantile of the held-out mean square (residuals in noise sigmas) of a fit whose errors follow ``covariance``:
    noise (chi2 on M) plus the prediction error d^T J^T J d of d ~ N(0, covariance), by simulation."""
    M = len(J)
    L = np.linalg.cholesky(covariance + 1e-300 * np.eye(len(covariance)))
    weights = np.linalg.eigvalsh(L.T @ J.T @ J @ L)
    rng = np.random.default_rng(0)
    draws = (rng.normal(size=(20000, len(weights))) ** 2 @ weights + rng.chisquare(M, 20000)) / M
    return float(np.quantile(draws, level))


def _count(setup_, pairings=None, robot_only=True):
    """Rank of the ball-bar Jacobian over the 54 six-parameter robot parameters (Goswami's model)."""
    planned = setup_.plans[0]
    keep = np.array([pairings is None or (k[0], k[1]) in pairings for k in planned.keys])
    from armcal.procedures.plan import Plan

    subset = Plan(tuple(k for k, ok in zip(planned.keys, keep) if ok), planned.q[keep])
    problem = build_problem(setup_.kinematics, setup_.device, measure(setup_.kinematics, setup_.device, subset, None, None))
    free = np.array([n.split(".")[0].startswith(("L", "j")) for n in problem.parameters.names])
    assert free.sum() == 54
    _, J = problem.evaluate(problem.parameters.nominal)
    return analyse(J, problem.parameters, free).rank


def test_goswami_counts():
    """N = 5 n_r + 6 = 36 with all nine pairings, or any six using every sphere and pivot; 33 with one sphere."""
    ballbar = setup(SPECS / "goswami_puma560.yaml", FEWER_SHELL_POINTS)
    assert _count(ballbar) == 36
    six = {("chuck1", "sphere1"), ("chuck1", "sphere2"), ("chuck2", "sphere2"), ("chuck2", "sphere3"), ("chuck3", "sphere3"), ("chuck3", "sphere1")}
    assert _count(ballbar, six) == 36
    one_sphere = {("chuck1", "sphere1"), ("chuck2", "sphere1"), ("chuck3", "sphere1")}
    assert _count(ballbar, one_sphere) == 33


def test_theodolite_without_scale_bar_cannot_identify_scale():
    bar = "  scale_bar:\n    length: 1000.0\n    noise: 0.01\n    end1: {x: 1000.0, y: 1500.0, z: -1000.0}\n    end2: {x: 2000.0, y: 1500.0, z: -1000.0}\n"
    for changes, expected in (([], ()), ([(bar, "")], ("scale",))):
        s = setup(SPECS / "puma560_theodolite.yaml", changes)
        problem = build_problem(s.kinematics, s.device, measure(s.kinematics, s.device, s.plans[0], None, None))
        _, J = problem.evaluate(problem.parameters.nominal)
        assert analyse(J, problem.parameters, problem.parameters.free).unidentifiable == expected


def test_uncertainties_cover_the_truth_95_percent_of_the_time():
    """Over 100 simulated campaigns, the 95 % intervals hold the true parameters 93-97 % of the time."""
    s = setup(SPECS / "puma560_six.yaml", [("  count: 200\n", "  count: 120\n")])
    inside = []
    for seed in range(100):
        rng = np.random.default_rng(1000 + seed)
        theta_true = truth(s, rng)
        data = measure(s.kinematics, s.device, s.plans[0], theta_true, rng)
        result = fit(restricted(build_problem(s.kinematics, s.device, data), s.base), Fit())
        z = (result.theta[result.base] - theta_true[result.base]) / result.uncertainty.std
        inside.append(np.abs(z) <= 1.959964)
    coverage = np.mean(np.concatenate(inside))
    assert 0.93 <= coverage <= 0.97, coverage


def test_robust_loss_lists_gross_errors_and_keeps_the_fit():
    """5 % of readings off by 50 sigma: the linear fit is pulled away, Huber's is not and names them."""
    s = setup(SPECS / "puma560_six.yaml")
    rng = np.random.default_rng(21)
    theta_true = truth(s, rng)
    data = measure(s.kinematics, s.device, s.plans[0], theta_true, rng)
    clean = fit(restricted(build_problem(s.kinematics, s.device, data), s.base), Fit())
    bad = rng.choice(len(data), size=len(data) // 20, replace=False)
    data.readings["x"][bad] += 50 * s.device.spec.noise * rng.choice([-1, 1], size=len(bad))
    problem = restricted(build_problem(s.kinematics, s.device, data), s.base)
    plain = fit(problem, Fit())
    robust = fit(problem, Fit(loss="huber"))
    error = lambda r: np.abs((r.theta - theta_true)[clean.base] / clean.uncertainty.std).max()  # noqa: E731
    assert error(plain) > 3.0 and error(robust) < 3.0
    flagged = set(problem.residuals.sample[robust.outliers])
    assert set(bad) <= flagged and len(flagged) < 2 * len(bad)


@pytest.mark.parametrize("loss", ["linear", "huber"])
def test_a_fold_fit_started_from_the_full_fits_rows_is_the_fit_that_evaluates_its_start(loss):
    """rows_within finds a fold's readings among the full problem's: started from those rows of the full fit's (r, J)
    (FitResult.at_solution), the fold's fit is the one that evaluates them, bit for bit."""
    s = setup(SPECS / "puma560_six.yaml")
    rng = np.random.default_rng(5)
    data = measure(s.kinematics, s.device, s.plans[0], truth(s, rng), rng)
    full = fit(build_problem(s.kinematics, s.device, data), Fit(loss=loss))
    samples = np.flatnonzero(np.arange(len(data)) % 5 != 2)
    fold = build_problem(s.kinematics, s.device, data.subset(samples))
    rows = rows_within(fold, samples, build_problem(s.kinematics, s.device, data))
    r, J = full.at_solution
    started = fit(fold, Fit(loss=loss), full.theta, full.identifiability, (r[rows], np.asfortranarray(J[rows])))
    evaluated = fit(fold, Fit(loss=loss), full.theta, full.identifiability)
    assert started.solver.iterations > 0 and np.array_equal(started.theta, evaluated.theta)


def test_compiled_functions_are_cached_and_equal_the_interpreted_ones(tmp_path, monkeypatch):
    """The compiled library is built once per setup, reused by later problems, and gives the interpreter's numbers bit
    for bit (it is built without fused multiply-adds)."""
    monkeypatch.setenv("ARMCAL_CACHE", str(tmp_path))
    monkeypatch.setenv("ARMCAL_COMPILE", "now")  # a test of the compiled library, whatever mode the suite runs in
    s = setup(SPECS / "puma560_theodolite.yaml")
    data = measure(s.kinematics, s.device, s.plans[0], None, None)
    first = build_problem(s.kinematics, s.device, data)
    libraries = list(tmp_path.glob("*.so"))
    assert len(libraries) == 1
    built = libraries[0].stat().st_mtime_ns
    second = build_problem(s.kinematics, s.device, data)
    assert libraries[0].stat().st_mtime_ns == built  # loaded, not rebuilt
    monkeypatch.setenv("CC", "no-such-compiler")
    monkeypatch.setenv("PATH", "")
    interpreted = build_problem(s.kinematics, s.device, data)
    theta = first.parameters.nominal + 1e-3
    sigma, measured = first.residuals.sigma, first.residuals.measured
    for other in (second, interpreted):
        r1, J1 = first.evaluate(theta)
        r2, J2 = other.evaluate(theta)
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(J1, J2)


def test_the_tracker_start_keeps_the_base_components_a_spec_holds(tmp_path):
    """The registered start moves the free tracker-to-base components only (held ones keep their values)."""
    from armcal.dataio.reader import read_measurements
    from armcal.devices import device_model
    from armcal.identify.problem import build_problem
    from armcal.identify.starting_values import starting_values
    from armcal.kinematics.compiler import compile_robot

    folder = ROOT / "examples" / "hidden_harmonic"
    text = (folder / "spec.yaml").read_text().replace("ry: 0.0, rx: 0.0}", "ry: {value: 0.01, vary: false}, rx: {value: 0.0, vary: false}}")
    (tmp_path / "spec.yaml").write_text(text)
    spec = load_spec(tmp_path / "spec.yaml").spec
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    data = read_measurements(folder / "calibration.csv", spec)
    problem = build_problem(kinematics, device, data)
    theta = starting_values(problem, kinematics, device, data)
    value = dict(zip(problem.parameters.names, theta))
    assert value["robot_base.ry"] == pytest.approx(np.radians(0.01)) and value["robot_base.rx"] == 0.0
    assert value["robot_base.x"] != 300.0  # the free components are registered from the data
