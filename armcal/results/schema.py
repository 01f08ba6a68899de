"""results.json: the contract of docs/architecture.md as frozen models (no CasADi here)."""

from __future__ import annotations

import math
import re
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, field_validator, model_serializer, model_validator

TASK_TITLES = {"grid_task": "Grid-touching task (Stone 7.2.1)", "iso9283": "ISO 9283 positional accuracy"}  # evaluation's tasks


JOINT_PARAMETER = re.compile(r"^j(\d+)\.(theta|d|a|alpha|beta|theta0|k)$")  # a default-named joint's parameter: j3.theta, j3.k
SIX_PARAMETER_LINK = re.compile(r"^L(\d+)\.(\w+)$")  # a six_parameter link's parameter: L1..L(n+1), Goswami (3)
LINK_FIELDS = {"x", "y", "z", "alpha", "beta", "gamma"}


class _Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class _AsWritten(_Frozen):
    """A block the run writes as it goes: only the keys it gave, in the order it gave them (an older armcal's results
    lack some; the evaluation's tasks stand in the spec's order)."""

    _keys: tuple[str, ...] = PrivateAttr(default=())

    @model_validator(mode="wrap")
    @classmethod
    def _remember_keys(cls, data, handler):
        made = handler(data)
        if isinstance(data, dict):
            made._keys = tuple(data)
        return made

    @model_serializer(mode="wrap")
    def _given_keys(self, handler) -> dict:
        out = handler(self)
        return {key: out[key] for key in self._keys}


class GitInfo(_Frozen):
    commit: str
    dirty: bool


class Placeholder(_Frozen):
    """A stand-in armcal new or import-urdf wrote, still unchanged in the spec (spec/placeholders.py)."""

    field: str  # the spec's field, e.g. "robot.serial"
    stands_for: str  # what it takes the place of, e.g. "the robot's serial number"


class SpecInfo(_Frozen):
    path: str
    sha256: str
    git: GitInfo | None
    placeholders: list[Placeholder] = []  # the values the spec does not give: armcal's stand-ins, unchanged


class RobotInfo(_Frozen):
    name: str
    serial: str
    convention: str
    dof: int


class DeviceInfo(_Frozen):
    type: str
    unit: str  # unit of the residual statistics
    noise_sigma: float | None = None  # the noise model's sigma of one reading (RMS), in unit; absent in older results


class FixedParameter(_Frozen):
    name: str
    reason: str


class FlatDirection(_Frozen):
    """A direction of the base parameters the data barely see, at the solution."""

    ratio: float  # its singular value over the largest, column-scaled Jacobian
    parameters: list[tuple[str, float]]  # the parameters it moves most, with their components


class ParallelAxesInfo(_Frozen):
    """Consecutive parallel axes of a dh chain and how they are modelled (kinematics/parallel_axes.py)."""

    joints: tuple[int, int]
    added: str | None  # Hayati's beta added by armcal
    held: str | None  # the d held instead


class IdentifiabilityInfo(_Frozen):
    n_parameters: int
    rank: int
    free: list[str]
    fixed: list[FixedParameter]
    condition_number: float  # column-scaled base Jacobian at the solution
    observability_o1: float
    unidentifiable: list[str]
    design_point: str = "nominal"  # where the base set was decided
    flat_directions: list[FlatDirection] = []
    parallel_axes: list[ParallelAxesInfo] = []
    breakdown: dict[str, dict[str, int]] = {}  # robot / instrument / registration / effects x identified / not_identifiable / held_by_spec (results/breakdown.py)


class ParameterResult(_Frozen):
    name: str
    unit: str
    nominal: Annotated[float, Field(allow_inf_nan=False)]
    value: Annotated[float, Field(allow_inf_nan=False)]
    std: Annotated[float, Field(ge=0.0, allow_inf_nan=False)] | None  # null: not identified
    free: bool


class ImplausibleValue(_Frozen):
    """An identified robot value farther from its nominal value than the tolerance of its kind (spec units)."""

    name: str
    unit: str
    nominal: float
    value: float
    deviation: float  # value - nominal (angles the short way round)
    tolerance: float
    std: float | None
    why: Literal["nominal", "undetermined"]  # many stds from nominal (the data put it there), or poorly determined


