"""The output folder as one unit: one run's complete set of artifacts, or the previous set, never a mix.

A run locks the folder (an flock on a hidden file beside it) for its whole length,
so a second run into the same folder stops at once. Its artifacts are written into
a new hidden folder beside the output folder with a manifest (``.armcal-set.json``:
the run's id and each file's SHA-256), then the two folders are exchanged in one
atomic rename (Linux renameat2 RENAME_EXCHANGE; elsewhere two renames, and a
crash between them is repaired by the next run) and the old set is deleted: no
stale file survives beside a new set. A folder is replaced only with ``force``,
only when it holds an armcal set (or nothing), and never when it holds an input
of the run. The run's id is a hash of what determines the results (armcal's
version and the input files), stamped into every artifact, so ``armcal report``
can tell a set from a mix.
"""

from __future__ import annotations

import ctypes
import errno
import fcntl
import hashlib
import json
import os
import shutil
import stat
import tempfile
from collections.abc import Iterable
from contextlib import contextmanager
from pathlib import Path

from armcal import __version__
from armcal.support.errors import UserError
from armcal.support.fileio import current_umask, output_folder

MANIFEST = ".armcal-set.json"
ARTIFACT_SUFFIXES = (".json", ".yaml", ".html", ".pdf", ".svg")  # what an armcal set holds (legacy sets had no manifest)
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def run_id(inputs: Iterable[Path]) -> str:
    """16 hex digits of SHA-256 over armcal's version and the input files' contents."""
    digest = hashlib.sha256(f"armcal {__version__}".encode())
    for path in inputs:
        digest.update(hashlib.sha256(Path(path).read_bytes()).digest())
    return digest.hexdigest()[:16]


def stamp_svg(svg: str, identifier: str) -> str:
    """An SVG plot carrying the run's id (an XML comment after its declaration)."""
    head, newline, rest = svg.partition("\n")
    comment = f"<!-- armcal run {identifier} -->"
    return f"{head}\n{comment}\n{rest}" if head.startswith("<?xml") and newline else f"{comment}\n{svg}"


@contextmanager
def output_set(folder: Path, inputs: Iterable[Path], force: bool, names: Iterable[str] = (),
               replaced: str = "the certificate and the whole output set", main: str = "certificate.pdf"):
    """Lock ``folder`` for a run and check it may take a new set; yields ``publish(files, identifier)``.

    ``names``: files an earlier set written before manifests existed may hold besides ARTIFACT_SUFFIXES (e.g.
    montecarlo.csv); ``replaced`` and ``main`` word the refusal without ``force`` ("MAIN exists; use --force to
    replace REPLACED")."""
    folder = output_folder(folder).absolute()
    _refuse_inputs(folder, inputs)
    with _locked(folder):
        try:
            _repair(folder)
            _check_replaceable(folder, force, frozenset(names), replaced, main)
        except OSError as exc:  # a folder that may not be read, a leftover that cannot be moved back
            raise UserError(f"cannot write the output set into {folder}: {exc.strerror or exc}") from None
        yield lambda files, identifier: _publish(folder, files, identifier)


def replace_in_set(folder: Path, files: dict[str, bytes | str]) -> list[Path]:
    """The set in ``folder`` with ``files`` written in (``armcal report``): published anew as one unit."""
    folder = Path(folder).absolute()
    with _locked(folder):
        manifest = read_manifest(folder)
        kept = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file() and p.name != MANIFEST and p.name not in files}
        _publish(folder, {**kept, **files}, manifest["run_id"] if manifest else "")
    return [folder / name for name in files]


def read_manifest(folder: Path) -> dict | None:
    """The manifest of the set in ``folder`` ({run_id, files: {name: sha256}}), None for a legacy set."""
    path = Path(folder) / MANIFEST
    if not path.is_file():
        return None
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
        files = manifest["files"]
        if not isinstance(manifest["run_id"], str) or not all(isinstance(v, str) for v in files.values()):
            raise TypeError
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        raise UserError(f"{path}: not a readable armcal manifest; the set cannot be checked") from None
    return manifest


def check_set(folder: Path, names: Iterable[str]) -> str | None:
    """The run id of ``folder``'s set after checking that the files ``names`` are the ones its run wrote."""
    manifest = read_manifest(folder)
    if manifest is None:
        return None
    for name in names:
        path = Path(folder) / name
        recorded = manifest["files"].get(name)
        if recorded is None or not path.is_file() or _sha256(path) != recorded:
            raise UserError(
                f"{path} is not the file run {manifest['run_id']} wrote into {folder}: the folder mixes two runs; "
                "run `armcal run` again to get one complete set"
            )
    return manifest["run_id"]


def _refuse_inputs(folder: Path, inputs: Iterable[Path]) -> None:
    """An input of the run is never replaced: it may not lie in the output folder."""
    target = folder.resolve()
    for path in inputs:
        resolved = Path(path).resolve()
        if resolved == target or target in resolved.parents:
            raise UserError(f"the output folder {folder} holds {path}, an input of this run; choose another --out")


