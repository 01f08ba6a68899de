"""A hostile git repository is refused fast, with a message naming the file and revision (armcal/support/gitrepo.py).

The repositories are written by hand (commit and tree as loose objects, the spec's blob in a pack built here),
so every field git would check can lie: a delta chain deeper than git writes, a small pack that inflates far
beyond its size, an entry whose declared size is not what it inflates to, a pack index whose fan-out table
decreases or whose size does not fit its declared object count. Oracle: git's pack and index formats
(Documentation/gitformat-pack.txt); every refusal is a UserError within a second, not minutes.
"""

import hashlib
import struct
import time
import zlib

import pytest
from conftest import HANG, armcal_process

from armcal.support import gitrepo
from armcal.support.errors import UserError
from armcal.support.gitrepo import file_at_revision

SPEC = b"robot: {name: r}\n"


def _loose(git_dir, kind: bytes, body: bytes) -> bytes:
    data = b"%s %d\0" % (kind, len(body)) + body
    oid = hashlib.sha1(data).digest()
    path = git_dir / "objects" / oid.hex()[:2] / oid.hex()[2:]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(zlib.compress(data))
    return oid


def _repo(tmp_path, blob_id: bytes):
    """A repository whose HEAD commit holds spec.yaml as ``blob_id`` (the blob itself is the test's to add)."""
    git_dir = tmp_path / "repo" / ".git"
    (git_dir / "objects" / "pack").mkdir(parents=True)
    (git_dir / "refs" / "heads").mkdir(parents=True)
    tree = _loose(git_dir, b"tree", b"100644 spec.yaml\0" + blob_id)
    commit = _loose(git_dir, b"commit", b"tree %s\nauthor a <a> 0 +0000\ncommitter a <a> 0 +0000\n\nm\n" % tree.hex().encode())
    (git_dir / "HEAD").write_text("ref: refs/heads/main\n")
    (git_dir / "refs" / "heads" / "main").write_text(commit.hex() + "\n")
    spec = tmp_path / "repo" / "spec.yaml"
    spec.write_bytes(SPEC)
    return git_dir, spec


def _header(kind: int, size: int) -> bytes:
    out, byte, size = bytearray(), (kind << 4) | (size & 15), size >> 4
    while size:
        out.append(byte | 0x80)
        byte, size = size & 0x7F, size >> 7
    out.append(byte)
    return bytes(out)


def _varint(value: int) -> bytes:
    out = bytearray()
    while True:
        out.append((value & 0x7F) | (0x80 if value > 0x7F else 0))
        value >>= 7
        if not value:
            return bytes(out)


def _distance(value: int) -> bytes:
    """An offset delta's base distance (git's big-endian varint with its +1 per byte)."""
    out = [value & 0x7F]
    value >>= 7
    while value:
        value -= 1
        out.insert(0, 0x80 | (value & 0x7F))
        value >>= 7
    return bytes(out)


def _copy_all(size: int) -> bytes:
    """A delta that copies the whole base (size below 16 MiB) and so yields it again."""
    return _varint(size) + _varint(size) + bytes([0x80 | 0x70]) + size.to_bytes(3, "little")


def _pack(git_dir, entries: list[bytes], listed: bytes, declared_count: int = 1,
          fanout=None, extra_index: bytes = b"") -> None:
    """A pack of ``entries`` (raw entries: header and data), its last entry listed in the index as ``listed``."""
    body, offsets = bytearray(b"PACK" + struct.pack(">II", 2, declared_count)), []
    for entry in entries:
        offsets.append(len(body))
        body += entry
    body += hashlib.sha1(body).digest()
    counts = fanout or [0] * listed[0] + [1] * (256 - listed[0])
    index = b"\377tOc" + struct.pack(">I", 2) + struct.pack(">256I", *counts) + listed + struct.pack(">I", 0)
    index += struct.pack(">I", offsets[-1]) + extra_index + hashlib.sha1(body).digest()
    index += hashlib.sha1(index).digest()
    (git_dir / "objects" / "pack" / "pack-0.pack").write_bytes(body)
    (git_dir / "objects" / "pack" / "pack-0.idx").write_bytes(index)