class Plausibility(_Frozen):
    """Identified robot values against their nominal values (results/plausibility.py)."""

    length: float  # tolerance, in length_unit
    length_unit: str
    angle: float  # tolerance, in angle_unit
    angle_unit: str
    scale: float | None = None  # tolerance of encoder scales k, a ratio; null in results of an older armcal
    from_spec: bool  # false: the defaults (10 mm, 2 deg, 0.01), the spec gave no robot.tolerance
    implausible: list[ImplausibleValue]


class Stats(_Frozen):
    n: int
    rms: float
    mean: float
    std: float
    max_abs: float


class BeforeAfter(_Frozen):
    before: Stats
    after: Stats


class Residuals(_Frozen):
    calibration: BeforeAfter
    validation: BeforeAfter | None


class Stats3D(_Frozen):
    """Per-pose 3D distance errors |measured - predicted| of a point-measuring instrument."""

    n: int
    mean: float
    rms: float
    max: float


class BeforeAfter3D(_Frozen):
    before: Stats3D
    after: Stats3D


class Residuals3D(_Frozen):
    unit: str
    calibration: BeforeAfter3D
    validation: BeforeAfter3D | None


class ImprovementFactor(_Frozen):
    calibration: float
    validation: float | None


class EffectParameter(_Frozen):
    name: str
    value: float | None
    std: float | None
    unit: str


class EffectResult(_Frozen):
    type: str
    joint: int | None
    order: int | None
    parameters: list[EffectParameter]
    from_joint: int | None = None  # joint_coupling: the driving joint (the spec's `from`)
    form: str | None = None  # joint_compliance: masses | moments


class Candidate(_Frozen):
    effect: str
    id: str
    joint: int | None
    order: int | None
    from_joint: int | None = None  # joint_coupling: the driving joint
    statistic: float
    dof: int
    p_value: float
    distinguishable: bool
    significant: bool


class RMSPair(_Frozen):
    calibration: float
    validation: float | None


class Round(_Frozen):
    candidates: list[Candidate]
    accepted: EffectResult | None
    note: str
    partly_explained: bool = False  # the accepted effect left part of its signature
    rms_before: RMSPair
    rms_after: RMSPair


def _finite_or_none(value: float | None) -> float | None:
    """inf and nan as results.json holds them: null (a run's object and the one read back hold the same values)."""
    return value if value is None or math.isfinite(value) else None


BINNED_FIELDS = ("joint", "x", "count")  # a binned series' keys in results.json that are not series


class BinnedSeries(_AsWritten):
    """Each sample's residual magnitude (the evidence's unit) averaged in equal-width bins of x, empty bins left out
    (evaluate/evidence.py); x is a joint's angle or position (spec units), the gravity torque about it (N m), time (s),
    temperature (degC) or the longitude around a ball-bar's pivot (deg). `series` holds before (the fit before the diagnosis), after (final) and the predicted
    contribution of each effect the diagnosis added, keyed by the effect's id, in the run's order. results.json holds
    them inline, between x and count; they are read into one dict[str, list[float]] and written back where they stood
    (not extra="allow", whose values would go untyped and be written after the fields): the file reads and writes
    back byte for byte."""

    joint: int | None = None  # 1-based, in the panels of joints and gravity_torque; absent over t, temperature, longitude
    x: list[float | None]  # bin centres; null only in older results, which binned a scale bar's readings (no pose) at nan
    series: dict[str, list[float]]  # one mean per bin
    count: list[int]  # samples in each bin

    @model_validator(mode="wrap")
    @classmethod
    def _remember_keys(cls, data, handler):
        """The series results.json holds inline gathered into `series`, the order of the keys kept."""
        if not isinstance(data, dict):
            return handler(data)
        if isinstance(data.get("series"), dict):  # built with its fields: joint (if given), x, the series, count
            made = handler(data)
            made._keys = (*(["joint"] if made.joint is not None else []), "x", *made.series, "count")
            return made
        fields = {key: value for key, value in data.items() if key in BINNED_FIELDS}
        made = handler({**fields, "series": {key: value for key, value in data.items() if key not in BINNED_FIELDS}})
        made._keys = tuple(data)
        return made

    @field_validator("x")
    @classmethod
    def _finite_x(cls, x: list[float | None]) -> list[float | None]:
        return [_finite_or_none(v) for v in x]

    @model_validator(mode="after")
    def _bins_line_up(self) -> "BinnedSeries":
        if not {"before", "after"} <= set(self.series):
            raise ValueError("a binned series lacks its before or its after series")
        if any(len(values) != len(self.x) for values in (self.count, *self.series.values())):
            raise ValueError("a binned series' count or one of its series is not as long as its x")
        return self

    @model_serializer(mode="wrap")
    def _given_keys(self, handler) -> dict:
        out = handler(self)
        inline = {**out, **out.pop("series")}
        return {key: inline[key] for key in self._keys}

    @property
    def before(self) -> list[float]:
        return self.series["before"]

    @property
    def after(self) -> list[float]:
        return self.series["after"]


