"""Stone's three-dimensional grid-touching task (7.2.1): 34 indices, design-model vs calibrated control.

Lines 1, 4, 5, 8 run along X (vertices 1-2, 3-4, 5-6, 7-8, with midpoints 9-12),
lines 2, 3, 6, 7 along Y (1-3, 2-4, 5-7, 6-8) and lines 9-12 along Z (1-5, 2-6,
3-7, 4-8). Indices: 16 linear displacement errors (12 lines, 4 diagonals 1-4,
2-3, 5-8, 6-7), 4 normal deviations (midpoints from lines 1, 4, 5, 8), 4 radial
and 4 absolute orientation errors (vertices 1, 4, 5, 8), 3 relative orientation
errors (vertices 4, 5, 8 against vertex 1), 3 perpendicularity errors. The
perpendicularity pairs printed in 7.2.1 do not share a vertex with this line
numbering; here they are the X, Y and Z lines through vertex 1 (lines 1, 2, 9).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armcal.kinematics.parallel_axes import parallel_axes

LINES = [(1, 2), (1, 3), (2, 4), (3, 4), (5, 6), (5, 7), (6, 8), (7, 8), (1, 5), (2, 6), (3, 7), (4, 8)]
DIAGONALS = [(1, 4), (2, 3), (5, 8), (6, 7)]
MIDPOINTS = {1: 9, 4: 10, 5: 11, 8: 12}  # line -> its midpoint vertex
CORNERS = (1, 4, 5, 8)
RADIAL = tuple(f"vertex {k} radial" for k in CORNERS)  # the indices of Stone's Figures 7-4 to 7-8
ORIENTATION = tuple(f"vertex {k} orientation" for k in CORNERS)  # absolute: the tool's orientation in the task frame


def _angle(R: np.ndarray) -> float:
    return float(np.arccos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)))


def grid_indices(actual: np.ndarray, desired: np.ndarray) -> dict[str, float]:
    """The 34 performance indices (mm, rad) of reached frames (12, 4, 4) against the desired ones."""
    P, D = actual[:, :3, 3], desired[:, :3, 3]
    v = lambda k: P[k - 1]  # noqa: E731
    out: dict[str, float] = {}
    for number, (a, b) in enumerate(LINES, start=1):
        out[f"line {number} length"] = float(np.linalg.norm(v(b) - v(a)) - np.linalg.norm(D[b - 1] - D[a - 1]))
    for a, b in DIAGONALS:
        out[f"diagonal {a}-{b} length"] = float(np.linalg.norm(v(b) - v(a)) - np.linalg.norm(D[b - 1] - D[a - 1]))
    for line, mid in MIDPOINTS.items():
        a, b = LINES[line - 1]
        direction = (v(b) - v(a)) / np.linalg.norm(v(b) - v(a))
        off = v(mid) - v(a)
        out[f"line {line} normal deviation"] = float(np.linalg.norm(off - (off @ direction) * direction))
    for k in CORNERS:
        out[f"vertex {k} radial"] = float(np.linalg.norm(v(k) - D[k - 1]))
        out[f"vertex {k} orientation"] = _angle(actual[k - 1, :3, :3] @ desired[k - 1, :3, :3].T)
    for k in CORNERS[1:]:
        relative = actual[k - 1, :3, :3] @ actual[0, :3, :3].T
        wanted = desired[k - 1, :3, :3] @ desired[0, :3, :3].T
        out[f"vertex {k} relative orientation"] = _angle(relative @ wanted.T)
    for name, (la, lb) in (("X-Y", (1, 2)), ("Y-Z", (2, 9)), ("Z-X", (9, 1))):
        (a1, b1), (a2, b2) = LINES[la - 1], LINES[lb - 1]
        d1, d2 = v(b1) - v(a1), v(b2) - v(a2)
        out[f"{name} perpendicularity"] = float(np.arccos(d1 @ d2 / np.linalg.norm(d1) / np.linalg.norm(d2)) - np.pi / 2)
    return out


@dataclass(frozen=True)
class TaskControl:
    """A task's desired frames under design-model control (Stone 7.2.2) and calibrated control (7.2.3).

    Design control solves the task once with the design model (many starts, the
    solution nearest the design's); calibrated control solves it with an identified
    model by Newton-Raphson (5.4) started from the design solution, halving steps that
    would not reduce the error (an identified pseudo-DH model can be near-singular,
    Table 6-3). The true robot
    then goes to both solutions. ``frame`` is the tool centre point: the tool, or the
    one target an instrument measured (the flange itself is then not observed, only
    that point). ``teach``: when the instrument's placement was identified with the
    robot (DeviceSpec.base_frame_free), the base frame is only known up to a rigid motion, so the task
    frame is taught (Stone: models describe the internal kinematics; the task frame is
    taught before the task) by the best rigid fit of the reached frames, for both
    controls alike.
    """

    kinematics: object
    desired: np.ndarray  # (N, 4, 4)
    q_design: np.ndarray  # (N, n)
    frame: str | None = None
    teach: bool = False
    goal: int = 12  # what both controls command of a frame: its pose (12), its point and z axis (6), its point (3)
    error: object = None  # ik.error_function of the frame and goal, compiled once for every robot's control

    @staticmethod
    def plan(kinematics, desired: np.ndarray, p_design: np.ndarray, frame: str | None = None, teach: bool = False,
             goal: int = 12, known: np.ndarray | None = None) -> "TaskControl | None":
        """The task solved with the design model; None when the design model cannot reach it. With a ``goal`` short of
        the pose (a robot of fewer axes, procedures/placement.py), the desired orientation is the design model's at its
        solution: the one design-model control commands. ``known``: joints (N, n) the placement found reaching the
        frames, taken where the random starts find none."""
        from armcal.kinematics import ik
        from armcal.procedures.placement import goal_rows

        error = ik.compiled_error(kinematics, frame, goal, None)
        q_design = ik.solve_from_starts(kinematics, goal_rows(desired, goal), frame=frame, p=p_design, starts=48, error=error)  # few goals: many starts
        if known is not None:
            q_design = np.where(np.isnan(q_design), known, q_design)
        if np.isnan(q_design).any():
            return None
        if goal != 12:
            reached = kinematics.target_poses(frame, q_design, p_design) if frame else kinematics.tool_poses(q_design, p_design)
            desired = desired.copy()
            desired[:, :3, :3] = reached[:, :3, :3]
        return TaskControl(kinematics, desired, q_design, frame, teach, goal, error)

    def reached(self, truth, p_calibrated: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Frames (N, 4, 4) the true robot reaches under design-model and under calibrated control."""
        from armcal.kinematics import ik
        from armcal.procedures.placement import goal_rows

        goals = goal_rows(self.desired, self.goal)
        q_calibrated = ik.solve(self.kinematics, goals, self.q_design, frame=self.frame, p=p_calibrated, halvings=ik.SAFE_HALVINGS,
                                error=self.error).q
        count = len(self.desired)
        extras = {"t": np.zeros(count), "temperature": np.full(count, 20.0), "dir": np.ones((count, self.kinematics.dof))}
        reach = (lambda q: truth.target_poses(self.frame, q, extras)) if self.frame else (lambda q: truth.tool_poses(q, extras))
        seen = (lambda q: taught(reach(q), self.desired)) if self.teach else reach
        return seen(self.q_design), seen(q_calibrated)

    def describe(self) -> dict:
        return {"tool_centre_point": self.frame or "tool", "task_frame": "taught by best fit" if self.teach else "robot base"}


def iso9283_evaluation(kinematics, p_design, p_calibrated, truth, units, cube, frame: str | None = None, teach: bool = False) -> dict:
    """ISO 9283 positional accuracy AP at the cube's poses P1..P5, design-model vs calibrated control.

    AP is the distance between the commanded and the attained position (one cycle:
    the simulated robot repeats perfectly); orientation as Rot(y, 180) Rot(z, 90) of 7.2.1.
    The cube stands where the spec puts it, or where procedures/placement.py finds the
    largest one the robot reaches.
    """
    from armcal.kinematics.transforms import compose, rot_y, rot_z
    from armcal.procedures.placement import Placement, placed, unplaced
    from armcal.procedures.tasks import iso9283_cube
    from armcal.support.units import from_internal

    if cube is not None:
        centre = np.array([cube.x, cube.y, cube.z])
        rotation = compose(rot_y(np.pi), rot_z(np.pi / 2))[:3, :3]
        stands = Placement(iso9283_cube(centre, cube.side, rotation), centre, cube.side, "as the spec gives it (report.iso9283_cube)")
    else:
        stands = placed("iso9283", kinematics, p_design, frame)
        if stands is None:
            return {"skipped": f"no ISO 9283 cube is reachable by this robot's design model: {unplaced('iso9283', kinematics, p_design, frame)}"}
    control = TaskControl.plan(kinematics, stands.frames, p_design, frame, teach, stands.goal, stands.q)
    if control is None:
        return {"skipped": "the ISO 9283 cube the spec gives (report.iso9283_cube) is not reachable by this robot's design model"}
    rows = []
    for k, (d, c) in enumerate(zip(*control.reached(truth, p_calibrated)), start=1):
        ap_d, ap_c = (float(np.linalg.norm(x[:3, 3] - stands.frames[k - 1, :3, 3])) for x in (d, c))
        rows.append({"pose": f"P{k}", "unit": units.length, "design": from_internal(ap_d, "length", units.length),
                     "calibrated": from_internal(ap_c, "length", units.length), "improvement_factor": ap_d / ap_c if ap_c else float("inf")})
    length = lambda v: from_internal(float(v), "length", units.length)  # noqa: E731
    where = {"centre": [length(v) for v in stands.centre], "side": length(stands.size), "unit": units.length, "placement": stands.how}
    return {**control.describe(), "cube": where, "poses": rows}


def taught(reached: np.ndarray, desired: np.ndarray) -> np.ndarray:
    """Reached frames seen from a task frame taught by the best rigid fit of the reached vertices (Stone 4.3.5)."""
    from armcal.kinematics.transforms import rigid_registration

    T = rigid_registration(reached[:, :3, 3], desired[:, :3, 3])
    return np.einsum("ij,njk->nik", T, reached)


def index_kind(name: str) -> str:
    """A grid index is an angle (orientation, perpendicularity) or a length."""
    return "angle" if ("orientation" in name or "perpendicularity" in name) else "length"


TABLE_7_1 = "Table 7-1 (Stone 7.2.1), where the PUMA 560 reaches it"
GRID_UNREACHABLE = "Stone's grid is reachable by this robot's design model neither at Table 7-1 nor, scaled, near the centre of its workspace"


def grid_unreachable(kinematics, p_design: np.ndarray, frame: str | None = None) -> str:
    """Why the grid has no place (GRID_UNREACHABLE and the numbers of the search, procedures/placement.unplaced)."""
    from armcal.procedures.placement import unplaced

    return f"{GRID_UNREACHABLE}: {unplaced('grid_task', kinematics, p_design, frame)}"


def grid_control(kinematics, p_design: np.ndarray, frame: str | None = None, teach: bool = False):
    """Stone's grid solved with the design model (7.2.2): (TaskControl, Placement), or None where it is not reached.

    The grid stands at Table 7-1 where the design model reaches it there (the PUMA's grid, as Stone's), else where
    procedures/placement.py scales and places it in the robot's own workspace (memoized per design and process).
    """
    from armcal.procedures.placement import Placement, placed
    from armcal.procedures.tasks import grid_task

    control = TaskControl.plan(kinematics, grid_task(), p_design, frame, teach)
    if control is not None:
        vertices = control.desired[:, :3, 3]
        return control, Placement(control.desired, (vertices.min(axis=0) + vertices.max(axis=0)) / 2, 1.0, TABLE_7_1)
    stands = placed("grid_task", kinematics, p_design, frame)  # another robot: the grid in its own workspace
    control = None if stands is None else TaskControl.plan(kinematics, stands.frames, p_design, frame, teach, stands.goal, stands.q)
    return None if control is None else (control, stands)


def grid_placement(stands, units) -> dict:
    """Where the grid stood, in the spec's length unit: ``placement`` (how), ``scaled`` (False only at Table 7-1),
    ``scale`` (1: Table 7-1's 60 x 30 x 50 cm), ``centre`` of its box in the robot base frame, ``unit``."""
    from armcal.support.units import from_internal

    length = lambda v: round(from_internal(float(v), "length", units.length), 6) + 0.0  # noqa: E731 (no -0.0, no 1e-14)
    return {"placement": stands.how, "scaled": stands.how != TABLE_7_1, "scale": stands.size,
            "centre": [length(v) for v in stands.centre], "unit": units.length}


def grid_evaluation(
    kinematics, p_design: np.ndarray, p_calibrated: np.ndarray, truth, units, frame: str | None = None, teach: bool = False
) -> dict:
    """Design-model vs calibrated control on the true robot (Stone 6.6, 7.2.2-7.2.3), in the spec's units.

    Each index's improvement factor is |design error| / |calibrated error| (Tables 6-10, 6-11).
    """
    from armcal.support.units import from_internal

    solved = grid_control(kinematics, p_design, frame, teach)
    if solved is None:
        return {"skipped": grid_unreachable(kinematics, p_design, frame)}
    control, stands = solved
    reached_design, reached_calibrated = control.reached(truth, p_calibrated)
    design = grid_indices(reached_design, control.desired)
    calibrated = grid_indices(reached_calibrated, control.desired)
    rows = []
    for name in design:
        kind = index_kind(name)
        unit = units.of(kind)
        d, c = design[name], calibrated[name]
        rows.append(
            {
                "index": name,
                "unit": unit,
                "design": from_internal(d, kind, unit),
                "calibrated": from_internal(c, kind, unit),
                "improvement_factor": abs(d) / abs(c) if c else float("inf"),
            }
        )
    return {**control.describe(), **grid_placement(stands, units), "indices": rows}


def evaluation_tasks(spec, kinematics, calibrated, truth: dict | None) -> dict:
    """The tasks the spec's report asks for, evaluated where the data's truth is known (simulation), else skipped
    with the reason."""
    if truth is None:
        why = "it needs the true robot, known for simulated data only (the truth.json armcal simulate writes beside them)"
        return {task: {"skipped": why} for task in spec.report.tasks}
    recorded, names = set(truth.get("parameters", {})), set(kinematics.parameters.names)
    added = {f"{axes.name}.beta" for axes in parallel_axes(spec.robot.chain()) if axes.beta_added}  # at 0 in a record made before
    if not recorded <= names or names - recorded - added or len(truth["encoder_errors"]) != kinematics.dof:
        why = "the data's truth.json describes a robot of another model than this spec's (simulated from another spec)"
        return {task: {"skipped": why} for task in spec.report.tasks}
    from armcal.simulate.truth import TrueRobot

    theta = calibrated.identified.theta[: calibrated.problem.n_robot]
    free = {e.name for e in calibrated.problem.parameters.entries if e.free}
    setting = (kinematics, kinematics.parameters.nominal, theta, TrueRobot.from_record(kinematics, truth), spec.robot.units)
    where = {"frame": measured_point(spec), "teach": spec.device.base_frame_free(free)}
    tasks = {}
    if "grid_task" in spec.report.tasks:
        tasks["grid_task"] = grid_evaluation(*setting, **where)
    if "iso9283" in spec.report.tasks:
        tasks["iso9283"] = iso9283_evaluation(*setting, spec.report.iso9283_cube, **where)
    return tasks


def measured_point(spec) -> str | None:
    """The one robot target a point-measuring instrument saw, if that is all it saw (the tasks' tool centre point)."""
    targets = spec.device.seen_targets()
    return targets[0] if len(targets) == 1 and spec.device.locates_targets else None


def unobserved_orientation(spec) -> str | None:
    """Why the data cannot tell the calibrated model the task's absolute orientation (the four ``vertex k orientation``
    indices), or None when they can.

    The tool centre point's link must be seen as a frame: orientation readings (a tracker's 6-DOF probe), or three or
    more measured points on that link. With one point (a reflector, a theodolite's ball, Stone's sparker on link 6, a
    single ball-bar sphere) a turn of the link's frame about it (the simulated robot's error freedoms after its last
    link, Stone 7.1-7.8), with two a turn about the line through them, is absorbed by the points' offsets and stays at
    the design model's value: calibrated control keeps that part of the manufacturing error (about sigma_o; the
    joint axes the points sweep are identified, hence a reduction, not a calibration). The positions, lengths, perpendicularities
    and the relative orientations (vertex k against vertex 1: a constant turn of the last link cancels) are predicted.
    """
    device = spec.device
    if device.sees_orientation():
        return None
    seen = device.seen_targets() or getattr(spec.procedure, "targets", None) or list(spec.robot.targets)
    point = measured_point(spec)
    link = spec.robot.targets[point].link if point else spec.robot.dof
    on_link = [name for name in seen if name in spec.robot.targets and spec.robot.targets[name].link == link]
    if len(on_link) >= 3:
        return None
    count = f"{len(on_link)} measured point{'s' if len(on_link) != 1 else ''} ({', '.join(on_link)})" if on_link else "no measured point"
    turn = ("the link's frame is", "a turn of the link's frame about that point is", "a turn of the link's frame about the line through them is")[len(on_link)]
    return (f"the instrument sees {count} on link {link} (the {'target ' + point if point else 'tool'}'s) and no orientation: "
            f"{turn} not observed, so calibrated control keeps that part of the manufacturing error; "
            f"these indices do not measure the calibration")
