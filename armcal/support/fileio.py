"""Input files are read bounded, from ordinary files only; output files are written whole or not at all.

An output is only ever a regular file: a device (/dev/null), a pipe or /proc/self/fd/1 in its place is refused, with
--force too (os.replace would put a regular file where the device node was). Nothing is written under /dev, /proc or
/sys, by the path as given, with its folders' links resolved, or through any link on its way (``--out /dev/stdout``
with standard output redirected to a file would otherwise replace the system's link by a file). A link at an output
is never written through: with --force the link itself is replaced by the file and its target left as it was, unless
the target is no regular file or lies in those folders (then it is refused, --force or not). A file that is an input
of the command, by any name (a link, a hard link: the same device and inode), is never replaced. A failure to write
(a read-only file system, a full disk, a parent that is a file, a name too long) is one user error naming the file,
never a traceback.

A spec may name regular files anywhere it can read, except under /proc, /sys and
/dev (pseudo-files that read as endless streams, devices or the process's own
environment); each kind of input has a size limit (INPUT_LIMITS), checked before
it is read, so /dev/zero, a FIFO or a runaway file ends with a clear error.
"""

from __future__ import annotations

import errno
import os
import re
import stat
import tempfile
from pathlib import Path

from armcal.support.errors import UserError
from armcal.support.units import is_number


KiB, MiB = 1 << 10, 1 << 20
INPUT_LIMITS = {"spec": 256 * KiB, "data": 64 * MiB, "truth": 16 * MiB, "urdf": 16 * MiB}  # a spec parses at ~50 KiB/s at worst
PSEUDO_FILE_SYSTEMS = (Path("/proc"), Path("/sys"), Path("/dev"))


def read_input(path: Path, kind: str) -> bytes:
    """The bytes of an input file of ``kind`` (INPUT_LIMITS): a regular file, not a pseudo-file, within its limit."""
    path = Path(path)
    what = f"{path}: cannot read the {kind} file"
    try:
        resolved = _resolved(path)
        for root in PSEUDO_FILE_SYSTEMS:
            if resolved == root or root in resolved.parents:
                raise UserError(f"{what}: it lies under {root}, which holds no input files")
        with open(path, "rb", opener=lambda name, flags: os.open(name, flags | os.O_NONBLOCK)) as stream:
            info = os.fstat(stream.fileno())
            if not stat.S_ISREG(info.st_mode):
                raise UserError(f"{what}: it is not a regular file")
            limit = INPUT_LIMITS[kind]
            if info.st_size > limit:
                raise UserError(f"{what}: it has {_size(info.st_size)}, more than the {_size(limit)} a {kind} file may have")
            return stream.read(limit + 1)[:limit]
    except FileNotFoundError:
        raise UserError(f"{what}: there is no such file") from None
    except IsADirectoryError:
        raise UserError(f"{what}: it is a folder") from None
    except OSError as exc:
        raise UserError(f"{what} ({exc.strerror or exc})") from None


def _size(count: int) -> str:
    return f"{count / MiB:.3g} MiB" if count >= MiB else f"{count / KiB:.3g} KiB"


def read_regular(path: Path, limit: int, shown: Path) -> bytes | None:
    """The bytes of a regular file of at most ``limit`` bytes; None if there is none. A FIFO or device is refused, never opened to read."""
    try:
        handle = os.open(path, os.O_RDONLY | os.O_NONBLOCK)  # O_NONBLOCK: opening a FIFO does not wait for a writer
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as exc:
        raise UserError(f"{shown}: cannot read the file ({getattr(exc, 'strerror', None) or exc})") from None
    if not stat.S_ISREG(os.fstat(handle).st_mode):
        os.close(handle)
        raise UserError(f"{shown} is not a regular file; refused")
    with os.fdopen(handle, "rb") as stream:
        data = stream.read(limit + 1)
    if len(data) > limit:
        raise UserError(f"{shown} is larger than {limit // MiB} MiB; refused")
    return data


def decoded(data: bytes, shown: Path) -> str:
    """UTF-8 text, else a UserError naming the file and the first bad byte."""
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise UserError(f"{shown}: the file is not UTF-8 text (byte {exc.start})") from None


