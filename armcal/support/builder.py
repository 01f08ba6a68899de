"""Building a library of compiled functions into the private cache: here, or in a detached process.

Standard library only, so the detached builder (started by compiled.py as ``python -I -c ...``)
starts in milliseconds and imports neither CasADi nor numpy. What it builds is C source that
the parent process generated and wrote into a private ``build-*`` folder inside the cache.

One build at a time per cache folder: a builder holds an exclusive lock (flock) on the folder
while it compiles, so two builders never race on the same file, and one that waited finds the
library its predecessor finished and does not build it again. The lock dies with its process.
Files are written in a temporary folder inside the cache and moved into place whole
(os.replace): the library, then the SHA-256 record of its bytes. A crash or kill therefore
leaves no library, the old one, or a library whose record does not match, which is never
loaded and is built again.
"""

from __future__ import annotations

import contextlib
import fcntl
import functools
import hashlib
import os
import platform
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# This processor's instructions, but no a*b+c contracted into one fused multiply-add (rounded once instead of twice):
# the machine code then computes what CasADi's virtual machine computes, bit for bit, on any processor. Fusing was
# 12-18 % faster (the UR10's closed loop 6.6 s of CPU against 7.8 s), and made the last bits, and outcomes that hang
# on them, depend on the processor and on whether a run had its library yet. -O1 compiled the ball-bar and
# hidden-harmonic examples' libraries in 0.56-0.57 of -O3's compiler time, to the same numbers bit for bit, but their
# warm runs took 8-15 % more CPU (2026-12-07): a library is compiled once and run many times, so -O3.
FLAGS = ("-shared", "-fPIC", "-O3", "-march=native", "-ffp-contract=off")
PORTABLE = ("-shared", "-fPIC", "-O3", "-ffp-contract=off")  # for a compiler that does not know -march=native
SOURCE = "functions.c"  # the C file inside a build folder
STALE = 24 * 3600.0  # s: a build folder this old belongs to a builder that was killed


def key(source: str, compiler: str) -> str:
    """The cache key of a library: what its machine code depends on (the C source, and ``flavour``)."""
    return hashlib.sha256(f"{source}\0{flavour(compiler)}".encode()).hexdigest()[:32]


def flavour(compiler: str) -> str:
    """What a library's machine code depends on besides its source: the compiler, its flags and, for -march=native,
    the processor (a cache shared by machines of different processors keeps one library each)."""
    return f"{compiler} {' '.join(FLAGS)}\0{processor()}"


@functools.cache
def processor() -> str:
    """What -march=native compiles for: the processor's model and instruction-set flags (Linux's /proc/cpuinfo),
    else what the platform module knows."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        lines = []
    described = [line for line in lines if line.split(":")[0].strip() in ("model name", "flags", "Features", "CPU part")]
    return "\n".join(dict.fromkeys(described)) or f"{platform.machine()} {platform.processor()}"


def exposure(path: Path | int) -> str | None:
    """Why someone other than this user could have written ``path`` (or the open file descriptor), or None when no one
    could."""
    info = os.stat(path)
    if info.st_uid != os.geteuid():
        return f"belongs to user id {info.st_uid}"
    if info.st_mode & 0o022:
        return "is writable by group or others"
    return None


def hash_file(library: Path) -> Path:
    """Where the SHA-256 of ``library`` is recorded."""
    return library.with_name(library.name + ".sha256")


def sha256(path: Path) -> str:
    """Hex SHA-256 of a file's bytes."""
    with path.open("rb") as stream:
        return hashlib.file_digest(stream, "sha256").hexdigest()


def intact(library: Path) -> bool:
    """Whether ``library`` and its hash file are this user's alone and the library's SHA-256 is the recorded one."""
    record = hash_file(library)
    try:
        if exposure(library) or exposure(record) or not library.is_file():
            return False
        return record.read_text().strip() == sha256(library)
    except (OSError, UnicodeDecodeError):
        return False


@contextlib.contextmanager
def locked(folder: Path):
    """Hold the cache folder's build lock (waiting for a builder that holds it)."""
    descriptor = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX)
        yield
    finally:
        os.close(descriptor)  # releases the lock


def build(source: Path, library: Path, compiler: str) -> None:
    """Compile the C file ``source`` into ``library`` and record its hash; each file replaced whole or not at all.

    The caller holds the folder's lock."""
    with tempfile.TemporaryDirectory(dir=library.parent) as work:
        partial = Path(work) / library.name
        try:
            subprocess.run([compiler, *FLAGS, str(source), "-o", str(partial)], check=True, capture_output=True)
        except subprocess.CalledProcessError as refused:
            if b"march" not in refused.stderr:  # another failure: compiling it again would fail again
                raise
            subprocess.run([compiler, *PORTABLE, str(source), "-o", str(partial)], check=True, capture_output=True)
        os.chmod(partial, 0o700)
        record = Path(work) / hash_file(library).name
        record.write_text(sha256(partial) + "\n")
        os.chmod(record, 0o600)
        os.replace(partial, library)
        os.replace(record, hash_file(library))


def build_unless_intact(source: Path, library: Path, compiler: str) -> None:
    """Under the folder's lock: build ``library`` unless a builder finished it meanwhile."""
    with locked(library.parent):
        if not intact(library):
            build(source, library, compiler)


def _remove_stale(folder: Path, now: float) -> None:
    """Build folders left by builders that were killed (a live builder's folder is minutes old, not a day)."""
    for stale in folder.glob("build-*"):
        with contextlib.suppress(OSError):
            if now - stale.stat().st_mtime > STALE:
                shutil.rmtree(stale)


def main(arguments: list[str]) -> None:
    """The detached builder: ``BUILD_FOLDER LIBRARY COMPILER``; removes BUILD_FOLDER when done, whatever happens."""
    work, library, compiler = Path(arguments[0]), Path(arguments[1]), arguments[2]
    for number in (signal.SIGTERM, signal.SIGHUP):  # a polite kill still cleans up (SIGKILL: _remove_stale)
        signal.signal(number, lambda *_: sys.exit(1))
    try:
        build_unless_intact(work / SOURCE, library, compiler)
        _remove_stale(library.parent, time.time())
    except (OSError, subprocess.CalledProcessError):
        pass  # nothing was put in place; the next run evaluates without the library and tries again
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main(sys.argv[1:])