def _chain(base: bytes, depth: int) -> list[bytes]:
    """A blob and ``depth`` offset deltas on it, each on the entry before (the pack's entries start at byte 12)."""
    delta = _copy_all(len(base))
    entries, at = [_header(3, len(base)) + zlib.compress(base)], 12
    for _ in range(depth):
        previous, at = at, at + len(entries[-1])
        entries.append(_header(6, len(delta)) + _distance(at - previous) + zlib.compress(delta))
    return entries


def _refused(spec, match: str) -> str:
    """The read refused with ``match``, within HANG (the message shows where reading stopped)."""
    started = time.monotonic()
    with pytest.raises(UserError, match=match) as caught:
        file_at_revision(spec, "HEAD")
    assert time.monotonic() - started < HANG
    assert str(caught.value).startswith(f"{spec}@HEAD: ")
    return str(caught.value)


def _blob_id(content: bytes) -> bytes:
    return hashlib.sha1(b"blob %d\0" % len(content) + content).digest()


def test_a_hand_made_pack_within_the_bounds_is_read(tmp_path):
    """The oracle of the builder: a chain of 5 deltas on the spec's bytes gives those bytes."""
    git_dir, spec = _repo(tmp_path, _blob_id(SPEC))
    _pack(git_dir, _chain(SPEC, 5), _blob_id(SPEC))
    assert file_at_revision(spec, "HEAD") == SPEC


def test_a_delta_chain_deeper_than_git_writes_is_refused(tmp_path):
    git_dir, spec = _repo(tmp_path, _blob_id(SPEC))
    _pack(git_dir, _chain(SPEC, gitrepo._MAX_DEPTH + 40), _blob_id(SPEC))
    assert "deeper than 250 deltas" in _refused(spec, "delta chain")


def test_a_small_pack_that_inflates_beyond_the_reads_budget_stops_early(tmp_path):
    """9 MiB of zeros (a 9 KiB zlib stream) behind 30 copying deltas: 280 MiB of work, refused after 64 MiB."""
    big = bytes(9 << 20)
    git_dir, spec = _repo(tmp_path, _blob_id(big))
    _pack(git_dir, _chain(big, 30), _blob_id(big))
    assert (git_dir / "objects" / "pack" / "pack-0.pack").stat().st_size < 100_000
    _refused(spec, "inflates more than 64 MiB")


def test_an_entry_whose_declared_size_lies_is_refused(tmp_path):
    git_dir, spec = _repo(tmp_path, _blob_id(SPEC))
    _pack(git_dir, [_header(3, 5) + zlib.compress(SPEC * 50)], _blob_id(SPEC))
    _refused(spec, "more than the 5 bytes its header declares")
    _pack(git_dir, [_header(3, len(SPEC) + 7) + zlib.compress(SPEC)], _blob_id(SPEC))
    _refused(spec, f"inflates to {len(SPEC)} bytes, its header declares {len(SPEC) + 7}")
    _pack(git_dir, [_header(3, 1 << 40) + zlib.compress(SPEC)], _blob_id(SPEC))  # refused before inflating
    _refused(spec, "declares 1099511627776 bytes")


def test_a_pack_index_that_is_not_sane_is_refused(tmp_path):
    git_dir, spec = _repo(tmp_path, _blob_id(SPEC))
    oid = _blob_id(SPEC)
    assert oid[0] < 200  # the spec's blob id starts with 0x64
    decreasing = [0] * oid[0] + [1] * (200 - oid[0]) + [0] * 56  # entry 200 falls back to 0
    _pack(git_dir, _chain(SPEC, 0), oid, fanout=decreasing)
    _refused(spec, "fan-out table decreases at entry 200")
    huge = [0] * oid[0] + [0x7FFFFFF0] * (256 - oid[0])  # monotonic, but 1.1 KB cannot list 2 billion objects
    _pack(git_dir, _chain(SPEC, 0), oid, fanout=huge)
    _refused(spec, "do not fit the 2147483632 objects")
    _pack(git_dir, _chain(SPEC, 0), oid, extra_index=b"\0" * 12)  # 12 stray bytes: no whole large offset
    _refused(spec, "do not fit the 1 objects")
    _pack(git_dir, _chain(SPEC, 0), oid, declared_count=3)
    _refused(spec, "declares 3 objects, its index 1")


