"""Compiled measurement functions, cached across runs.

All functions of a problem are generated as C in one file and compiled once by
the system's C compiler; the shared object is kept under a hash of the functions'
serialized graphs, CasADi's version (together they fix the C source), the compiler,
its flags and the processor (builder.py compiles for this one), so it is keyed on what its machine code depends on, and a run that
finds its library generates no C at all. Values a user edits often (noise, nominal values, limits, data) are
inputs of the functions or never enter them, so editing them reuses the library;
a change of structure (another robot, instrument, key or candidate effect) builds
another. Without a C compiler CasADi's virtual machine evaluates them.

When the library is not built yet, $ARMCAL_COMPILE says what to do:

- ``auto`` (the default): evaluate with CasADi's virtual machine (the same numbers, bit for
  bit: builder.FLAGS) and build the library in the background once the functions have done
  the work that pays for the compile (``BREAK_EVEN``), counted across runs in the cache: a
  short job (a test's, a one-off candidate structure's) is done before a compile would
  have paid, a long one or a spec run again and again gets its library;
- ``now``: compile at once and load the library; a compile that waits on another
  builder of the same cache waits for it rather than building the same file twice;
- ``background``: evaluate with the virtual machine at once and leave the compile to a
  detached process (builder.py) at once, so the first run pays no compile and later runs
  load the library;
- ``off``: never compile (the virtual machine only).

In ``auto`` and ``background`` a long run goes on in machine code once the library has
landed (``current``): the real UR10's first closed loop took 76 s of CPU in the
virtual machine alone, 11-13 s so with ``background``.

Loading a library runs its code, so the cache is private: its folder is made 0700,
each library is written 0700 with the SHA-256 of its bytes beside it
(``armcal_<digest>.so.sha256``), and a library is loaded only when it, its hash file
and the folder belong to this user, are writable by no one else and the hash matches.
A library that fails the check (truncated, garbage, replaced) is rebuilt; a cache
folder that fails it is not used: that process compiles into a private temporary
folder (``now``) or does not compile (``auto``, ``background``).
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import hashlib
import os
import shutil
import stat
import subprocess
import sys
import tempfile
import threading
import time
import weakref
from pathlib import Path

import casadi as ca

from armcal import __version__
from armcal.support import builder

MODES = ("auto", "now", "background", "off")
# ``auto`` builds a library once its functions have been evaluated BREAK_EVEN times each, counted in proportion to
# their sizes (instructions): gcc -O3 then has cost what the machine code would have saved so far. Measured on the
# shipped examples' libraries (2026-12-07, benchmarks/bench_break_even.py): gcc took 180-540 us per instruction, the
# virtual machine 7-12 ns per instruction and evaluation and machine code 2-5 times less, a break-even at 26,000-
# 88,000 evaluations; both sides scale with the processor's speed. Building at the break-even costs at most twice the
# better of never and at once in hindsight (the ski-rental bound); the low end of the range builds a spec run again
# and again a little sooner.
BREAK_EVEN = 40_000
WORK_RECORD = 4096  # bytes: a library's record of the work done in earlier runs (``.work``) is read and grown up to this
LONG = 100_000  # characters of C: more than a second of gcc -O3 (a ball-bar problem's functions: 0.5-1 MB, 4-9 s)
MESSAGE = "armcal: compiling the measurement functions for this robot and instrument{where} (once; later runs load them)"


def cache_dir() -> Path:
    """$ARMCAL_CACHE, else ~/.cache/armcal."""
    return Path(os.environ.get("ARMCAL_CACHE") or Path.home() / ".cache" / "armcal")


def compile_mode() -> str:
    """$ARMCAL_COMPILE: auto (default), now, background or off (module docstring)."""
    mode = os.environ.get("ARMCAL_COMPILE") or "auto"
    if mode not in MODES:
        _say_once(f"armcal: ARMCAL_COMPILE={mode!r} is not one of {', '.join(MODES)}; compiling when it pays (auto)")
        return "auto"
    return mode


def compiled(functions: list[ca.Function], identity: str | None = None) -> list[ca.Function]:
    """The same functions, compiled to machine code, or as given (evaluated by CasADi's virtual machine) when
    there is no compiler, $ARMCAL_COMPILE is off, or it is auto or background and the library is not built yet.

    The library is keyed on the generated C source, or on ``identity`` (a canonical description of what
    defines the functions) when one is given."""
    mode = compile_mode()
    compiler = shutil.which(os.environ.get("CC", "cc")) or shutil.which("gcc")
    if compiler is None or not functions or mode == "off":
        return functions
    names = [f"f{i}" for i in range(len(functions))]
    serialized = _serialized(functions, names)
    if identity is None:  # the serialized graph and CasADi's version determine the generated source
        digest = builder.key(f"{serialized}\0casadi {ca.__version__}", compiler)
    else:
        digest = hashlib.sha256(f"{identity}|armcal {__version__}|casadi {ca.__version__}|{builder.flavour(compiler)}".encode()).hexdigest()[:32]
    folder = _private_folder(mode)
    if folder is None:
        return functions
    library = folder / f"armcal_{digest}.so"
    if builder.intact(library):
        return _loaded(library, names)
    if library in _failed:  # a compile of it failed in this process: it would fail again
        return functions
    if mode == "auto":
        _awaited(functions, names, library, _pending(library, serialized, functions, names, compiler))
        return functions
    source = _source(serialized, functions, names)
    if mode == "background":
        _start_builder(source, library, compiler)
        _awaited(functions, names, library)
        return functions
    try:
        if len(source) > LONG:
            _say_once(MESSAGE.format(where=""))
        with tempfile.TemporaryDirectory(dir=folder) as work:
            path = Path(work) / builder.SOURCE
            _write_source(path, source)
            builder.build_unless_intact(path, library, compiler)
    except (OSError, subprocess.CalledProcessError):
        _failed.add(library)
        return functions
    return _loaded(library, names)


_failed: set[Path] = set()  # libraries whose compile failed in this process (no compiler, a full disk, ...)


CHECK = 0.5  # s between two looks for a library being built in the background (a look hashes it: about a millisecond)


def current(function: ca.Function, points: int = 0) -> ca.Function:
    """``function``, or its compiled twin once the background builder has put its library in place; ``points``: the
    evaluations the caller is about to make (``auto`` counts them towards the library's break-even)."""
    awaited = _awaiting.get(function)
    return function if awaited is None else awaited[0].twin(awaited[1], function, points)


class _Pending:
    """An ``auto`` library not built yet, one per library and process: what building it takes, and the work its
    functions have done (instructions evaluated) here and in earlier runs (its .work record). _COUNTING guards it."""

    def __init__(self, library: Path, serialized: str, sizes: list[int], names: list[str], compiler: str):
        self.library, self.serialized, self.names, self.compiler = library, serialized, names, compiler
        self.sizes, self.needed = sizes, BREAK_EVEN * sum(sizes)
        self.done, self.earlier = 0.0, _work_done(library)
        self.started = False

    def count(self, index: int, points: int, functions: list[weakref.ref]) -> None:
        """Count ``points`` evaluations of function ``index``; at the break-even, start the build from ``functions``
        (the ones being evaluated: their source is the library's)."""
        self.done += points * self.sizes[index]
        if self.started or self.done + self.earlier < self.needed:
            return
        alive = [f() for f in functions]
        if any(f is None for f in alive):  # a set being dropped: the next evaluation of a live one builds
            return
        self.started = True  # one attempt a process, as _start_builder's
        if builder.intact(self.library) or _start_builder(_source(self.serialized, alive, self.names), self.library, self.compiler):
            with contextlib.suppress(OSError):
                _work_record(self.library).unlink(missing_ok=True)  # counted; a build that fails is tried after another break-even

    def record(self) -> None:
        """Add this process's work to the library's .work record, for the next run's count; the record never grows
        past WORK_RECORD bytes, and one that is not this user's alone is replaced."""
        if self.started or self.done <= 0 or self.library.exists():
            return
        record, line = _work_record(self.library), f"{self.done:.0f}\n".encode()
        with contextlib.suppress(OSError):
            if os.path.lexists(record) and builder.exposure(record):
                record.unlink()
            handle = os.open(record, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW, 0o600)
            try:
                os.fchmod(handle, 0o600)
                if os.fstat(handle).st_size + len(line) <= WORK_RECORD:
                    os.write(handle, line)
            finally:
                os.close(handle)


_COUNTING = threading.Lock()  # the _Pending of every library: several problems and threads count into one
_unbuilt: dict[Path, _Pending] = {}  # auto libraries of this process by path


@atexit.register
def _record_work() -> None:
    with _COUNTING:
        for pending in list(_unbuilt.values()):
            pending.record()


def _forget_work() -> None:
    """In a forked child: the parent's work is the parent's to record."""
    global _COUNTING
    _COUNTING = threading.Lock()
    for pending in _unbuilt.values():
        pending.done = 0.0


os.register_at_fork(after_in_child=_forget_work)


class _Awaited:
    """A library built in the background for functions the virtual machine evaluates meanwhile (by name: the
    functions are _awaiting's weak keys); ``pending``: an ``auto`` library, built once its work pays for it."""

    def __init__(self, functions: list[ca.Function], names: list[str], library: Path, pending: _Pending | None = None):
        self.names, self.library, self.pending = names, library, pending
        self.functions = [weakref.ref(f) for f in functions] if pending is not None else []
        self.loaded: list[ca.Function] | None = None  # [] when the library cannot be loaded
        self.next_look = 0.0
        self.lock = threading.Lock()

    def twin(self, index: int, function: ca.Function, points: int = 0) -> ca.Function:
        if self.pending is not None:
            with _COUNTING:
                self.pending.count(index, points, self.functions)
        with self.lock:  # also before this process starts a build: another process (a pool's worker) may have built it
            if self.loaded is None and time.monotonic() >= self.next_look:
                self.next_look = time.monotonic() + CHECK
                if builder.intact(self.library):
                    try:
                        self.loaded = _loaded(self.library, self.names)
                    except RuntimeError:  # e.g. a cache on a noexec mount: the run goes on as it started
                        self.loaded = []
                        _say_once("armcal: the compiled functions cannot be loaded; evaluating with CasADi's virtual machine")
            return self.loaded[index] if self.loaded else function


def _awaited(functions: list[ca.Function], names: list[str], library: Path, pending: _Pending | None = None) -> None:
    """Remember each of ``functions`` as awaiting ``library``, for as long as it lives."""
    awaited = _Awaited(functions, names, library, pending)
    for index, function in enumerate(functions):
        _awaiting[function] = (awaited, index)


def _pending(library: Path, serialized: str, functions: list[ca.Function], names: list[str], compiler: str) -> _Pending:
    """The library's _Pending in this process."""
    with _COUNTING:
        if library not in _unbuilt:
            _unbuilt[library] = _Pending(library, serialized, [_instructions(f) for f in functions], names, compiler)
        return _unbuilt[library]


_awaiting: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # a function handed out -> (its library's _Awaited, index)


def _instructions(function: ca.Function) -> int:
    """The size of ``function``'s work per evaluation: its virtual machine's instructions."""
    return max(int(function.n_instructions()), 1)


def _work_record(library: Path) -> Path:
    """Where the work done by earlier runs with ``library`` missing is recorded (instructions evaluated, a line a run)."""
    return library.with_name(library.stem + ".work")


def _work_done(library: Path) -> float:
    """The work the library's record holds: its complete lines' numbers, within its first WORK_RECORD bytes (0 when
    there is none, or it is not a regular file of this user's alone)."""
    try:
        handle = os.open(_work_record(library), os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except OSError:
        return 0.0
    with os.fdopen(handle, "rb") as stream:
        if not stat.S_ISREG(os.fstat(handle).st_mode) or builder.exposure(handle):
            return 0.0
        lines = stream.read(WORK_RECORD).decode("ascii", errors="replace").split("\n")[:-1]  # the last: unfinished or ''
    return sum(float(line) for line in lines if line.isdigit())


def _loaded(library: Path, names: list[str]) -> list[ca.Function]:
    return [ca.external(name, str(library)) for name in names]


def _serialized(functions: list[ca.Function], names: list[str]) -> str:
    """SHA-256 of the functions' serialized graphs under their names: what their generated source depends on
    (besides CasADi's version), a fifth of the cost of generating it."""
    return hashlib.sha256("\0".join([*names, *(f.serialize() for f in functions)]).encode()).hexdigest()


def _source(serialized: str, functions: list[ca.Function], names: list[str]) -> str:
    """The C source of all functions, each under its name in ``names``; generated only for a library to build, and
    once per process for the same functions (``serialized``; 0.05-0.1 s of codegen each)."""
    if serialized not in _sources:
        if len(_sources) >= 16:
            _sources.pop(next(iter(_sources)))
        _sources[serialized] = _generated(functions, names)
    return _sources[serialized]


_sources: dict[str, str] = {}


def _generated(functions: list[ca.Function], names: list[str]) -> str:
    generator = ca.CodeGenerator(builder.SOURCE, {"with_header": False})
    for function, name in zip(functions, names):
        generator.add(_renamed(function, name))
    return generator.dump()


def _start_builder(source: str, library: Path, compiler: str) -> bool:
    """Leave the build of ``library`` to a detached process (once per library and process); say so once. Whether a
    builder started (or had started).

    ``sh`` starts the builder in the background and exits at once: the builder is nobody's child in this
    process (it is not waited for, its CPU time is not this process's), in a session of its own, so
    neither the end of this process nor Ctrl-C on it stops the build."""
    if library in _started:
        return True
    _started.add(library)  # one attempt a process: one that failed would fail again
    package_root = str(Path(__file__).resolve().parents[2])
    code = "import sys; sys.path.insert(0, sys.argv[1]); from armcal.support.builder import main; main(sys.argv[2:])"
    work = None
    try:
        work = Path(tempfile.mkdtemp(prefix="build-", dir=library.parent))  # 0700
        _write_source(work / builder.SOURCE, source)
        command = [sys.executable, "-I", "-c", code, package_root, str(work), str(library), compiler]
        subprocess.run(
            ["/bin/sh", "-c", '"$@" </dev/null >/dev/null 2>&1 &', "armcal-builder", *command],
            check=True, start_new_session=True, stdin=subprocess.DEVNULL,
        )
    except (OSError, subprocess.CalledProcessError):  # a full disk, a removed cache: the run goes on as it is
        if work is not None:
            shutil.rmtree(work, ignore_errors=True)
        return False
    if len(source) > LONG:
        _say_once(MESSAGE.format(where=" in the background"))
    return True


_started: set[Path] = set()


def _private_folder(mode: str = "now") -> Path | None:
    """The cache folder, created 0700; when the cache cannot be trusted, a private temporary folder (``now``) or
    None (``auto``, ``background``: evaluate without compiling)."""
    folder = cache_dir()
    try:
        _make_private(folder)
        problem = builder.exposure(folder)
    except OSError as error:
        problem = f"cannot be created ({error.strerror})"
    if problem is None:
        return folder
    instead = "compiling into a temporary folder" if mode == "now" else "evaluating without compiled code"
    _say_once(f"armcal: not using the compiled-code cache {folder}: it {problem}; {instead}")
    return _temporary_folder() if mode == "now" else None


def _make_private(folder: Path) -> None:
    """Create ``folder`` and its missing parents with mode 0700, whatever the umask."""
    for missing in reversed([f for f in (folder, *folder.parents) if not f.exists()]):
        try:
            os.mkdir(missing, 0o700)
        except FileExistsError:  # created meanwhile by another process
            pass


SOURCE_MODE = 0o644  # the generated C: readable, writable by its owner alone, whatever the umask


def _write_source(path: Path, text: str) -> None:
    """Write the generated C source as a new file of mode SOURCE_MODE (fchmod: the umask plays no part)."""
    handle = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), SOURCE_MODE)
    with os.fdopen(handle, "w", encoding="utf-8") as stream:
        os.fchmod(stream.fileno(), SOURCE_MODE)
        stream.write(text)


_exposure, _intact, _hash_file, _sha256 = builder.exposure, builder.intact, builder.hash_file, builder.sha256


def _build(functions: list[ca.Function], names: list[str], library: Path, compiler: str) -> None:
    """Compile the functions into ``library`` (under the folder's build lock) and record its hash."""
    with tempfile.TemporaryDirectory(dir=library.parent) as work:
        source = Path(work) / builder.SOURCE
        _write_source(source, _source(_serialized(functions, names), functions, names))
        with builder.locked(library.parent):
            builder.build(source, library, compiler)


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
