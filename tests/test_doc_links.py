"""Every relative link in README.md and docs/**/*.md leads to a file of the repository, and a
#anchor to a heading of that page (GitHub's anchors: lower case, punctuation dropped, spaces
to -). Pages and source files named in the prose (docs/ur10.md, armcal/simulate/truth.py) exist
too, relative to the page or to the repository's root."""

import re
from pathlib import Path

import pytest
from conftest import ROOT

PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
FENCE = re.compile(r"^```.*?^```", re.M | re.S)
LINK = re.compile(r"(?<!!)\[([^\]]*)\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
EXTERNAL = re.compile(r"^[a-z][a-z0-9+.-]*:", re.I)  # https:, mailto:, ...
MENTION = re.compile(r"(?<![\w/.-])((?:\.\.?/)*[\w.-]+(?:/[\w.-]+)*\.(?:md|py))\b")


def prose(page: Path) -> str:
    """The page without its fenced blocks (commands and their output, not references)."""
    return FENCE.sub("", page.read_text())


def links(page: Path) -> list[str]:
    return [m.group(2) for m in LINK.finditer(re.sub(r"`[^`\n]*`", "", prose(page)))]


def mentions(page: Path) -> list[str]:
    return MENTION.findall(LINK.sub(" ", prose(page)))


def anchors(page: Path) -> set[str]:
    headings = re.findall(r"^#{1,6}\s+(.+?)\s*#*\s*$", prose(page), re.M)
    return {re.sub(r"[^\w\- ]", "", heading.lower()).replace(" ", "-") for heading in headings}


def in_repository(path: Path) -> bool:
    path = path.resolve()
    return path.exists() and ROOT.resolve() in [path, *path.parents]


def test_the_patterns_find_links_mentions_and_headings(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("## Data file columns\nsee docs/ur10.md, [the guide](../x/guide.md#data) and `ARCHITECTURE.md`\n```sh\ncat fenced.md\n```\n")
    assert links(page) == ["../x/guide.md#data"]
    assert mentions(page) == ["docs/ur10.md", "ARCHITECTURE.md"]
    assert anchors(page) == {"data-file-columns"}


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(ROOT)) for p in PAGES])
def test_relative_links_resolve(page):
    broken = []
    for link in links(page):
        if EXTERNAL.match(link):
            continue
        path, _, anchor = link.partition("#")
        target = page.parent / path if path else page
        if not in_repository(target):
            broken.append(f"{link}: no such file in the repository")
        elif anchor and target.suffix == ".md" and anchor.lower() not in anchors(target):
            broken.append(f"{link}: no heading #{anchor} in {target.resolve().relative_to(ROOT.resolve())}")
    assert not broken, f"{page.relative_to(ROOT)}: " + "; ".join(broken)


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(ROOT)) for p in PAGES])
def test_files_the_prose_names_exist(page):
    missing = [name for name in mentions(page) if not (in_repository(page.parent / name) or in_repository(ROOT / name))]
    assert not missing, f"{page.relative_to(ROOT)} names files the repository does not have: {missing}"
