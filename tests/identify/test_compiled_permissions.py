"""The compiled-code cache's files have explicit modes, whatever the umask (issue 30 leftover 10): the generated C
source (functions.c) is 0644 in its 0700 build folder, never world-writable under umask 000."""

import os
import stat
import subprocess

from armcal.support import builder
from armcal.support import compiled as cache


def _under_umask_0(action):
    previous = os.umask(0)
    try:
        return action()
    finally:
        os.umask(previous)


def test_the_source_is_written_0644_under_umask_000(tmp_path):
    path = tmp_path / builder.SOURCE
    _under_umask_0(lambda: cache._write_source(path, "int f(void) { return 1; }\n"))
    assert stat.S_IMODE(path.stat().st_mode) == 0o644 and path.read_text().startswith("int f")


def test_the_background_build_folder_and_its_source_under_umask_000(tmp_path, monkeypatch):
    """The detached builder's folder (0700) and the source it compiles (0644), left as they are when it starts."""
    monkeypatch.setattr(subprocess, "run", lambda *args, **kwargs: None)  # no builder process
    library = tmp_path / "armcal_x.so"
    monkeypatch.setattr(cache, "_started", set())
    _under_umask_0(lambda: cache._start_builder("/* c */\n", library, "cc"))
    (work,) = tmp_path.glob("build-*")
    assert stat.S_IMODE(work.stat().st_mode) == 0o700
    assert stat.S_IMODE((work / builder.SOURCE).stat().st_mode) == 0o644
