"""Benchmark: when compiling pays (support/compiled.py's BREAK_EVEN), measured on the shipped examples' libraries.

For each example (examples/*/spec.yaml) the functions of its calibration problem, one per key, as `armcal run` builds
them, and the UR10's inverse-kinematics error function (specs/ur10.yaml): their C source compiled with armcal's flags
(builder.FLAGS) in a temporary folder, timed as the compiler's CPU; then each function evaluated at 256 random points
by CasADi's virtual machine and by the library (CPU per evaluation, best of 5). The break-even is the number of
evaluations of every function after which the compile has cost what the machine code saved:
gcc / (VM - compiled), per evaluation of all the library's functions. The baseline column is the virtual machine.

Run: .venv/bin/python benchmarks/bench_break_even.py   (prints one table; about a minute)
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
os.environ["ARMCAL_COMPILE"] = "off"  # the functions as the virtual machine evaluates them; compiled here, by hand

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

from armcal.commands.run import fitted_device  # noqa: E402
from armcal.dataio.reader import read_measurements  # noqa: E402
from armcal.diagnose.calibration import calibration_problem  # noqa: E402
from armcal.kinematics import ik  # noqa: E402
from armcal.kinematics.compiler import compile_robot  # noqa: E402
from armcal.spec import load_spec  # noqa: E402
from armcal.support import builder, compiled  # noqa: E402

POINTS = 256


def problem_functions(spec_path: Path) -> list[ca.Function]:
    """The value-and-Jacobian functions of the example's first calibration problem, one per key."""
    spec = load_spec(spec_path).spec
    raw = read_measurements(spec_path.parent / spec.data.calibration, spec)
    kinematics, device = compile_robot(spec.robot.chain()), fitted_device(spec, raw)
    problem, _ = calibration_problem(spec, kinematics, device, device.prepare(raw))
    return list(dict.fromkeys(block._function for block in problem.blocks))


def compile_seconds(functions: list[ca.Function], folder: Path) -> tuple[float, Path]:
    """The compiler's CPU seconds for the library of ``functions`` (named f0, f1, ...) and its path."""
    source, library = folder / builder.SOURCE, folder / "library.so"
    source.write_text(compiled._generated(functions, [f"f{i}" for i in range(len(functions))]))
    compiler = os.environ.get("CC") or "cc"
    before = os.times()
    subprocess.run([compiler, *builder.FLAGS, str(source), "-o", str(library)], check=True)
    after = os.times()
    return (after.children_user + after.children_system) - (before.children_user + before.children_system), library


def seconds_per_evaluation(function: ca.Function, arguments: list[np.ndarray]) -> float:
    """CPU seconds of one evaluation, from a mapped call over POINTS points (best of 5)."""
    mapped = function.map(POINTS)
    mapped(*arguments)
    best = float("inf")
    for _ in range(5):
        started = time.process_time()
        mapped(*arguments)
        best = min(best, time.process_time() - started)
    return best / POINTS


def measure(name: str, functions: list[ca.Function], rng: np.random.Generator) -> str:
    with tempfile.TemporaryDirectory() as folder:
        gcc, library = compile_seconds(functions, Path(folder))
        machine = virtual = 0.0
        for i, function in enumerate(functions):
            arguments = [rng.standard_normal((function.size1_in(k), POINTS)) for k in range(function.n_in())]
            virtual += seconds_per_evaluation(function, arguments)
            machine += seconds_per_evaluation(ca.external(f"f{i}", str(library)), arguments)
    instructions = sum(int(f.n_instructions()) for f in functions)
    return (f"{name:34s} {len(functions):3d} {instructions:8d} {gcc:6.2f} {machine * 1e6:9.1f} {virtual * 1e6:9.1f} "
            f"{virtual / machine:5.1f} {gcc / (virtual - machine):11.0f}")


def main() -> None:
    rng = np.random.default_rng(0)
    cases = [(f"{spec.parent.name} problem", problem_functions(spec)) for spec in sorted((ROOT / "examples").glob("*/spec.yaml"))]
    ur10 = compile_robot(load_spec(ROOT / "specs" / "ur10.yaml").spec.robot.chain())
    cases.append(("UR10 inverse kinematics", [ik.error_function(ur10)]))
    print(f"{'case':34s} {'fns':>3s} {'instr':>8s} {'gcc s':>6s} {'armcal us':>9s} {'VM us':>9s} {'ratio':>5s} {'break-even':>11s}")
    print("-" * 92)
    for name, functions in cases:
        print(measure(name, functions, rng), flush=True)
    print(f"armcal us / VM us: CPU per evaluation of all the library's functions, compiled / virtual machine (ratio VM / "
          f"compiled); break-even: evaluations after which gcc's CPU equals the time saved. compiled.BREAK_EVEN = {compiled.BREAK_EVEN}")


if __name__ == "__main__":
    main()
