"""Benchmark: peak memory of identification on 10,000 and 100,000 samples, armcal against the baseline.

The ball-bar campaign of examples/goswami_ballbar with its 816 samples repeated. Each side
runs in a fresh process that imports everything and reads the data first; what is reported is its peak
resident set (getrusage) above the resident set at that point, i.e. what the work itself adds.
armcal: build_problem and fit. Baseline: the numpy model (benchmarks/_common.py) fitted by scipy's
LM with finite differences on armcal's base set. Both fits must reach the same cost.

Run: .venv/bin/python benchmarks/bench_memory.py   (prints one table)
"""

from __future__ import annotations

import json
import resource
import subprocess
import sys
import time

from _common import ROOT, NumpyCampaign, assert_same_model, numpy_device, scipy_lm_fd

import numpy as np

from armcal.dataio.reader import read_measurements
from armcal.devices import device_model
from armcal.identify.fit import fit
from armcal.identify.problem import build_problem
from armcal.kinematics.compiler import compile_robot
from armcal.spec import load_spec

SAMPLES = (10_000, 100_000)
MIB = 1024.0  # KiB per MiB


def _resident_kib() -> int:
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) for line in status if line.startswith("VmRSS:"))


def child(side: str, samples: int) -> dict:
    """In a fresh process: the work of one side on ``samples`` samples; MiB above the resident set before it."""
    folder = ROOT / "examples" / "goswami_ballbar"
    spec = load_spec(folder / "spec.yaml").spec
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    small = read_measurements(folder / "calibration.csv", spec)
    problem = build_problem(kinematics, device, small)
    names, start = problem.parameters.names, problem.parameters.nominal
    data = small.subset(np.arange(samples) % len(small))
    if side == "baseline":
        model = NumpyCampaign(spec.robot, numpy_device(spec), names, data)
        free = fit(problem, spec.fit).base
        assert_same_model(NumpyCampaign(spec.robot, numpy_device(spec), names, small), problem, start)
    before, started = _resident_kib(), time.perf_counter()
    if side == "armcal":
        final = fit(build_problem(kinematics, device, data), spec.fit).solver.cost
    else:
        final = 0.5 * float(np.sum(model.residuals(scipy_lm_fd(model, start, free)[0]) ** 2))
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return {"work": (peak - before) / MIB, "total": peak / MIB, "seconds": time.perf_counter() - started, "cost": final}


def measure(side: str, samples: int) -> dict:
    out = subprocess.run([sys.executable, __file__, side, str(samples)], check=True, capture_output=True, text=True).stdout
    return json.loads(out.splitlines()[-1])


def main() -> None:
    header = f"{'case':44s} {'armcal MiB':>10s} {'baseline MiB':>12s} {'ratio':>7s}"
    print(header)
    print("-" * len(header))
    for samples in SAMPLES:
        armcal, baseline = measure("armcal", samples), measure("baseline", samples)
        assert abs(armcal["cost"] - baseline["cost"]) < 1e-6 * armcal["cost"], (armcal["cost"], baseline["cost"])
        print(f"{'ball-bar, %d lengths, 85 params' % samples:44s} {armcal['work']:10.0f} {baseline['work']:12.0f} {armcal['work'] / baseline['work']:7.1f}")
        print(
            f"    (armcal: build_problem + fit, {armcal['seconds']:.1f} s; baseline: scipy LM-FD fit, {baseline['seconds']:.1f} s;"
            f" whole processes incl. imports and data: {armcal['total']:.0f} and {baseline['total']:.0f} MiB)"
        )
    print("MiB: peak resident set above the process's resident set after imports and reading the data; ratio: armcal / baseline")


if __name__ == "__main__":
    if len(sys.argv) > 1:
        print(json.dumps(child(sys.argv[1], int(sys.argv[2]))))
    else:
        main()