def output_folder(path: Path) -> Path:
    """``path``, checked as a folder to write into: a user error if a file, a dangling link or something
    unreadable is in the way (a link to nothing is never followed: armcal would create a folder where it points),
    or if it lies under /dev, /proc or /sys."""
    path = Path(path)
    try:
        _refuse_pseudo(path)
        dangling = _dangling_link_on_the_way(path)
        if dangling is not None:
            raise UserError(f"{dangling} is a link to {os.readlink(dangling)}, which does not exist; armcal does not follow it: "
                            "remove the link or choose another --out")
        blocked = next((p for p in (path, *path.parents) if p.exists() and not p.is_dir()), None)
    except OSError as exc:  # a folder that may not be searched, a name too long, a loop of links
        raise UserError(f"cannot write into {path}: {exc.strerror or exc}") from None
    if blocked is not None:
        raise UserError(f"{blocked} is a file; the output needs a folder there")
    return path


def _dangling_link_on_the_way(folder: Path) -> Path | None:
    """The first of ``folder`` and its parents that is a link to nothing, if any."""
    return next((p for p in reversed((folder, *folder.parents)) if p.is_symlink() and not p.exists()), None)


def refuse_replacing(targets, inputs, force: bool) -> None:
    """Nothing existing is replaced without ``force``, an input of the command never is, and no two of the files one
    command writes are one file (``plan --out x.json`` would write its CSV, then its JSON over it)."""
    try:
        sources = {_resolved(p) for p in inputs}
    except OSError as exc:
        raise UserError(f"cannot read {exc.filename}: {exc.strerror}") from None
    inodes = {key for key in map(_inode, inputs) if key is not None}
    distinct_outputs(targets)
    for target in map(Path, targets):
        try:
            if _resolved(target) in sources or _inode(target) in inodes:
                raise UserError(f"{target} is an input of this command (the file itself, a link to it or a hard link); "
                                "it is never replaced (choose another --out)")
            if target.is_dir():
                raise UserError(f"{target} is a folder; give the name of the file to write")
            _refuse_special(target)
            if target.is_symlink() and not target.exists() and not force:
                raise UserError(f"{target} is a link to {os.readlink(target)}, which does not exist; armcal never follows it: "
                                "use --force to replace the link itself with the file, or choose another --out")
            if os.path.lexists(target) and not force:
                raise UserError(f"{target} exists; use --force to replace it")
        except OSError as exc:  # a name too long, a loop of links, a folder that may not be searched
            raise UserError(f"cannot write {target}: {exc.strerror or exc}") from None


