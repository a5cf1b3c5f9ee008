"""The documentation the code cites exists, and the scene reference agrees with the code.

* every ``docs/<page>.md`` (and ``#anchor``) named in the code, the tests, the benchmarks,
  the studies and the case files is a page of the repository with that heading (GitHub's
  anchor rules);
* the ``[solver]`` table of ``docs/scenes.md`` is the one the option declarations make
  (:func:`thinfilm.scene.solver_reference`), so a new option or a changed default cannot be
  left out of the reference.
"""

from __future__ import annotations

import re

import pytest

from tests.helpers import ROOT
from thinfilm.scene import solver_reference

CITATION = re.compile(r"docs/([\w-]+\.md)(?:#([\w-]+))?")


def anchors(page):
    """GitHub's anchors of a Markdown page's headings."""
    out = set()
    for line in page.read_text(encoding="utf-8").splitlines():
        m = re.match(r"#{1,6}\s+(.*)", line)
        if m:
            text = re.sub(r"[^\w\- ]", "", m.group(1).strip().lower().replace("`", ""))
            out.add(text.replace(" ", "-"))
    return out


def citations():
    """``(file, page, anchor)`` of every citation of a docs page outside docs/."""
    out = []
    for folder in ("thinfilm", "onedim", "tests", "benchmarks", "studies", "cases"):
        for path in sorted((ROOT / folder).rglob("*")):
            if path.suffix in (".py", ".toml") and path.is_file():
                for page, anchor in CITATION.findall(path.read_text(encoding="utf-8")):
                    out.append((path.relative_to(ROOT), page, anchor))
    return out


def test_anchor_rules():
    assert "free-edges-of-the-plate" in anchors(ROOT / "docs" / "solvers.md")


def test_every_cited_page_and_heading_exists():
    found = citations()
    assert len(found) > 10  # the code does cite the docs
    missing = []
    for path, page, anchor in found:
        target = ROOT / "docs" / page
        if not target.is_file():
            missing.append(f"{path}: docs/{page}")
        elif anchor and anchor not in anchors(target):
            missing.append(f"{path}: docs/{page}#{anchor}")
    assert not missing


def _generated_table(page, marker):
    """The text between ``<!-- marker -->`` and ``<!-- /marker -->`` of a docs page."""
    text = (ROOT / "docs" / page).read_text(encoding="utf-8")
    m = re.search(rf"<!-- {marker} -->\n(.*?)\n<!-- /{marker} -->", text, re.S)
    if m is None:
        pytest.fail(f"docs/{page} has no <!-- {marker} --> table")
    return m.group(1).strip()


def test_the_scene_reference_lists_every_solver_option():
    assert _generated_table("scenes.md", "solver-options") == solver_reference().strip(), (
        "docs/scenes.md's [solver] table differs from the options' declarations; paste the output of"
        " python -c 'from thinfilm.scene import solver_reference; print(solver_reference())'")


def test_the_scan_page_lists_every_metric():
    from thinfilm.scan.metrics import metrics_reference

    assert _generated_table("scans.md", "metrics") == metrics_reference().strip(), (
        "docs/scans.md's metrics table differs from thinfilm.scan.metrics.METRICS; paste the output of"
        " python -c 'from thinfilm.scan.metrics import metrics_reference; print(metrics_reference())'")
