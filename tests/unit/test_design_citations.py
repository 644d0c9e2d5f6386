"""Design citations point into the repository: docs/design.md exists with its numbered sections, every
"docs/design.md §X" in the code, tests, scripts and docs names one of its headings, and nothing cites a design
file that lives outside the repository (the upper-case name followed by ".md" or "§")."""
import re

from conftest import ROOT

DESIGN = ROOT / "docs" / "design.md"
SCANNED = ("manipdyn", "tests", "scripts", "docs")
SECTIONS = {str(n) for n in range(1, 10)} | {"4b", "4c", "4d", "4e"}

OUTSIDE = re.compile(r"\bDESIGN(?:\.md|\s*§)")                              # the old, outside file
CITATION = re.compile(r"\b(?:docs/)?design\.md\s*((?:§\s*\d+[a-z]?\s*(?:,\s*)?)+)")   # "docs/design.md §4b, §5"
HEADING = re.compile(r"^#{2,3} (\d+[a-z]?)\. \S", re.M)                     # "## 3. Conventions", "### 4b. Speed"


def text_files():
    """(relative path, text) of README.md and every text file under SCANNED (no __pycache__, no binary)."""
    paths = [ROOT / "README.md"] + [p for top in SCANNED for p in sorted((ROOT / top).rglob("*"))]
    for p in paths:
        if "__pycache__" in p.parts or not p.is_file():
            continue
        data = p.read_bytes()
        if b"\0" in data[:8192]:
            continue
        try:
            yield str(p.relative_to(ROOT)), data.decode("utf-8")
        except UnicodeDecodeError:
            continue


def sections(design_text):
    """The section numbers of design.md's headings ('1', '4b', ...)."""
    return set(HEADING.findall(design_text))


def outside_citations(text):
    """[(line, cited text)] of every citation of the outside design file."""
    return [(text.count("\n", 0, m.start()) + 1, m.group()) for m in OUTSIDE.finditer(text)]


def bad_citations(text, known):
    """[(line, section)] of every design.md § citation whose section is not a heading in ``known``."""
    out = []
    for m in CITATION.finditer(text):
        line = text.count("\n", 0, m.start()) + 1
        out += [(line, s) for s in re.findall(r"§\s*(\d+[a-z]?)", m.group(1)) if s not in known]
    return out


def test_design_document_has_its_sections():
    text = DESIGN.read_text(encoding="utf-8")
    found = sections(text)
    assert SECTIONS <= found, sorted(SECTIONS - found)
    assert "## 6. The chapter's errata" in text and "### 4b. Speed without losing the reading" in text


def test_nothing_cites_a_design_file_outside_the_repository():
    files = dict(text_files())
    assert len(files) > 100 and "manipdyn/dynamics/rnea.py" in files and "README.md" in files
    bad = {path: found for path, text in files.items() if (found := outside_citations(text))}
    assert bad == {}


def test_every_design_citation_names_a_section():
    known = sections(DESIGN.read_text(encoding="utf-8"))
    files = dict(text_files())
    cited = sum(len(CITATION.findall(text)) for text in files.values())
    assert cited > 30                                    # the scan sees the citations
    bad = {path: found for path, text in files.items() if (found := bad_citations(text, known))}
    assert bad == {}


def test_the_checks_catch_bad_citations():
    upper = "DES" + "IGN"                                # spelled apart, so this file cites nothing itself
    assert outside_citations(f"a\n(see {upper}.md §3)\n# {upper} §6: x") == [(2, f"{upper}.md"), (3, f"{upper} §")]
    assert outside_citations("docs/design.md §3; a DESIGNER; DESIGNS") == []
    known = sections("# Design\n## 3. Conventions\n### 4b. Speed\n## 6. Errata\n")
    assert known == {"3", "4b", "6"}
    d = "docs/" + "design.md"
    text = f"ok {d} §3\nbad {d} §12\nlist {d} §4b, §5\n[{d.split('/')[1]} §7](x)\n{d} without a section"
    assert bad_citations(text, known) == [(2, "12"), (3, "5"), (4, "7")]
