"""A command's process ends without a last garbage collection over its objects (support/process_end.py): what the
collector would still find at exit is left to the operating system, while the exit handlers run as before."""

import subprocess
import sys

from conftest import ROOT

# An object in a reference cycle, held by a module until exit, is freed only by the collector: once Python's exit
# clears the modules, its last collection finalizes it (its __del__ writes FINALIZED), unless that collection is
# left out. The exit handler shows that atexit still runs.
PROBE = """
import atexit, sys
class Cycle:
    def __del__(self):
        sys.stdout.write("FINALIZED\\n"); sys.stdout.flush()
cycle = Cycle(); cycle.me = cycle
atexit.register(lambda: print("EXIT HANDLER RAN"))
"""


def _exit_of(code: str, tmp_path, *argv: str) -> str:
    (tmp_path / "sitecustomize.py").write_text(PROBE)
    env = {"PYTHONPATH": f"{tmp_path}:{ROOT}", "PATH": "/usr/bin:/bin"}
    result = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, env=env, timeout=120)
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_python_alone_finalizes_the_cycle_at_exit(tmp_path):
    """The probe's oracle: without the call, Python's last collection finalizes the cycle."""
    out = _exit_of("pass", tmp_path)
    assert "FINALIZED" in out and "EXIT HANDLER RAN" in out


def test_an_armcal_command_leaves_it_and_still_runs_the_exit_handlers(tmp_path):
    code = "import sys; from armcal.cli import app; app(prog_name='armcal', args=sys.argv[1:])"
    out = _exit_of(code, tmp_path, "validate", str(ROOT / "examples" / "goswami_ballbar" / "spec.yaml"))
    assert "FINALIZED" not in out and "EXIT HANDLER RAN" in out


def test_once_per_process_however_often_it_is_called(tmp_path):
    code = ("import atexit, gc\nfrom armcal.support.process_end import end_without_final_collection\n"
            "calls = []\nreal = gc.freeze\ngc.freeze = lambda: calls.append(1) or real()\n"
            "atexit.register(lambda: print('FREEZES', len(calls)))\n"  # registered first, so it runs last
            "for _ in range(1000): end_without_final_collection()\n")
    out = _exit_of(code, tmp_path)
    assert "FREEZES 1\n" in out and "FINALIZED" not in out
