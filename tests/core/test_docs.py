"""The documentation the code cites exists, and the scene reference agrees with the code.

* every ``docs/<page>.md`` (and ``#anchor``) named in the packages (``onedim``, ``thinfilm``,
  ``fem3d``), the tests, the benchmarks, the studies, the examples and the case files is a
  page of the repository with that heading (GitHub's anchor rules);
* every repository path they cite (``studies/branching/README.md``,
  ``benchmarks/results/usolve.md``, ``cases/fig2_5.toml``, ...) is a file of the repository,
  and none cites a document outside it (``FEM_MODEL.md``, ``../shared/...``, ``/work/...``,
  ``dissertation.txt``): a reader of the repository has only the repository;
* every relative link of the Markdown pages (``README.md``, ``docs/``, the studies' and the
  benchmarks' pages) leads to a file of the repository and, with an ``#anchor``, to a heading
  of it;
* ``docs/README.md`` lists every page of ``docs/``;
* the ``[solver]`` table of ``docs/scenes.md`` is the one the option declarations make
  (:func:`thinfilm.scene.solver_reference`), so a new option or a changed default cannot be
  left out of the reference.
"""

from __future__ import annotations

import re

import pytest

from tests.helpers import ROOT
from thinfilm.scene import solver_reference

#: The folders whose source files are scanned for citations (``examples`` when present).
SOURCES = ("onedim", "thinfilm", "fem3d", "tests", "benchmarks", "studies", "examples", "cases")

#: The folders of the repository a cited path can start with.
TOP = ("docs", "benchmarks", "studies", "cases", "tests", "thinfilm", "onedim", "fem3d",
       "examples")

CITATION = re.compile(r"docs/([\w-]+\.md)(?:#([\w-]+))?")

#: A repository path: a top folder, then a file with an extension a citation names (a page,
#: a source, a scene, a table or a figure). Results a run writes (``.h5``, ``.json``) and
#: directories are outputs, not citations.
REPO_PATH = re.compile(
    r"(?<![\w./-])((?:\.\./)*(?:%s)/[\w./-]*\.(?:md|py|toml|txt|pdf|csv|png|msh|geo))(?![\w-])"
    % "|".join(TOP))

#: Documents outside the repository: the project's working notes and any path that leaves
#: the tree.
OUTSIDE = re.compile(
    r"FEM_MODEL|SOLVER_NOTES|\b(?:MODEL|DESIGN|ANCHORS)\.md|(?:\.\./)+shared/|/work/|"
    r"dissertation\.(?:txt|pdf|md|tex)")

#: A Markdown link to a file of the repository: ``[text](relative/path#anchor)``.
MD_LINK = re.compile(r"\]\(([^)\s#]*)(?:#([^)\s]+))?\)")


def anchors(page):
    """GitHub's anchors of a Markdown page's headings (fenced code left out, repeats numbered)."""
    out = set()
    fenced = False
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        m = None if fenced else re.match(r"#{1,6}\s+(.*)", line)
        if m:
            text = re.sub(r"[^\w\- ]", "", m.group(1).strip().lower().replace("`", ""))
            slug = text.replace(" ", "-")
            n, unique = 0, slug
            while unique in out:
                n += 1
                unique = f"{slug}-{n}"
            out.add(unique)
    return out


def sources():
    """Every scanned source file (``.py``, ``.toml``), sorted."""
    for folder in SOURCES:
        for path in sorted((ROOT / folder).rglob("*")):
            if path.suffix in (".py", ".toml") and path.is_file():
                yield path


def pages():
    """Every Markdown page of the repository outside hidden folders, sorted."""
    for path in sorted(ROOT.rglob("*.md")):
        if not any(part.startswith(".") for part in path.relative_to(ROOT).parts):
            yield path


def citations():
    """``(file, line, page, anchor)`` of every citation of a docs page in the scanned sources."""
    out = []
    for path in sources():
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for page, anchor in CITATION.findall(line):
                out.append((path.relative_to(ROOT), i, page, anchor))
    return out


def path_citations():
    """``(file, line, path)`` of every repository path cited in the scanned sources.

    A path with an upper-case placeholder as its name (``cases/CASE.toml``) stands for any file
    and is left out.
    """
    out = []
    for path in sources():
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for cited in REPO_PATH.findall(line):
                stem = cited.rsplit("/", 1)[-1].split(".")[0]
                if not stem.isupper():
                    out.append((path.relative_to(ROOT), i, cited))
    return out


def test_anchor_rules(tmp_path):
    assert "free-edges-of-the-plate" in anchors(ROOT / "docs" / "solvers.md")
    page = tmp_path / "p.md"
    page.write_text("# A `b` (c.d)\n```\n# not a heading\n```\n## A b (c.d)\n")
    assert anchors(page) == {"a-b-cd", "a-b-cd-1"}


def test_every_cited_page_and_heading_exists():
    found = citations()
    assert len(found) > 10  # the code does cite the docs
    missing = []
    for path, line, page, anchor in found:
        target = ROOT / "docs" / page
        if not target.is_file():
            missing.append(f"{path}:{line}: docs/{page}")
        elif anchor and anchor not in anchors(target):
            missing.append(f"{path}:{line}: docs/{page}#{anchor}")
    assert not missing, "\n".join(missing)


def test_every_cited_path_is_in_the_repository():
    found = path_citations()
    assert len(found) > 10
    missing = []
    for path, line, cited in found:
        # a path is cited from the repository's root, or (../...) from the citing file
        if not ((ROOT / cited).is_file() or (ROOT / path).parent.joinpath(cited).is_file()):
            missing.append(f"{path}:{line}: {cited}")
    assert not missing, "\n".join(missing)


def test_nothing_cites_a_document_outside_the_repository():
    outside = []
    for path in [*sources(), *pages()]:
        if path == ROOT / "tests" / "core" / "test_docs.py":
            continue  # names them to refuse them
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            m = OUTSIDE.search(line)
            if m:
                outside.append(f"{path.relative_to(ROOT)}:{i}: {m.group(0)}")
    assert not outside, "\n".join(outside)


def test_every_link_of_the_pages_exists():
    broken = []
    links = 0
    for page in pages():
        text = page.read_text(encoding="utf-8")
        text = re.sub(r"```.*?```", "", text, flags=re.S)  # code is not linked
        for target, anchor in MD_LINK.findall(text):
            links += 1
            if re.match(r"[a-z]+:", target):
                continue  # a web address
            file = (page.parent / target).resolve() if target else page
            if ROOT not in file.parents or not file.exists():
                broken.append(f"{page.relative_to(ROOT)}: {target}")
            elif anchor and file.suffix == ".md" and anchor not in anchors(file):
                broken.append(f"{page.relative_to(ROOT)}: {target}#{anchor}")
    assert links > 10
    assert not broken, "\n".join(broken)


def test_the_docs_index_lists_every_page():
    index = (ROOT / "docs" / "README.md").read_text(encoding="utf-8")
    listed = set(re.findall(r"\]\(([\w-]+\.md)\)", index))
    pages = {p.name for p in (ROOT / "docs").glob("*.md")} - {"README.md"}
    assert listed == pages


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