class KeyRMS(_Frozen):
    """The residuals' RMS at one key (target, pivot pairing, station; its parts joined by '/'), in the evidence's unit."""

    key: str
    n: int  # readings
    rms_before: float  # the design model's
    rms_after: float  # calibrated


class ResidualHistogram(_Frozen):
    """The final signed residuals' counts beside those the noise model's Gaussian (mean 0, sigma noise_sigma) expects
    (Goswami Figs. 3-4); lengths in the evidence's unit."""

    edges: list[float]  # one more than counts
    counts: list[int]
    expected: list[float]
    noise_sigma: float  # RMS of the readings' sigmas
    mean: float
    std: float


class Evidence(_AsWritten):
    """Where the residuals come from, before and after the diagnosis (evaluate/evidence.py), the data of the plots.
    unit is the instrument's residual unit (device.unit: mm, arcsec, ...); every residual below is in it."""

    unit: str
    joints: list[BinnedSeries]  # against each joint's angle or position
    joint_axes: list[str] | None = None  # each joint's x label, e.g. "joint angle (deg)"; absent in older results
    torque_masses: str | None = None  # the masses gravity_torque is from; absent in older results
    gravity_torque: list[BinnedSeries]  # against the gravity torque about each joint that carries one
    keys: list[KeyRMS]
    magnitude: str  # what a sample's residual magnitude is: "RMS over each sample's readings"
    histogram: ResidualHistogram
    t: BinnedSeries | None = None  # against time, where the data have a t column
    temperature: BinnedSeries | None = None  # where the data have a temperature column
    longitude: BinnedSeries | None = None  # along the shells' longitudes around a ball-bar's pivot (Goswami Fig. 3)


class Diagnosis(_Frozen):
    rounds: list[Round]
    added_effects: list[EffectResult]
    unexplained: bool
    chosen_on: str | None = None  # the data that judged the candidates (diagnose.holdout)
    alpha: float | None = None  # family-wise level of a round's score tests (Holm); absent in older results
    evidence: Evidence | None = None  # null: none drawn (armcal run draws it on every run)
    plots: list[str] = []


class CoordinateRMS(_Frozen):
    """One coordinate's held-out RMS without and with the learned residual model."""

    coordinate: str
    unit: str  # mm for lengths, deg for angles
    physical: float
    learned: float


class LearnedFigures(_Frozen):
    """Held-out errors of the physical model alone and with the learned residual model."""

    per_coordinate: list[CoordinateRMS]
    rms_3d_physical: float | None = None  # mm, 3D distance per pose (tracker)
    rms_3d_learned: float | None = None
    outside: int  # readings outside the calibrated region: their correction is not applied
    readings: int


class LearnedHyperparameters(_Frozen):
    coordinate: str
    at: str  # where it is read (LearnedCoordinate.at)
    unit: str
    signal_std: float  # prior standard deviation of the learned function
    noise_std: float
    length_scales: list[float]  # one per joint, in its unit (joint_units)
    training_readings: int


