"""Compiled measurement functions, cached across runs.

All functions of a problem are generated as C in one file and compiled once by
the system's C compiler; the shared object is kept under a hash of what defines
them (the canonical robot and device sections of the spec, the device's mode,
the keys, and the armcal and CasADi versions), so later runs of the same setup
load it at once. Without a C compiler CasADi's virtual machine evaluates them.

Loading a library runs its code, so the cache is private: its folder is made 0700,
each library is written 0700 with the SHA-256 of its bytes beside it
(``armcal_<digest>.so.sha256``), and a library is loaded only when it, its hash file
and the folder belong to this user, are writable by no one else and the hash matches.
A library that fails the check (truncated, garbage, replaced) is rebuilt; a cache
folder that fails it is not used: that process compiles into a private temporary folder.
"""

from __future__ import annotations

import atexit
import functools
import hashlib
import os
import shutil
import subprocess
import sys
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
    library = _private_folder() / f"armcal_{digest}.so"
    names = [f"f{i}" for i in range(len(functions))]
    if not _intact(library):
        try:
            _build(functions, names, library, compiler)
        except (OSError, subprocess.CalledProcessError):
            return functions
    return [ca.external(name, str(library)) for name in names]


def _private_folder() -> Path:
    """The cache folder, created 0700; a private temporary folder when the cache cannot be trusted."""
    folder = cache_dir()
    try:
        _make_private(folder)
        problem = _exposure(folder)
    except OSError as error:
        problem = f"cannot be created ({error.strerror})"
    if problem is None:
        return folder
    _say_once(f"armcal: not using the compiled-code cache {folder}: it {problem}; compiling into a temporary folder")
    return _temporary_folder()


def _make_private(folder: Path) -> None:
    """Create ``folder`` and its missing parents with mode 0700, whatever the umask."""
    for missing in reversed([f for f in (folder, *folder.parents) if not f.exists()]):
        try:
            os.mkdir(missing, 0o700)
        except FileExistsError:  # created meanwhile by another process
            pass


def _exposure(path: Path) -> str | None:
    """Why someone other than this user could have written ``path``, or None when no one could."""
    info = os.stat(path)
    if info.st_uid != os.geteuid():
        return f"belongs to user id {info.st_uid}"
    if info.st_mode & 0o022:
        return "is writable by group or others"
    return None


def _intact(library: Path) -> bool:
    """Whether ``library`` and its hash file are this user's alone and the library's SHA-256 is the recorded one."""
    record = _hash_file(library)
    try:
        if _exposure(library) or _exposure(record) or not library.is_file():
            return False
        return record.read_text().strip() == _sha256(library)
    except (OSError, UnicodeDecodeError):
        return False


def _build(functions: list[ca.Function], names: list[str], library: Path, compiler: str) -> None:
    """Compile the functions into ``library`` and record its hash; each file replaced whole or not at all."""
    with tempfile.TemporaryDirectory(dir=library.parent) as work:
        generator = ca.CodeGenerator("armcal_functions.c", {"with_header": False})
        for function, name in zip(functions, names):
            generator.add(_renamed(function, name))
        source = generator.generate(work + os.sep)
        partial = Path(work) / library.name
        subprocess.run([compiler, "-shared", "-fPIC", "-O1", source, "-o", str(partial)], check=True, capture_output=True)
        os.chmod(partial, 0o700)
        record = Path(work) / _hash_file(library).name
        record.write_text(_sha256(partial) + "\n")
        os.chmod(record, 0o600)
        os.replace(partial, library)
        os.replace(record, _hash_file(library))


def _hash_file(library: Path) -> Path:
    """Where the SHA-256 of ``library`` is recorded."""
    return library.with_name(library.name + ".sha256")


def _sha256(path: Path) -> str:
    """Hex SHA-256 of a file's bytes."""
    with path.open("rb") as stream:
        return hashlib.file_digest(stream, "sha256").hexdigest()


@functools.cache
def _temporary_folder() -> Path:
    """A private folder for this process's libraries, removed when it exits."""
    folder = tempfile.mkdtemp(prefix="armcal-")
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return Path(folder)


@functools.cache
def _say_once(message: str) -> None:
    """Print ``message`` on standard error, once per process."""
    print(message, file=sys.stderr)


def _renamed(function: ca.Function, name: str) -> ca.Function:
    """``function`` as an SX function called ``name``."""
    inputs = [ca.SX.sym(function.name_in(i), function.sparsity_in(i)) for i in range(function.n_in())]
    return ca.Function(name, inputs, function.call(inputs), function.name_in(), function.name_out())
