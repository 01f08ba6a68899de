"""Compiled measurement functions, cached across runs.

All functions of a problem are generated as C in one file and compiled once by
the system's C compiler; the shared object is kept under a hash of what defines
them (the canonical robot and device sections of the spec, the device's mode,
the keys, and the armcal and CasADi versions), so later runs of the same setup
load it at once. Without a C compiler CasADi's virtual machine evaluates them.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import casadi as ca

from armcal import __version__


def cache_dir() -> Path:
    """$ARMCAL_CACHE, else ~/.cache/armcal."""
    return Path(os.environ.get("ARMCAL_CACHE") or Path.home() / ".cache" / "armcal")


def compiled(functions: list[ca.Function], identity: str) -> list[ca.Function]:
    """The same functions, compiled to machine code (or as given when no compiler is available)."""
    compiler = shutil.which(os.environ.get("CC", "cc")) or shutil.which("gcc")
    if compiler is None or not functions:
        return functions
    digest = hashlib.sha256(f"{identity}|armcal {__version__}|casadi {ca.__version__}".encode()).hexdigest()[:32]
    library = cache_dir() / f"armcal_{digest}.so"
    names = [f"f{i}" for i in range(len(functions))]
    if not library.exists():
        try:
            _build(functions, names, library, compiler)
        except (OSError, subprocess.CalledProcessError):
            return functions
    return [ca.external(name, str(library)) for name in names]


def _build(functions: list[ca.Function], names: list[str], library: Path, compiler: str) -> None:
    library.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=library.parent) as work:
        generator = ca.CodeGenerator("armcal_functions.c", {"with_header": False})
        for function, name in zip(functions, names):
            generator.add(_renamed(function, name))
        source = generator.generate(work + os.sep)
        partial = Path(work) / library.name
        subprocess.run([compiler, "-shared", "-fPIC", "-O1", source, "-o", str(partial)], check=True, capture_output=True)
        os.replace(partial, library)  # whole or not at all


def _renamed(function: ca.Function, name: str) -> ca.Function:
    inputs = [ca.SX.sym(function.name_in(i), function.sparsity_in(i)) for i in range(function.n_in())]
    return ca.Function(name, inputs, function(*inputs), function.name_in(), function.name_out())
