"""A git repository read as files, in Python: refs, loose and packed objects, a file at a revision.

git itself is never run, because any git command may start programs the repository's own
configuration names (core.fsmonitor, clean and smudge filters, hooks), and a spec's folder is
not trusted that far. Nor is a repository's content: every read (one ObjectStore, one ``file_at_revision``) is
bounded in memory and time, and a file that breaks a bound is refused as unreadable (RepositoryLimit, a
ValueError), never worked through:

- an object inflates to at most _MAX_OBJECT bytes, and its pack entry's (or loose header's) declared size must be
  the size it inflates to (a size is checked before anything is inflated);
- all inflated bytes of one read together (objects, deltas, every delta's result) stay below _MAX_READ, so a small
  pack of a large blob behind many deltas stops after a few of them;
- a delta chain is at most _MAX_DEPTH deep (git writes 50 unless told otherwise; an offset delta's base lies before
  it in the pack);
- a pack index must be a version 2 index whose fan-out table never decreases and whose size is exactly what the
  object count it declares needs; its pack must start with git's header and the same object count, every offset
  inside the pack; all indexes of a repository together are at most _MAX_INDEXES bytes;
- objects/info/alternates files are at most _MAX_ALTERNATES_BYTES each, name at most _MAX_ALTERNATES folders
  together and nest at most _ALTERNATES_DEPTH deep (git's own depth);
- one read ends after READ_SECONDS (a generous bound: a real read takes milliseconds), the alternates' resolution
  included.
"""

from __future__ import annotations

import hashlib
import io
import os
import re
import stat
import struct
import time
import zlib
from pathlib import Path

from armcal.support.errors import UserError

OBJECT_ID = re.compile(r"[0-9a-f]{40}|[0-9a-f]{64}")  # SHA-1 or SHA-256 repositories
UNREADABLE = (OSError, ValueError, IndexError, struct.error, zlib.error)
_MAX_OBJECT = 1 << 24  # bytes of one object: a spec is at most 256 KiB, commits and trees far smaller
_MAX_READ = 1 << 26  # bytes inflated by one read, all objects, deltas and delta results together
_MAX_CHAIN = 1000  # symbolic refs and tags followed before giving up
_MAX_DEPTH = 250  # deltas of one object (git's default depth is 50, --aggressive's was 250)
_MAX_INDEXES = 1 << 28  # bytes of a repository's pack indexes together (about ten million objects)
_MAX_IDS = 1000  # objects listed under one id prefix (more: the prefix is ambiguous anyway)
READ_SECONDS = 20.0  # wall time of one read
_MAX_ALTERNATES_BYTES = 4 << 10  # an objects/info/alternates file: a few folder names
_MAX_ALTERNATES = 16  # alternate object folders of one repository, all depths together
_ALTERNATES_DEPTH = 5  # alternates of alternates followed, as git does (link_alt_odb_entries)
_PACK_TYPES = {1: "commit", 2: "tree", 3: "blob", 4: "tag"}
_OFS_DELTA, _REF_DELTA = 6, 7


def repository(folder: Path) -> tuple[Path, Path] | None:
    """(work tree, git directory) of the innermost repository holding ``folder``: a .git folder or a gitdir file."""
    for top in (folder, *folder.parents):
        dot_git = top / ".git"
        if dot_git.is_file():
            dot_git = (top / read_bytes(dot_git).decode().removeprefix("gitdir:").strip()).resolve()
        if (dot_git / "HEAD").is_file():
            return top, dot_git
    return None


def common_dir(git_dir: Path) -> Path:
    """The folder holding branches and objects: the main repository's for a linked worktree."""
    pointer = git_dir / "commondir"
    return (git_dir / read_bytes(pointer).decode().strip()).resolve() if pointer.is_file() else git_dir


def resolve_head(git_dir: Path, common: Path, name: str = "HEAD") -> str | None:
    """The object id a ref names (HEAD, or refs/...), following symbolic refs to loose or packed refs; None when
    it names nothing (an unborn branch)."""
    for _ in range(_MAX_CHAIN):
        loose = (git_dir if name == "HEAD" else common) / name
        value = read_bytes(loose).decode().strip() if loose.is_file() else _packed_ref(common, name)
        if value is None or not value.startswith("ref:"):
            return value if value and OBJECT_ID.fullmatch(value) else None
        name = value.removeprefix("ref:").strip()
        if not name.startswith("refs/") or ".." in name.split("/"):
            return None
    return None


