"""Where a spec came from: the git commit of its work tree and whether the spec differs from it.

The repository is read as files (armcal/support/gitrepo.py): git itself is never run.
"""

from __future__ import annotations

from datetime import datetime, timezone
from pathlib import Path

from armcal.support.gitrepo import UNREADABLE, ObjectStore, blob_at, blob_id, common_dir, read_bytes, repository, resolve_head, tree_path


def git_info(path: Path) -> dict | None:
    """{commit, dirty} of the git repository holding ``path``, or None outside git (or with no readable HEAD).

    ``dirty`` is true unless the spec file's bytes equal its blob in the HEAD commit: a
    spec that is modified, staged but not committed, untracked, or whose committed
    version cannot be read counts as dirty. Other files of the work tree are not looked at.
    """
    spec = Path(path).absolute()
    try:
        found = repository(spec.parent.resolve())
        if found is None:
            return None
        work_tree, git_dir = found
        common = common_dir(git_dir)
        commit = resolve_head(git_dir, common)
    except UNREADABLE:
        return None
    if commit is None:
        return None
    return {"commit": commit, "dirty": not _unchanged(spec, work_tree, common, commit)}


def _unchanged(spec: Path, work_tree: Path, common: Path, commit: str) -> bool:
    """Whether the spec file's bytes are the blob the commit holds at its path."""
    try:
        committed = blob_at(ObjectStore(common), bytes.fromhex(commit), tree_path(spec, work_tree))
        content = read_bytes(spec)
    except UNREADABLE:
        return False
    return committed is not None and committed == blob_id(content, len(committed))


def utc_now() -> str:
    """ISO 8601 UTC timestamp, seconds resolution."""
    return datetime.now(timezone.utc).replace(microsecond=0).isoformat().replace("+00:00", "Z")
