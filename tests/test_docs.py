"""Every code block in docs/ runs: sh blocks in bash, python blocks in one namespace per page, yaml
blocks parse (and a whole spec, one with an `armcal:` key, validates). text blocks show output.
A yaml block opened with ```yaml file=PATH is also written to PATH, for the blocks after it.

The blocks run in a scratch copy of the project (examples/, specs/, docs/; ../shared beside it
when it exists), with the project's armcal first on PATH. A page that needs the public UR10
data says `<!-- needs: shared -->` and is skipped without it. A block that only runs a tutorial's
script is left to that script's own test (tests/test_tutorial_NAME.py), which runs it once.
"""

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT, SHARED_DATA
from ruamel.yaml import YAML

from armcal.spec import load_spec

DOCS = sorted((ROOT / "docs").rglob("*.md"))
BLOCK = re.compile(r"^```(\w*)([^\n]*)\n(.*?)^```", re.M | re.S)
LANGUAGES = {"sh", "python", "yaml", "text"}
TUTORIAL_SCRIPT = re.compile(r"python docs/tutorials/(\w+)\.py\s*")  # a block that runs a tutorial's script and nothing else


def run_by_its_own_test(code: str) -> bool:
    """A block that runs a tutorial script which tests/test_tutorial_<name>.py runs itself, checking its exit and numbers."""
    match = TUTORIAL_SCRIPT.fullmatch(code)
    own = ROOT / "tests" / f"test_tutorial_{match.group(1)}.py" if match else None
    return own is not None and own.exists() and f'ROOT / "docs" / "tutorials" / "{match.group(1)}.py"' in own.read_text()


def code_blocks(page: Path) -> list[tuple[str, str, str, int]]:
    """(language, file to write or "", code, line of the opening fence) of every fenced block of a page."""
    text = page.read_text()
    blocks = []
    for m in BLOCK.finditer(text):
        target = re.search(r"file=(\S+)", m.group(2))
        blocks.append((m.group(1), target.group(1) if target else "", m.group(3), text.count("\n", 0, m.start()) + 1))
    return blocks


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    root = tmp_path_factory.mktemp("docs") / "armcal"
    for folder in ("examples", "specs", "docs"):
        shutil.copytree(ROOT / folder, root / folder, ignore=shutil.ignore_patterns("out", "__pycache__"))
    if SHARED_DATA.exists():
        (root.parent / "shared").symlink_to(SHARED_DATA.parent)
    return root


def test_every_block_has_a_known_language():
    for page in DOCS:
        for language, _, _, line in code_blocks(page):
            assert language in LANGUAGES, f"{page.relative_to(ROOT)}:{line}: block language {language!r}, use one of {sorted(LANGUAGES)}"


@pytest.mark.parametrize("page", DOCS, ids=[str(p.relative_to(ROOT / "docs")) for p in DOCS])
def test_code_blocks_run(page, scratch, monkeypatch):
    if "<!-- needs: shared -->" in page.read_text() and not SHARED_DATA.exists():
        pytest.skip("needs ../shared/data")
    monkeypatch.chdir(scratch)
    environment = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    namespace: dict = {"__name__": "__docs__"}
    for language, target, code, line in code_blocks(page):
        where = f"{page.relative_to(ROOT)}:{line}"
        if language == "sh" and run_by_its_own_test(code):
            continue  # not twice: its own test runs the script once and checks more than its exit
        if language == "sh":
            result = subprocess.run(["bash", "-euo", "pipefail", "-c", code], cwd=scratch, env=environment, capture_output=True, text=True, timeout=600)
            assert result.returncode == 0, f"{where}: exit {result.returncode}\n{result.stdout[-2000:]}\n{result.stderr[-2000:]}"
        elif language == "python":
            exec(compile(code, where, "exec"), namespace)  # noqa: S102 - the project's own documentation
        elif language == "yaml":
            document = YAML(typ="safe").load(code)
            spec_path = scratch / (target or "docs_block_spec.yaml")
            if target or (isinstance(document, dict) and "armcal" in document):
                spec_path.parent.mkdir(parents=True, exist_ok=True)
                spec_path.write_text(code)
            if isinstance(document, dict) and "armcal" in document:
                load_spec(spec_path)