class RepositoryLimit(ValueError):
    """A repository file breaks a bound of the reader (module docstring): refused, not read further."""


class _Budget:
    """What one read may still inflate, and until when it may run."""

    def __init__(self):
        self.left, self.deadline = _MAX_READ, time.monotonic() + READ_SECONDS

    def spend(self, count: int, where: object) -> None:
        self.left -= count
        if self.left < 0:
            raise RepositoryLimit(f"{where}: reading it inflates more than {_MAX_READ >> 20} MiB (a delta chain of a "
                                  "large object?); refused")
        self.tick(where)

    def tick(self, where: object) -> None:
        if time.monotonic() > self.deadline:
            raise RepositoryLimit(f"{where}: reading the repository took more than {READ_SECONDS:g} s; refused")


def tree_path(path: Path, work_tree: Path) -> list[bytes]:
    """The components of a work tree's file's path in the repository's trees."""
    return [os.fsencode(p) for p in (*path.absolute().parent.resolve().relative_to(work_tree).parts, path.name)]


def file_at_revision(path: Path, revision: str) -> bytes:
    """The bytes of ``path``, a file of a git work tree, in the commit ``revision`` names: HEAD, a branch, a tag,
    a commit id or its unique prefix (4 hex digits or more), each optionally followed by ~N (N-th first-parent
    ancestor) and ^N (N-th parent) steps, as git reads them."""
    match = _REVISION.fullmatch(revision)
    if match is None:
        raise UserError(f"{path}@{revision}: '{revision}' is not a revision (HEAD, a branch, a tag or a commit id, then ~N or ^N)")
    try:
        found = repository(path.absolute().parent.resolve())
        if found is None:
            raise UserError(f"{path}@{revision}: {path} is not in a git repository")
        work_tree, git_dir = found
        common = common_dir(git_dir)
        store = ObjectStore(common)
        commit = _named_commit(store, git_dir, common, match["name"], f"{path}@{revision}")
        for step, count in re.findall(r"([~^])(\d*)", match["steps"]):
            commit = _ancestor(store, commit, step, int(count or 1), f"{path}@{revision}")
        parts = tree_path(path, work_tree)
        blob = blob_at(store, commit, parts)
        if blob is None:
            raise UserError(f"{path}@{revision}: the commit {commit.hex()[:12]} has no file {'/'.join(p.decode() for p in parts)}")
        _, content = store.read(blob)
    except UNREADABLE as error:
        raise UserError(f"{path}@{revision}: the repository could not be read ({error})") from None
    return content


_REVISION = re.compile(r"(?P<name>[A-Za-z0-9_.\-/]+?)(?P<steps>(?:[~^]\d*)*)")


def _named_commit(store: ObjectStore, git_dir: Path, common: Path, name: str, where: str) -> bytes:
    """The commit a name gives, looked up as git does: the ref itself, refs/, tags, branches, remotes, then an id
    prefix; an annotated tag is peeled to its commit."""
    if ".." in name.split("/"):
        raise UserError(f"{where}: '{name}' is not a revision")
    for ref in (name, f"refs/{name}", f"refs/tags/{name}", f"refs/heads/{name}", f"refs/remotes/{name}"):
        if ref == "HEAD" or ref.startswith("refs/"):
            oid = resolve_head(git_dir, common, ref)
            if oid is not None:
                return _peeled(store, bytes.fromhex(oid), where)
    candidates = store.expand(name.lower()) if re.fullmatch(r"[0-9a-fA-F]{4,64}", name) else []
    if len(candidates) > 1:
        raise UserError(f"{where}: the commit id prefix '{name}' is ambiguous ({len(candidates)} objects); give more digits")
    if not candidates:
        raise UserError(f"{where}: no branch, tag or commit '{name}' in this repository")
    return _peeled(store, candidates[0], where)