class LearnedCoordinate(_Frozen):
    """What reproduces one coordinate's learned model: a Gaussian process with the kernel
    signal_variance * RBF(length_scales) + noise_variance * White, conditioned on the targets at the inputs."""

    coordinate: str  # a channel as read, or base_x, base_y, base_z: a point's error in the robot's base frame
    at: str  # where it is read: a point's target, else its readings' key (names joined by '/')
    inputs: list[list[float]]  # joint values of the training readings (joint_units)
    targets: list[float]  # measured - predicted by the physical model, mm (rad for an angle)
    signal_variance: float
    length_scales: list[float]
    noise_variance: float


class ResidualModelResult(_Frozen):
    """The learned residual model (diagnose.residual_model), after the physical effects, and its test."""

    kind: Literal["gp"]
    accepted: bool
    z: float  # change of the held-out squared error, in standard errors (accepted below -threshold)
    threshold: float
    folds: int
    folds_along_joint: int | None  # the folds are contiguous ranges of this joint's values
    held_out: LearnedFigures  # k-fold over the calibration poses
    validation: LearnedFigures | None = None  # the validation data (final figures)
    outside_fraction: float  # the predictive std above which a prediction is outside the calibrated region, of the prior's
    joint_units: list[str]  # of the joint values the model is learned on: rad (revolute) or mm (prismatic)
    hyperparameters: list[LearnedHyperparameters]
    seconds: float
    carried: str  # where the model goes beyond this run
    model: list[LearnedCoordinate] | None = None  # the accepted model, to reproduce its predictions (null: not accepted)


class VarianceTestResult(_Frozen):
    statistic: float  # r (sigma / declared)^2, chi-square on r degrees of freedom under the declared noise
    dof: float
    p_value: float  # two-sided
    verdict: Literal["consistent", "declared_too_small", "declared_too_large"]


class NoiseGroup(_Frozen):
    group: str  # e.g. "position", "orientation, target tmac"
    field: str  # the device's noise field it estimates
    unit: str
    readings: int
    redundancy: float
    sigma: float  # estimated
    std: float
    interval: tuple[float, float]  # 95 %
    declared: float | None
    test: VarianceTestResult | None


class NoiseEstimate(_Frozen):
    """The noise of each group of readings, estimated from the calibration data (identify/variance.py)."""

    method: str
    rounds: int
    converged: bool
    groups: list[NoiseGroup]


class Cause(_Frozen):
    """A likely cause of residuals above the noise model, with the spec key to look at (diagnose/causes.py)."""

    kind: Literal["held_by_spec", "held_by_spec_together", "candidate_not_accepted", "candidates_not_distinguishable", "declared_noise"]
    parameters: list[str]
    spec_key: str
    line: int | None  # the spec's line of that key
    chi2_drop: float | None  # chi2 freeing the parameters would remove (linearised), or the candidate's score statistic
    dof: int | None
    p_value: float | None
    chi2_dof_after: float | None
    text: str


class NoiseCheck(_Frozen):
    chi2: float
    dof: int
    p_value: float
    covariance_scaled: bool
    verdict: Literal["consistent", "residuals_too_large", "residuals_too_small"] = "consistent"
    causes: list[Cause] = []  # ranked, when the residuals are too large


class CorrelationMatrix(_Frozen):
    """Correlations of every pair of identified parameters (identify/uncertainty.py): with each parameter's std, the
    covariance that propagates to predicted positions (evaluate/position_changes.py)."""

    parameters: list[str]  # the identified parameters, in the fit's order
    matrix: list[list[float]]  # within [-1, 1], 1 on the diagonal


class HeldOutCheck(_Frozen):
    """Held-out residuals against noise plus the parameters' propagated uncertainty (evaluate/held_out_check.py)."""

    chi2: float
    dof: int
    p_value: float
    rms_over_noise: float  # held-out RMS in noise sigmas
    expected_rms_over_noise: float  # what noise and the parameters' uncertainty predict
    parameter_share: float  # of the expected held-out variance, the parameters' uncertainty's share
    held_out_only: list[str]  # parameters only the held-out readings use (held at their spec values)
    verdict: Literal["consistent", "parameter_uncertainty", "beyond_prediction"]


class Solver(_Frozen):
    method: str
    iterations: int
    reason: str
    loss: str
    outliers: list[int]  # data file lines of samples the robust loss down-weighted


