"""docs/architecture.md's file map holds to the package: every module that defines something is named by its
path under manipdyn/, and every path the map names exists (a file split, renamed or removed fails here until
the map says so). A package's __init__.py that only imports and lists names (no def, no class) may go unnamed."""
from __future__ import annotations

import ast
import re

from conftest import ROOT

PKG = ROOT / "manipdyn"
DOC = ROOT / "docs" / "architecture.md"


def mapped_paths(doc=DOC):
    """The paths the map's code block names, in order: the first word of each entry line (two spaces in)."""
    text = doc.read_text(encoding="utf-8")
    block = re.search(r"```\nmanipdyn/\n(.*?)```", text, re.S)
    assert block, "docs/architecture.md has no file map (a code block that starts with manipdyn/)"
    return [m.group(1) for m in re.finditer(r"^  (\S+\.py)\b", block.group(1), re.M)]


def defines_something(path):
    """True when the module has a def, a class or an assignment other than __all__ at its top level."""
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            return True
        if isinstance(node, ast.Assign) and not all(getattr(t, "id", "") == "__all__" for t in node.targets):
            return True
    return False


def missing_modules(doc=DOC):
    """The modules (paths under manipdyn/) that the map does not name."""
    named = set(mapped_paths(doc))
    return [str(p.relative_to(PKG)) for p in sorted(PKG.rglob("*.py")) if "__pycache__" not in p.parts
            and str(p.relative_to(PKG)) not in named
            and (p.name != "__init__.py" or p.parent == PKG or defines_something(p))]


def test_every_module_is_on_the_map():
    missing = missing_modules()
    assert not missing, f"modules not in docs/architecture.md's file map: {missing}"


def test_every_path_on_the_map_exists_once():
    paths = mapped_paths()
    assert len(paths) > 40
    assert len(paths) == len(set(paths)), "a path is named twice in the map"
    gone = [p for p in paths if not (PKG / p).is_file()]
    assert not gone, f"docs/architecture.md names files that do not exist: {gone}"


def test_the_map_catches_a_missing_module(tmp_path):
    """The check itself: a map that names rnea.py by another name misses it, and names a file that is not there."""
    doc = tmp_path / "architecture.md"
    doc.write_text(DOC.read_text(encoding="utf-8").replace("  dynamics/rnea.py ", "  dynamics/rnea_gone.py "),
                   encoding="utf-8")
    assert missing_modules(doc) == ["dynamics/rnea.py"]
    assert not (PKG / "dynamics/rnea_gone.py").is_file() and "dynamics/rnea_gone.py" in mapped_paths(doc)