def _peeled(store: ObjectStore, oid: bytes, where: str) -> bytes:
    """The commit an object is, or an annotated tag points at."""
    for _ in range(_MAX_CHAIN):
        kind, data = store.read(oid)
        if kind == "commit":
            return oid
        if kind != "tag":
            raise UserError(f"{where}: {oid.hex()[:12]} is a {kind}, not a commit")
        oid = bytes.fromhex(data.split(b"\n", 1)[0].removeprefix(b"object ").decode())
    raise UserError(f"{where}: tags nested too deep")


def _ancestor(store: ObjectStore, commit: bytes, step: str, count: int, where: str) -> bytes:
    """``~count``: the first parent, count times; ``^count``: the count-th parent (^0 the commit itself)."""
    for _ in range(count if step == "~" else 1):
        if step == "^" and count == 0:
            return commit
        parents = [bytes.fromhex(line[7:].decode()) for line in store.read(commit)[1].split(b"\n\n", 1)[0].split(b"\n") if line.startswith(b"parent ")]
        wanted = 0 if step == "~" else count - 1
        if wanted >= len(parents):
            raise UserError(f"{where}: the commit {commit.hex()[:12]} has {len(parents)} parent(s)")
        commit = parents[wanted]
    return commit


def _packed_ref(common: Path, name: str) -> str | None:
    """The object id of ``name`` in packed-refs, if listed there."""
    packed = common / "packed-refs"
    for line in (read_bytes(packed).decode().splitlines() if packed.is_file() else []):
        oid, _, ref = line.partition(" ")
        if ref == name and not line.startswith(("#", "^")):
            return oid
    return None


def blob_at(store: ObjectStore, commit: bytes, parts: list[bytes]) -> bytes | None:
    """Id of the regular file at ``parts`` (path components) in the commit's tree, None if there is none."""
    kind, data = store.read(commit)
    first = data.split(b"\n", 1)[0]
    if kind != "commit" or not first.startswith(b"tree "):
        raise ValueError("not a commit")
    oid, mode = bytes.fromhex(first[5:].decode()), b"40000"
    for name in parts:
        if mode != b"40000":
            return None
        kind, data = store.read(oid)
        if kind != "tree":
            raise ValueError("not a tree")
        entry = _tree_entry(data, name, len(oid))
        if entry is None:
            return None
        mode, oid = entry
    return oid if mode in (b"100644", b"100755") else None


def _tree_entry(tree: bytes, name: bytes, id_size: int) -> tuple[bytes, bytes] | None:
    """(mode, id) of ``name`` in a tree object's entries (``<mode> <name>\\0<id>``)."""
    position = 0
    while position < len(tree):
        space = tree.index(b" ", position)
        end = tree.index(b"\0", space)
        if tree[space + 1 : end] == name:
            return tree[position:space], tree[end + 1 : end + 1 + id_size]
        position = end + 1 + id_size
    return None


def blob_id(content: bytes, id_size: int) -> bytes:
    """The id git gives a file with these bytes (no filters applied)."""
    return hashlib.new("sha1" if id_size == 20 else "sha256", b"blob %d\0" % len(content) + content).digest()


def _object_folders(objects: Path, budget: _Budget) -> list[Path]:
    """The repository's objects folder and those of its alternates: each line of an objects/info/alternates file is
    a folder (absolute, or relative to the objects folder holding the file; ``#`` starts a comment), whose own
    alternates are followed to git's depth of _ALTERNATES_DEPTH. Refused: a file above _MAX_ALTERNATES_BYTES, more
    than _MAX_ALTERNATES folders, deeper nesting (git ignores it; then an object would be missing)."""
    folders, pending = [objects], [(objects, 0)]
    while pending:
        folder, depth = pending.pop(0)
        listing = folder / "info" / "alternates"
        if not listing.is_file():
            continue
        if depth > _ALTERNATES_DEPTH:
            raise RepositoryLimit(f"{listing}: alternates nested more than {_ALTERNATES_DEPTH} deep (git's own limit); refused")
        for line in read_bytes(listing, _MAX_ALTERNATES_BYTES).decode().splitlines():
            budget.tick(listing)
            if not line.strip() or line.startswith("#"):
                continue
            alternate = (folder / line).resolve()
            if alternate in folders:
                continue
            if len(folders) > _MAX_ALTERNATES:
                raise RepositoryLimit(f"{listing}: more than {_MAX_ALTERNATES} alternate object folders; refused")
            folders.append(alternate)
            pending.append((alternate, depth + 1))
    return folders