class Traceability(_Frozen):
    """The instrument's identity and its own calibration, as the spec gives them (device.instrument)."""

    maker: str | None
    model: str | None
    serial: str | None
    calibrated: str | None  # ISO date
    certificate: str | None
    mpe: str | None


class Campaign(_Frozen):
    """What was measured, for the certificate."""

    instrument: str
    details: list[str]  # microphones, pivots and spheres, stations, targets
    procedure: str
    validation_procedure: str | None
    calibration_samples: int
    validation_samples: int | None
    temperature: list[float] | None  # min, max in degC when measured
    traceability: Traceability | None = None  # null: the spec does not give the instrument's identity
    joint_ranges: list[list[float] | None] | None = None  # per joint [lowest, highest] calibration reading; null: an older armcal


class ReportInfo(_Frozen):
    certificate_number: str
    unit: str | None = None  # the certificate's length unit (report.unit, else the spec's); absent in older results
    customer: str | None
    operator: str | None
    location: str | None
    notes: str | None


class AcceptanceResult(_Frozen):
    """The statement of conformity: a held-out figure against the spec's tolerance (evaluate/acceptance.py)."""

    statistic: Literal["validation_rms", "validation_max", "validation_rms_3d", "validation_max_3d"]
    value: float
    unit: str
    tolerance: float
    decision_rule: Literal["simple", "guarded"]
    expanded_uncertainty: float | None  # U of the figure (guarded only)
    coverage_factor: float | None
    acceptance_limit: float  # the tolerance, less U when guarded
    verdict: Literal["pass", "fail"]


class SimulatedData(_Frozen):
    """Whether each data file is armcal's simulation (a truth.json beside it names its SHA-256)."""

    calibration: bool
    validation: bool | None


class ParameterChange(_Frozen):
    name: str
    unit: str
    old: float
    new: float
    change: float
    z: float | None  # change / sqrt(u_old^2 + u_new^2); null when neither has an uncertainty


class HistoryEntry(_Frozen):
    """An earlier calibration of the same robot, and the parameters that changed significantly since."""

    source: str  # the results.json read
    created: str
    run_id: str | None
    certificate_number: str
    status: str
    unit: str
    rms_calibration: float
    rms_validation: float | None
    compared: int  # parameters compared
    significant: list[ParameterChange]


class TaskSkipped(_Frozen):
    skipped: str  # why the task the spec asks for was not evaluated


class GridIndex(_Frozen):
    """One index of the grid task: its design-model and calibrated-control values on the true robot (evaluate/grid.py)."""

    index: str
    unit: str
    design: float
    calibrated: float
    improvement_factor: float | None  # |design| / |calibrated|; null: the calibrated value is 0

    _finite_factor = field_validator("improvement_factor")(_finite_or_none)


class IsoPose(_Frozen):
    """AP at one of the cube's poses, design-model and calibrated control (evaluate/grid.py)."""

    pose: str  # P1..P5
    unit: str
    design: float
    calibrated: float
    improvement_factor: float | None  # null: the calibrated AP is 0

    _finite_factor = field_validator("improvement_factor")(_finite_or_none)


class GridTaskResult(_AsWritten):
    """Stone's grid task (7.2.1-7.2.3), design-model vs calibrated control."""

    tool_centre_point: str | None = None  # absent in older results, as are the fields of its placement
    task_frame: str | None = None
    placement: str | None = None  # how the grid was placed (absent in older results)
    scaled: bool | None = None  # false only at Table 7-1
    scale: float | None = None  # 1: Table 7-1's 60 x 30 x 50 cm
    centre: list[float] | None = None  # of its box in the robot base frame, in unit
    unit: str | None = None
    indices: list[GridIndex]


class IsoCubeResult(_Frozen):
    centre: list[float]
    side: float
    unit: str
    placement: str


class IsoTaskResult(_AsWritten):
    """ISO 9283 positional accuracy AP at the cube's poses P1..P5."""

    tool_centre_point: str
    task_frame: str
    cube: IsoCubeResult | None = None  # absent in results before armcal placed the cube
    poses: list[IsoPose]


class FeatureUnits(_Frozen):
    length: str
    angle: str


class JointFeatures(_Frozen):
    """One joint's features and their accuracy (Stone 6.11-6.13), in the spec's units."""

    joint: int
    radius: float
    range_deg: float
    normal_residual_std: float
    radial_residual_std: float
    plane_sigma: float
    centre_sigma: float


