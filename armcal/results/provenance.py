"""Where a spec came from: the git commit of its work tree and whether it was dirty."""

from __future__ import annotations

import subprocess
from datetime import datetime, timezone
from pathlib import Path


def git_info(path: Path) -> dict | None:
    """{commit, dirty} of the git work tree holding ``path``, or None outside git."""
    folder = Path(path).resolve().parent

    def git(*args: str) -> str | None:
        try:
            done = subprocess.run(["git", "-C", str(folder), *args], capture_output=True, text=True, timeout=10)
        except (OSError, subprocess.TimeoutExpired):
            return None
        return done.stdout.strip() if done.returncode == 0 else None

    commit = git("rev-parse", "HEAD")
    if not commit:
        return None
    status = git("status", "--porcelain")
    return {"commit": commit, "dirty": bool(status)}


def utc_now() -> str:
    """ISO 8601 UTC timestamp, seconds resolution."""
    return datetime.now(timezone.utc).replace(microsecond=0).isoformat().replace("+00:00", "Z")