class ObjectStore:
    """Loose and packed objects of a repository and of its alternates (objects/info/alternates); one store is one
    read, bounded as the module docstring says."""

    def __init__(self, common: Path):
        self.budget = _Budget()
        self.folders = _object_folders(common / "objects", self.budget)
        config = common / "config"
        sha256 = config.is_file() and re.search(rb"objectformat\s*=\s*sha256", read_bytes(config), re.IGNORECASE)
        self.id_size = 32 if sha256 else 20
        self.packs, total = [], 0
        for index_path in (i for f in self.folders for i in sorted((f / "pack").glob("*.idx"))):
            index = read_bytes(index_path, _MAX_INDEXES - total)
            total += len(index)
            self.packs.append((_checked_index(index, index_path, self.id_size), index_path.with_suffix(".pack")))
            self.budget.tick(index_path)
        self._checked_packs: set[Path] = set()

    def read(self, oid: bytes) -> tuple[str, bytes]:
        """(type, content) of an object."""
        self.budget.tick(f"object {oid.hex()}")
        for folder in self.folders:
            loose = folder / oid.hex()[:2] / oid.hex()[2:]
            if loose.is_file():
                return _loose(loose, self.budget)
        for index, pack in self.packs:
            offset = _pack_offset(index, oid)
            if offset is not None:
                return self._unpack(index, pack, offset)
        raise ValueError(f"object {oid.hex()} not found")

    def expand(self, prefix: str) -> list[bytes]:
        """The ids of every object whose hex id starts with ``prefix`` (lower-case hex, 4 digits or more; at most
        _MAX_IDS of them)."""
        found = set()
        for folder in self.folders:
            loose = folder / prefix[:2]
            if loose.is_dir():
                for f in loose.iterdir():
                    if f.name.startswith(prefix[2:]) and OBJECT_ID.fullmatch(prefix[:2] + f.name) and len(found) < _MAX_IDS:
                        found.add(bytes.fromhex(prefix[:2] + f.name))
                    self.budget.tick(loose)
        for index, _ in self.packs:
            found.update(_pack_ids(index, prefix, self.id_size))
        return sorted(found)[:_MAX_IDS]

    def _unpack(self, index: bytes, pack: Path, offset: int) -> tuple[str, bytes]:
        """(type, content) of the pack entry at ``offset``, its chain of deltas applied."""
        deltas = []
        with _open(pack) as stream:
            end = os.fstat(stream.fileno()).st_size - self.id_size  # the pack's checksum follows its last entry
            if pack not in self._checked_packs:
                _check_pack_header(stream.read(12), pack, _index_count(index))
                self._checked_packs.add(pack)
            for depth in range(_MAX_DEPTH + 1):
                if not 12 <= offset < end:
                    raise RepositoryLimit(f"{pack}: an entry at offset {offset} lies outside the pack ({end + self.id_size} bytes)")
                stream.seek(offset)
                where = f"{pack} (the entry at offset {offset})"
                kind, declared = _entry_header(stream, pack, offset)
                if kind in _PACK_TYPES:
                    content = _inflate(stream, self.budget, where, declared)
                    break
                if kind == _OFS_DELTA:
                    distance = _base_distance(stream)
                    if not 0 < distance <= offset - 12:
                        raise RepositoryLimit(f"{pack}: the delta at offset {offset} names a base outside the pack")
                    offset -= distance
                elif kind == _REF_DELTA:
                    offset = _pack_offset(index, stream.read(self.id_size))
                    if offset is None:
                        raise ValueError("delta base outside the pack")
                else:
                    raise ValueError(f"pack entry type {kind}")
                deltas.append(_inflate(stream, self.budget, where, declared))
            else:
                raise RepositoryLimit(f"{pack}: a delta chain deeper than {_MAX_DEPTH} deltas; refused")
        for delta in reversed(deltas):
            content = _patched(content, delta, self.budget, pack)
        return _PACK_TYPES[kind], content


def _loose(path: Path, budget: _Budget) -> tuple[str, bytes]:
    """(type, content) of a loose object file, its header's size checked against its content."""
    with _open(path) as stream:
        header, _, content = _inflate(stream, budget, path).partition(b"\0")
    kind, _, size = header.partition(b" ")
    if kind.decode(errors="replace") not in _PACK_TYPES.values() or not size.isdigit() or int(size) != len(content):
        raise RepositoryLimit(f"{path}: not a loose object (its header of {len(header)} bytes is no '<type> <size>' of "
                              f"its {len(content)} bytes; the object's bytes are not shown)")
    return kind.decode(), content


def _entry_header(stream: io.BufferedIOBase, pack: Path, offset: int) -> tuple[int, int]:
    """A pack entry's type and declared (inflated) size, refused above _MAX_OBJECT before anything is inflated."""
    byte = stream.read(1)[0]
    kind, size, shift = (byte >> 4) & 7, byte & 15, 4
    while byte & 0x80:
        byte = stream.read(1)[0]
        size |= (byte & 0x7F) << shift
        shift += 7
        if shift > 70:
            break
    if size > _MAX_OBJECT:
        raise RepositoryLimit(f"{pack}: the entry at offset {offset} declares {size} bytes, more than the "
                              f"{_MAX_OBJECT >> 20} MiB an object may have; refused")
    return kind, size


def _index_count(index: bytes) -> int:
    return struct.unpack_from(">I", index, 8 + 4 * 255)[0]


def _checked_index(index: bytes, path: Path, id_size: int) -> bytes:
    """``index`` after checking it is a sane version 2 pack index: fan-out never decreasing, size as declared."""
    if index[:8] != b"\377tOc\0\0\0\2" or len(index) < 8 + 1024 + 2 * id_size:
        raise RepositoryLimit(f"{path}: not a version 2 pack index")
    fanout = struct.unpack_from(">256I", index, 8)
    falls = next((i for i in range(255) if fanout[i] > fanout[i + 1]), None)
    if falls is not None:
        raise RepositoryLimit(f"{path}: its fan-out table decreases at entry {falls + 1} ({fanout[falls]} > "
                              f"{fanout[falls + 1]}); not a pack index git wrote")
    count = fanout[255]
    needed = 8 + 1024 + count * (id_size + 8) + 2 * id_size  # ids, CRCs, offsets, two checksums
    large = (len(index) - needed) // 8
    if len(index) < needed or (len(index) - needed) % 8 or large > count:
        raise RepositoryLimit(f"{path}: {len(index)} bytes do not fit the {count} objects its fan-out table declares")
    return index


def _check_pack_header(header: bytes, pack: Path, count: int) -> None:
    if len(header) < 12 or header[:4] != b"PACK" or struct.unpack(">I", header[4:8])[0] not in (2, 3):
        raise RepositoryLimit(f"{pack}: not a git pack (its header)")
    declared = struct.unpack(">I", header[8:12])[0]
    if declared != count:
        raise RepositoryLimit(f"{pack}: declares {declared} objects, its index {count}")


def _pack_offset(index: bytes, oid: bytes) -> int | None:
    """Where a pack holds ``oid``, by binary search in its version 2 index (checked by _checked_index)."""
    fanout = struct.unpack_from(">256I", index, 8)
    count, names = fanout[255], 8 + 1024
    low, high = fanout[oid[0] - 1] if oid[0] else 0, fanout[oid[0]]
    while low < high:
        middle = (low + high) // 2
        name = index[names + middle * len(oid) : names + (middle + 1) * len(oid)]
        if name == oid:
            offsets = names + count * (len(oid) + 4)
            offset = struct.unpack_from(">I", index, offsets + 4 * middle)[0]
            large = offsets + 4 * count + 8 * (offset & 0x7FFFFFFF)
            return struct.unpack_from(">Q", index, large)[0] if offset & 0x80000000 else offset
        low, high = (middle + 1, high) if name < oid else (low, middle)
    return None


def _pack_ids(index: bytes, prefix: str, size: int) -> list[bytes]:
    """The ids (at most _MAX_IDS) a version 2 pack index lists under a hex prefix: a binary search to the first,
    then those that follow while they match."""
    fanout = struct.unpack_from(">256I", index, 8)
    first = int(prefix[:2], 16)
    names = 8 + 1024
    low, high = fanout[first - 1] if first else 0, fanout[first]
    smallest = bytes.fromhex(prefix.ljust(2 * size, "0"))
    name = lambda i: index[names + i * size : names + (i + 1) * size]  # noqa: E731
    start, stop = low, high
    while start < stop:
        middle = (start + stop) // 2
        start, stop = (middle + 1, stop) if name(middle) < smallest else (start, middle)
    ids = []
    for i in range(start, min(high, start + _MAX_IDS)):
        if not name(i).hex().startswith(prefix):
            break
        ids.append(name(i))
    return ids


