"""A git repository read as files, in Python: refs, loose and packed objects, a file at a revision.

git itself is never run, because any git command may start programs the repository's own
configuration names (core.fsmonitor, clean and smudge filters, hooks), and a spec's folder is
not trusted that far. Every read is bounded (objects, chains of refs and deltas).
"""

from __future__ import annotations

import hashlib
import io
import os
import re
import stat
import struct
import zlib
from pathlib import Path

from armcal.errors import UserError

OBJECT_ID = re.compile(r"[0-9a-f]{40}|[0-9a-f]{64}")  # SHA-1 or SHA-256 repositories
UNREADABLE = (OSError, ValueError, IndexError, struct.error, zlib.error)
_MAX_OBJECT = 1 << 26  # bytes; commits and trees are far smaller
_MAX_CHAIN = 1000  # symbolic refs, tags and pack deltas followed before giving up
_MAX_INDEX = 1 << 28  # bytes of a pack index (about ten million objects)
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


class ObjectStore:
    """Loose and packed objects of a repository and of its alternates (objects/info/alternates)."""

    def __init__(self, common: Path):
        objects = common / "objects"
        alternates = objects / "info" / "alternates"
        extra = read_bytes(alternates).decode().splitlines() if alternates.is_file() else []
        self.folders = [objects, *((objects / line).resolve() for line in extra if line and not line.startswith("#"))]
        self.packs = [(read_bytes(i, _MAX_INDEX), i.with_suffix(".pack")) for f in self.folders for i in sorted((f / "pack").glob("*.idx"))]
        config = common / "config"
        sha256 = config.is_file() and re.search(rb"objectformat\s*=\s*sha256", read_bytes(config), re.IGNORECASE)
        self.id_size = 32 if sha256 else 20

    def read(self, oid: bytes) -> tuple[str, bytes]:
        """(type, content) of an object."""
        for folder in self.folders:
            loose = folder / oid.hex()[:2] / oid.hex()[2:]
            if loose.is_file():
                header, _, content = _inflate(io.BytesIO(read_bytes(loose))).partition(b"\0")
                return header.split(b" ")[0].decode(), content
        for index, pack in self.packs:
            offset = _pack_offset(index, oid)
            if offset is not None:
                return _unpack(index, pack, offset, len(oid))
        raise ValueError(f"object {oid.hex()} not found")

    def expand(self, prefix: str) -> list[bytes]:
        """The ids of every object whose hex id starts with ``prefix`` (lower-case hex, 4 digits or more)."""
        found = set()
        for folder in self.folders:
            loose = folder / prefix[:2]
            if loose.is_dir():
                found.update(bytes.fromhex(prefix[:2] + f.name) for f in loose.iterdir() if f.name.startswith(prefix[2:]) and OBJECT_ID.fullmatch(prefix[:2] + f.name))
        for index, _ in self.packs:
            found.update(_pack_ids(index, prefix, self.id_size))
        return sorted(found)


def _pack_offset(index: bytes, oid: bytes) -> int | None:
    """Where a pack holds ``oid``, by binary search in its version 2 index."""
    if index[:8] != b"\377tOc\0\0\0\2":
        raise ValueError("unsupported pack index")
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
    """The ids a version 2 pack index lists under a hex prefix (the fan-out table bounds the scan)."""
    fanout = struct.unpack_from(">256I", index, 8)
    first = int(prefix[:2], 16)
    names = 8 + 1024
    low, high = fanout[first - 1] if first else 0, fanout[first]
    ids = (index[names + i * size : names + (i + 1) * size] for i in range(low, high))
    return [oid for oid in ids if oid.hex().startswith(prefix)]


def _unpack(index: bytes, pack: Path, offset: int, id_size: int) -> tuple[str, bytes]:
    """(type, content) of the pack entry at ``offset``, its chain of deltas applied."""
    deltas = []
    with _open(pack) as stream:
        for _ in range(_MAX_CHAIN):
            stream.seek(offset)
            byte = stream.read(1)[0]
            kind = (byte >> 4) & 7
            while byte & 0x80:  # the entry's size: not needed, the zlib stream ends itself
                byte = stream.read(1)[0]
            if kind in _PACK_TYPES:
                content = _inflate(stream)
                break
            if kind == _OFS_DELTA:
                offset -= _base_distance(stream)
            elif kind == _REF_DELTA:
                offset = _pack_offset(index, stream.read(id_size))
                if offset is None:
                    raise ValueError("delta base outside the pack")
            else:
                raise ValueError(f"pack entry type {kind}")
            deltas.append(_inflate(stream))
            if sum(map(len, deltas)) > _MAX_OBJECT:
                raise ValueError("delta chain too large")
        else:
            raise ValueError("delta chain too long")
    for delta in reversed(deltas):
        content = _patched(content, delta)
    return _PACK_TYPES[kind], content


def _base_distance(stream: io.BufferedIOBase) -> int:
    """How far back an offset delta's base starts (git's big-endian varint with its +1 per byte)."""
    byte = stream.read(1)[0]
    distance = byte & 0x7F
    while byte & 0x80:
        byte = stream.read(1)[0]
        distance = ((distance + 1) << 7) | (byte & 0x7F)
    return distance


def _patched(base: bytes, delta: bytes) -> bytes:
    """``base`` with git's delta applied: copies of base ranges and inserted literal bytes."""
    base_size, position = _size(delta, 0)
    size, position = _size(delta, position)
    if base_size != len(base) or size > _MAX_OBJECT:
        raise ValueError("delta does not fit its base")
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
    """A little-endian base-128 size at ``position``, and the position after it."""
    value = shift = 0
    while True:
        byte = data[position]
        value |= (byte & 0x7F) << shift
        position, shift = position + 1, shift + 7
        if not byte & 0x80:
            return value, position


def _inflate(stream: io.BufferedIOBase) -> bytes:
    """The zlib stream at the stream's position, refused beyond _MAX_OBJECT bytes."""
    inflater, out = zlib.decompressobj(), bytearray()
    while not inflater.eof:
        chunk = stream.read(1 << 16)
        if not chunk:
            raise ValueError("truncated object")
        out += inflater.decompress(chunk, _MAX_OBJECT + 1 - len(out))
        if len(out) > _MAX_OBJECT:
            raise ValueError("object too large")
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


