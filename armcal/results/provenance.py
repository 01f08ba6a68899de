"""Where a spec came from: the git commit of its work tree and whether the spec differs from it.

The repository is read as files, in Python; git itself is never run, because any git
command may start programs the repository's own configuration names (core.fsmonitor,
clean and smudge filters, hooks), and a spec's folder is not trusted that far.
"""

from __future__ import annotations

import hashlib
import io
import os
import re
import stat
import struct
import zlib
from datetime import datetime, timezone
from pathlib import Path

_OBJECT_ID = re.compile(r"[0-9a-f]{40}|[0-9a-f]{64}")  # SHA-1 or SHA-256 repositories
_UNREADABLE = (OSError, ValueError, IndexError, struct.error, zlib.error)
_MAX_OBJECT = 1 << 26  # bytes; commits and trees are far smaller
_MAX_CHAIN = 1000  # symbolic refs and pack deltas followed before giving up
_PACK_TYPES = {1: "commit", 2: "tree", 3: "blob", 4: "tag"}
_OFS_DELTA, _REF_DELTA = 6, 7


def git_info(path: Path) -> dict | None:
    """{commit, dirty} of the git repository holding ``path``, or None outside git (or with no readable HEAD).

    ``dirty`` is true unless the spec file's bytes equal its blob in the HEAD commit: a
    spec that is modified, staged but not committed, untracked, or whose committed
    version cannot be read counts as dirty. Other files of the work tree are not looked at.
    """
    spec = Path(path).absolute()
    try:
        found = _repository(spec.parent.resolve())
        if found is None:
            return None
        work_tree, git_dir = found
        common = _common_dir(git_dir)
        commit = _resolve_head(git_dir, common)
    except _UNREADABLE:
        return None
    if commit is None:
        return None
    return {"commit": commit, "dirty": not _unchanged(spec, work_tree, common, commit)}


def _repository(folder: Path) -> tuple[Path, Path] | None:
    """(work tree, git directory) of the innermost repository holding ``folder``: a .git folder or a gitdir file."""
    for top in (folder, *folder.parents):
        dot_git = top / ".git"
        if dot_git.is_file():
            dot_git = (top / _read(dot_git).decode().removeprefix("gitdir:").strip()).resolve()
        if (dot_git / "HEAD").is_file():
            return top, dot_git
    return None


def _common_dir(git_dir: Path) -> Path:
    """The folder holding branches and objects: the main repository's for a linked worktree."""
    pointer = git_dir / "commondir"
    return (git_dir / _read(pointer).decode().strip()).resolve() if pointer.is_file() else git_dir


def _resolve_head(git_dir: Path, common: Path) -> str | None:
    """The commit HEAD names, following symbolic refs to loose or packed branches; None on an unborn branch."""
    name = "HEAD"
    for _ in range(_MAX_CHAIN):
        loose = (git_dir if name == "HEAD" else common) / name
        value = _read(loose).decode().strip() if loose.is_file() else _packed_ref(common, name)
        if value is None or not value.startswith("ref:"):
            return value if value and _OBJECT_ID.fullmatch(value) else None
        name = value.removeprefix("ref:").strip()
        if not name.startswith("refs/") or ".." in name.split("/"):
            return None
    return None


def _packed_ref(common: Path, name: str) -> str | None:
    """The object id of ``name`` in packed-refs, if listed there."""
    packed = common / "packed-refs"
    for line in (_read(packed).decode().splitlines() if packed.is_file() else []):
        oid, _, ref = line.partition(" ")
        if ref == name and not line.startswith(("#", "^")):
            return oid
    return None


def _unchanged(spec: Path, work_tree: Path, common: Path, commit: str) -> bool:
    """Whether the spec file's bytes are the blob the commit holds at its path."""
    try:
        parts = [os.fsencode(p) for p in (*spec.parent.resolve().relative_to(work_tree).parts, spec.name)]
        committed = _blob_at(_ObjectStore(common), bytes.fromhex(commit), parts)
        content = _read(spec)
    except _UNREADABLE:
        return False
    return committed is not None and committed == _blob_id(content, len(committed))


def _blob_at(store: _ObjectStore, commit: bytes, parts: list[bytes]) -> bytes | None:
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


def _blob_id(content: bytes, id_size: int) -> bytes:
    """The id git gives a file with these bytes (no filters applied)."""
    return hashlib.new("sha1" if id_size == 20 else "sha256", b"blob %d\0" % len(content) + content).digest()


class _ObjectStore:
    """Loose and packed objects of a repository and of its alternates (objects/info/alternates)."""

    def __init__(self, common: Path):
        objects = common / "objects"
        alternates = objects / "info" / "alternates"
        extra = _read(alternates).decode().splitlines() if alternates.is_file() else []
        self.folders = [objects, *((objects / line).resolve() for line in extra if line and not line.startswith("#"))]
        self.packs = [(_read(i), i.with_suffix(".pack")) for f in self.folders for i in sorted((f / "pack").glob("*.idx"))]

    def read(self, oid: bytes) -> tuple[str, bytes]:
        """(type, content) of an object."""
        for folder in self.folders:
            loose = folder / oid.hex()[:2] / oid.hex()[2:]
            if loose.is_file():
                header, _, content = _inflate(io.BytesIO(_read(loose))).partition(b"\0")
                return header.split(b" ")[0].decode(), content
        for index, pack in self.packs:
            offset = _pack_offset(index, oid)
            if offset is not None:
                return _unpack(index, pack, offset, len(oid))
        raise ValueError(f"object {oid.hex()} not found")


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


def _read(path: Path) -> bytes:
    """A regular file's bytes."""
    with _open(path) as stream:
        return stream.read()


def utc_now() -> str:
    """ISO 8601 UTC timestamp, seconds resolution."""
    return datetime.now(timezone.utc).replace(microsecond=0).isoformat().replace("+00:00", "Z")