def _base_distance(stream: io.BufferedIOBase) -> int:
    """How far back an offset delta's base starts (git's big-endian varint with its +1 per byte)."""
    byte = stream.read(1)[0]
    distance = byte & 0x7F
    while byte & 0x80:
        byte = stream.read(1)[0]
        distance = ((distance + 1) << 7) | (byte & 0x7F)
    return distance


def _patched(base: bytes, delta: bytes, budget: _Budget, pack: Path) -> bytes:
    """``base`` with git's delta applied: copies of base ranges and inserted literal bytes (its result's size
    checked against the object bound and spent from the read's budget before it is built)."""
    base_size, position = _size(delta, 0)
    size, position = _size(delta, position)
    if base_size != len(base):
        raise ValueError("delta does not fit its base")
    if size > _MAX_OBJECT:
        raise RepositoryLimit(f"{pack}: a delta declares a result of {size} bytes, more than the {_MAX_OBJECT >> 20} MiB "
                              "an object may have; refused")
    budget.spend(size, pack)
    out = bytearray()
    while position < len(delta) and len(out) <= size:
        op = delta[position]
        position += 1
        if op & 0x80:  # copy: bits 0-3 say which offset bytes follow, bits 4-6 which length bytes
            fields = bytearray(7)
            for bit in range(7):
                if op & (1 << bit):
                    fields[bit], position = delta[position], position + 1
            start, length = int.from_bytes(fields[:4], "little"), int.from_bytes(fields[4:], "little")
            out += base[start : start + (length or 0x10000)]
        elif op:
            out += delta[position : position + op]
            position += op
        else:
            raise ValueError("delta opcode 0")
    if len(out) != size:
        raise ValueError("delta result has the wrong size")
    return bytes(out)


def _size(data: bytes, position: int) -> tuple[int, int]:
    """A little-endian base-128 size at ``position`` (at most 10 bytes), and the position after it."""
    value = shift = 0
    while shift < 70:
        byte = data[position]
        value |= (byte & 0x7F) << shift
        position, shift = position + 1, shift + 7
        if not byte & 0x80:
            return value, position
    raise ValueError("a delta size of more than 10 bytes")


def _inflate(stream: io.BufferedIOBase, budget: _Budget, where: object, declared: int | None = None) -> bytes:
    """The zlib stream at the stream's position, refused beyond _MAX_OBJECT bytes (or the read's budget); with
    ``declared``, it must inflate to exactly that many bytes."""
    limit = _MAX_OBJECT if declared is None else declared
    inflater, out = zlib.decompressobj(), bytearray()
    while not inflater.eof:
        chunk = inflater.unconsumed_tail or stream.read(1 << 16)
        if not chunk:
            raise ValueError("truncated object")
        piece = inflater.decompress(chunk, limit + 1 - len(out))
        out += piece
        budget.spend(len(piece), where)
        if len(out) > limit:
            raise RepositoryLimit(f"{where}: inflates to more than the {limit} bytes "
                                  f"{'its header declares' if declared is not None else 'an object may have'}; refused")
    if declared is not None and len(out) != declared:
        raise RepositoryLimit(f"{where}: inflates to {len(out)} bytes, its header declares {declared}; refused")
    return bytes(out)


def _open(path: Path) -> io.BufferedReader:
    """A regular file, opened for reading; a fifo or device is refused rather than waited on."""
    stream = os.fdopen(os.open(path, os.O_RDONLY | os.O_NONBLOCK), "rb")
    if not stat.S_ISREG(os.fstat(stream.fileno()).st_mode):
        stream.close()
        raise ValueError(f"{path} is not a regular file")
    return stream


def read_bytes(path: Path, limit: int = _MAX_OBJECT) -> bytes:
    """A regular file's bytes, refused beyond ``limit``."""
    with _open(path) as stream:
        data = stream.read(limit + 1)
    if len(data) > limit:
        raise ValueError(f"{path} is larger than {limit} bytes")
    return data