def test_an_id_prefix_in_a_sane_index_is_found_by_search(tmp_path):
    git_dir, spec = _repo(tmp_path, _blob_id(SPEC))
    store = gitrepo.ObjectStore(git_dir)
    assert store.expand(_blob_id(SPEC).hex()[:6]) == []  # the blob is nowhere yet
    _pack(git_dir, _chain(SPEC, 0), _blob_id(SPEC))
    assert gitrepo.ObjectStore(git_dir).expand(_blob_id(SPEC).hex()[:6]) == [_blob_id(SPEC)]


def test_a_read_is_bounded_in_time(tmp_path, monkeypatch):
    git_dir, spec = _repo(tmp_path, _blob_id(SPEC))
    _pack(git_dir, _chain(SPEC, 3), _blob_id(SPEC))
    monkeypatch.setattr(gitrepo, "READ_SECONDS", -1.0)
    _refused(spec, "took more than -1 s")


def test_compare_names_the_revision_and_exits_1(tmp_path):
    git_dir, spec = _repo(tmp_path, _blob_id(SPEC))
    _pack(git_dir, _chain(SPEC, gitrepo._MAX_DEPTH + 1), _blob_id(SPEC))
    result = armcal_process("compare", f"{spec}@HEAD", spec, timeout=HANG)
    assert result.returncode == 1 and f"{spec}@HEAD" in result.stderr and "deeper than" in result.stderr
    assert "Traceback" not in result.stderr


# -- hostile report 30 item 6: objects/info/alternates bounded in size, count, depth and time ----------------------


def _alternates(folder, *lines: str) -> None:
    (folder / "info").mkdir(parents=True, exist_ok=True)
    (folder / "info" / "alternates").write_text("".join(f"{line}\n" for line in lines))


def test_alternates_are_followed_to_gits_depth_and_bounded(tmp_path, monkeypatch):
    """Within git's rules (the pack in an alternate of an alternate, a cycle, comments) the spec is read; beyond them
    (a 5 KiB file, 17 folders, nesting 6 deep, the read's time) refused at once, naming the alternates file."""
    git_dir, spec = _repo(tmp_path, _blob_id(SPEC))
    objects = git_dir / "objects"
    second, third = tmp_path / "second" / "objects", tmp_path / "third" / "objects"
    (third / "pack").mkdir(parents=True)
    _pack(git_dir, _chain(SPEC, 2), _blob_id(SPEC))
    for name in ("pack-0.pack", "pack-0.idx"):
        (objects / "pack" / name).rename(third / "pack" / name)
    _alternates(objects, "# shared objects", str(second))
    _alternates(second, "../../third/objects", str(objects))  # relative to second's objects folder; a cycle back
    assert file_at_revision(spec, "HEAD") == SPEC

    _alternates(objects, "# " + "x" * 5000)
    _refused(spec, r"alternates is larger than 4096 bytes")

    _alternates(objects, *(str(tmp_path / f"o{k}") for k in range(17)))
    _refused(spec, r"alternates: more than 16 alternate object folders; refused")

    chain = [tmp_path / f"nest{k}" for k in range(7)]
    _alternates(objects, str(chain[0]))
    for folder, following in zip(chain, chain[1:]):
        _alternates(folder, str(following))
    message = _refused(spec, r"alternates nested more than 5 deep \(git's own limit\); refused")
    assert str(chain[5] / "info" / "alternates") in message

    _alternates(objects, str(second))
    monkeypatch.setattr(gitrepo, "READ_SECONDS", -1.0)
    _refused(spec, r"alternates: reading the repository took more than -1 s")