class PseudoDHRow(_Frozen):
    joint: int
    theta_offset: float
    d: float
    a: float
    alpha: float


class FeatureFit(_Frozen):
    s_model_features: Stats
    least_squares: Stats


class FeatureResiduals(_AsWritten):
    s_model_features: Stats
    least_squares: Stats
    validation: FeatureFit | None = None  # absent without validation data


class FeaturesResult(_Frozen):
    """Stone's feature method beside the least-squares fit (evaluate/features.py)."""

    units: FeatureUnits
    joints: list[JointFeatures]
    pseudo_dh: list[PseudoDHRow]
    residuals: FeatureResiduals


class Evaluation(_AsWritten):
    """The evaluation block: the feature method's figures (fit.method s_model_features) and the tasks the spec's
    report asks for, each evaluated or skipped."""

    s_model_features: FeaturesResult | None = None
    grid_task: GridTaskResult | TaskSkipped | None = None
    iso9283: IsoTaskResult | TaskSkipped | None = None

    def tasks(self) -> list[tuple[str, GridTaskResult | IsoTaskResult | TaskSkipped]]:
        """The tasks the spec asked for, in the order written."""
        return [(key, getattr(self, key)) for key in self._keys if key in TASK_TITLES]


class Results(_Frozen):
    armcal_version: str
    run_id: str | None = None  # the run's id, in every artifact of its output set (armcal/support/output_set.py)
    created: str
    spec: SpecInfo
    robot: RobotInfo
    device: DeviceInfo
    status: Literal["converged", "not_converged"]
    identifiability: IdentifiabilityInfo
    parameters: list[ParameterResult]
    residuals: Residuals
    residuals_3d: Residuals3D | None = None  # per pose, where the instrument measures points
    improvement_factor: ImprovementFactor
    diagnosis: Diagnosis
    evaluation: Evaluation
    solver: Solver
    noise: NoiseEstimate | None = None  # where the spec asks for noise from the data
    noise_check: NoiseCheck
    correlations: list[tuple[str, str, float]]
    correlation_matrix: CorrelationMatrix | None = None  # null: results of an armcal before it was written
    campaign: Campaign
    report: ReportInfo
    acceptance: AcceptanceResult | None = None  # null: the spec gives no acceptance criterion
    simulated: SimulatedData | None = None  # null: not recorded (results of an older armcal)
    history: list[HistoryEntry] = []  # earlier calibrations given with --history
    warnings: list[str] = []  # what the user should know about the inputs (e.g. a simulated-looking t column in real data)
    held_out_check: HeldOutCheck | None = None  # null: no held-out data
    plausibility: Plausibility | None = None  # null: results of an older armcal
    residual_model: ResidualModelResult | None = None  # null: diagnose.residual_model is none (or no diagnosis ran)


    @model_validator(mode="after")
    def _consistent(self) -> "Results":
        """What no run writes: a parameter listed twice, a joint's or six_parameter link's parameter the robot does not have, a correlation
        matrix not square over its parameters (the file was edited or comes from elsewhere)."""
        names = [p.name for p in self.parameters]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ValueError(f"parameters listed twice: {', '.join(twice[:5])}")
        beyond = [n for n in names if (m := JOINT_PARAMETER.match(n)) and not 1 <= int(m.group(1)) <= self.robot.dof]
        if self.robot.convention == "six_parameter":  # its links are named L1..L(n+1), no target may take such a name
            beyond += [n for n in names if (m := SIX_PARAMETER_LINK.match(n))
                       and (not 1 <= int(m.group(1)) <= self.robot.dof + 1 or m.group(2) not in LINK_FIELDS)]
        if beyond:
            raise ValueError(f"parameters of joints or links the robot ({self.robot.dof} joints) does not have: {', '.join(beyond[:5])}")
        matrix = self.correlation_matrix
        if matrix is not None and (len(matrix.matrix) != len(matrix.parameters) or any(len(row) != len(matrix.parameters) for row in matrix.matrix)):
            raise ValueError("correlation_matrix is not square over its parameters")
        return self