@contextmanager
def _locked(folder: Path):
    """Hold an exclusive lock on ``folder`` (a hidden file beside it, removed when done)."""
    lock_path = folder.parent / f".{folder.name}.lock"
    try:
        folder.parent.mkdir(parents=True, exist_ok=True)
        handle = open(lock_path, "a")
    except OSError as exc:
        raise UserError(f"cannot write into {folder.parent}: {exc.strerror}") from None
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            if os.stat(lock_path).st_ino != os.fstat(handle.fileno()).st_ino:  # a finishing run removed it meanwhile
                raise BlockingIOError
        except (BlockingIOError, FileNotFoundError):
            handle.close()
            raise UserError(f"another armcal run is writing into {folder}; wait for it or choose another --out") from None
        try:
            yield
        finally:
            lock_path.unlink(missing_ok=True)  # while still holding it: a later run creates its own
    finally:
        handle.close()


def _siblings(folder: Path, kind: str) -> list[Path]:
    return sorted(folder.parent.glob(f".{folder.name}.{kind}-*"))


def _repair(folder: Path) -> None:
    """Undo what a run killed mid-way left: restore a set moved aside, remove half-written ones."""
    if not folder.exists():
        previous = _siblings(folder, "old")
        if previous:
            os.rename(previous[-1], folder)
    for leftover in _siblings(folder, "new") + _siblings(folder, "old"):
        shutil.rmtree(leftover, ignore_errors=True)


def _check_replaceable(folder: Path, force: bool, names: frozenset = frozenset(),
                       replaced: str = "the certificate and the whole output set", main: str = "certificate.pdf") -> None:
    if not os.path.lexists(folder):
        return
    entries = sorted(p.name for p in folder.iterdir())
    if not entries:
        return
    foreign = [n for n in entries if not _is_artifact(folder / n, names)]
    if foreign and not (folder / MANIFEST).is_file():
        shown = ", ".join(foreign[:5]) + (" ..." if len(foreign) > 5 else "")
        raise UserError(f"{folder} holds files that are not an armcal output set ({shown}); choose an empty or new --out")
    if not force:
        existing = main if (folder / main).exists() else entries[0]
        raise UserError(f"{folder / existing} exists; use --force to replace {replaced}")


def _is_artifact(path: Path, names: frozenset = frozenset()) -> bool:
    return path.is_file() and not path.is_symlink() and (path.suffix in ARTIFACT_SUFFIXES or path.name in names or path.name == MANIFEST)


def _publish(folder: Path, files: dict[str, bytes | str], identifier: str) -> list[Path]:
    """Write the set into a new folder beside ``folder``, then exchange the two."""
    try:
        staging = Path(tempfile.mkdtemp(dir=folder.parent, prefix=f".{folder.name}.new-"))
    except OSError as exc:
        raise UserError(f"cannot write into {folder.parent}: {exc.strerror}") from None
    try:
        manifest = {"run_id": identifier, "files": {}}
        for name, content in files.items():
            data = content.encode("utf-8") if isinstance(content, str) else content
            (staging / name).write_bytes(data)
            os.chmod(staging / name, _kept_mode(folder / name, 0o666))
            manifest["files"][name] = hashlib.sha256(data).hexdigest()
        (staging / MANIFEST).write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n", encoding="utf-8")
        os.chmod(staging / MANIFEST, _kept_mode(folder / MANIFEST, 0o666))
        os.chmod(staging, _kept_mode(folder, 0o777))  # mkdtemp makes 0700: the replaced folder's mode, else the usual
        _swap_in(staging, folder)
    except OSError as exc:
        shutil.rmtree(staging, ignore_errors=True)
        raise UserError(f"cannot write the output set into {folder}: {exc.strerror or exc}; the previous set is unchanged") from None
    return [folder / name for name in files]


def _kept_mode(replaced: Path, usual: int) -> int:
    """The permission bits of the file or folder a new one replaces (not through a link), else ``usual`` less the
    umask: --force replaces the content, not who may read it."""
    try:
        info = os.lstat(replaced)
    except FileNotFoundError:
        return usual & ~current_umask()
    same_kind = stat.S_ISDIR(info.st_mode) if usual == 0o777 else stat.S_ISREG(info.st_mode)
    return stat.S_IMODE(info.st_mode) & 0o777 if same_kind else usual & ~current_umask()


def _swap_in(staging: Path, folder: Path) -> None:
    """``staging`` becomes ``folder``; the set that was there is deleted."""
    if not folder.exists():
        os.rename(staging, folder)
        return
    if _exchange(staging, folder):
        shutil.rmtree(staging, ignore_errors=True)  # now the previous set
        return
    aside = folder.parent / f".{folder.name}.old-{os.urandom(4).hex()}"
    os.rename(folder, aside)
    os.rename(staging, folder)
    shutil.rmtree(aside, ignore_errors=True)


def _exchange(a: Path, b: Path) -> bool:
    """Swap two folders atomically where the system can (Linux renameat2); False where it cannot."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    if renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP):
        return False
    raise OSError(code, os.strerror(code))


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()