def distinct_outputs(targets) -> None:
    """A user error when two of the files one command writes are one file: the same path spelled twice
    (``x.json``, ``./x.json``), one a link to the other, two hard links, or names that differ only in case (one
    file on macOS and Windows)."""
    seen: dict = {}
    for target in map(Path, targets):
        try:
            keys = [("path", str(_resolved(target)).casefold())]
            if target.exists():
                info = target.stat()
                keys.append(("inode", info.st_dev, info.st_ino))
        except OSError as exc:
            raise UserError(f"cannot write {target}: {exc.strerror or exc}") from None
        for key in keys:
            other = seen.setdefault(key, target)
            if other is not target:
                raise UserError(f"{other} and {target} are one file (the same path, a link to it, or a name differing only "
                                "in case): this command writes both, one would overwrite the other; choose another --out")


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` so that readers see the old file or the new one, never half of it."""
    write_bytes_atomic(path, text.encode("utf-8"))


def _inode(path) -> tuple[int, int] | None:
    """(device, inode) of the file at ``path`` (links followed), None when there is none."""
    try:
        info = Path(path).stat()
    except (OSError, ValueError):
        return None
    return info.st_dev, info.st_ino


def _refuse_special(path: Path) -> None:
    """A user error when ``path`` lies under /dev, /proc or /sys (_refuse_pseudo), or something other than a
    regular file (a device, a pipe, a socket) stands at ``path`` or at the end of the link standing there."""
    _refuse_pseudo(path)
    if path.exists() and not path.is_file() and not path.is_dir():
        raise UserError(f"{path} is not a regular file (a device, a pipe or a socket); armcal writes only regular files, "
                        "--force or not")


_MAX_HOPS = 40  # links followed in one path, as Linux does before ELOOP


def _refuse_pseudo(path: Path) -> None:
    """A user error when an output at ``path`` would be written under /dev, /proc or /sys: the path as given, with
    its folders' links resolved, or any place a chain of links standing at it passes through (a link to
    /proc/self/fd/1 resolves to whatever file standard output is, so the final resolved path alone says nothing)."""
    for place in _places(Path(path)):
        root = next((r for r in PSEUDO_FILE_SYSTEMS if place == r or r in place.parents), None)
        if root is not None:
            shown = "" if place == Path(os.path.abspath(path)) else f" (it leads to {place})"
            raise UserError(f"{path} lies under {root}{shown}; armcal writes no output there (no device, process or "
                            "kernel file is replaced), --force or not: choose a file elsewhere")


def _places(path: Path) -> list[Path]:
    """``path`` as given (absolute), its folders resolved, and every hop of the chain of links standing there."""
    places, current = [Path(os.path.abspath(path)), _resolved(path)], Path(os.path.abspath(path))
    for _ in range(_MAX_HOPS):
        folder = _resolved(current.parent)
        places.append(folder / current.name)
        if not (folder / current.name).is_symlink():
            break
        current = Path(os.path.abspath(folder / os.readlink(folder / current.name)))
        places.append(current)
    return places


def _resolved(path) -> Path:
    """``Path(path).resolve()``; a loop of links is an OSError (Python 3.11 raises RuntimeError)."""
    try:
        return Path(path).resolve()
    except RuntimeError:
        raise OSError(errno.ELOOP, os.strerror(errno.ELOOP), str(path)) from None


def write_bytes_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` whole or not at all, as a regular file (module docstring)."""
    path = Path(path)
    temporary = None
    try:
        _refuse_special(path)
        dangling = _dangling_link_on_the_way(path.parent)
        if dangling is not None:
            raise UserError(f"cannot write {path}: {dangling} is a link to {os.readlink(dangling)}, which does not exist; "
                            "armcal does not follow it: remove the link or choose another --out")
        path.parent.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
        replaced = path.stat().st_mode & 0o777 if path.is_file() else 0o666 & ~current_umask()
        os.chmod(temporary, replaced)  # mkstemp makes 0600: the replaced file's mode, else the usual one
        os.replace(temporary, path)
    except OSError as exc:
        _remove(temporary)
        raise UserError(f"cannot write {path}: {exc.strerror or exc}") from None
    except BaseException:
        _remove(temporary)
        raise


def _remove(temporary: str | None) -> None:
    if temporary is not None:
        Path(temporary).unlink(missing_ok=True)


FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r", "\n")  # a spreadsheet reads a cell starting so as a formula (OWASP)


def _formula_like(text: str) -> bool:
    """A text starting as a formula, also behind leading quotes (so that spreadsheet_text undoes spreadsheet_safe)."""
    return text.lstrip("'").startswith(FORMULA_STARTS)


def spreadsheet_safe(text: str) -> str:
    """A text cell for a CSV file that a spreadsheet shows as text: one starting as a formula gets a leading quote
    (as does one already so quoted, so that reading it back, spreadsheet_text, gives the text whole)."""
    return "'" + text if _formula_like(text) else text


def spreadsheet_text(cell: str) -> str:
    """A text cell as armcal wrote it (spreadsheet_safe) read back: the leading quote of a formula-like text removed."""
    return cell[1:] if cell.startswith("'") and _formula_like(cell[1:]) else cell


PLAIN = re.compile(r"(?:[^=+\-@\t\r\n',\"][^,\"\r\n]*)?")  # a cell neither formula-like nor to be quoted: written as it is


def csv_text(rows) -> str:
    """The text of a CSV file armcal writes (``rows``: the header, then one list of cells a row): every CSV armcal
    writes comes from here, so each text cell passes spreadsheet_safe (a cell that is a number by units.parse_number,
    such as -1.5, is a number, not a formula) and a cell holding a comma, quote or line break is quoted (RFC 4180;
    csv.writer leaves a lone CR unquoted), not a new column or row. Most cells (a positive number, a name) are PLAIN,
    decided by one match (a run's residuals.csv holds some 10^5 cells)."""
    lines = []
    for row in rows:
        cells = [text if PLAIN.fullmatch(text := str(cell)) else _cell(text) for cell in row]
        lines.append(",".join(cells))
    return "".join(line + "\n" for line in lines)


def _cell(text: str) -> str:
    """A cell that is not PLAIN: a number as it is, else spreadsheet_safe; quoted when it holds a comma, quote or line
    break."""
    cell = text if is_number(text) else spreadsheet_safe(text)
    return f'"{cell.replace(chr(34), chr(34) * 2)}"' if any(s in cell for s in ',"\r\n') else cell


def current_umask() -> int:
    """The process's umask (read by setting it and back)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask
