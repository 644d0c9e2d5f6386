"""The documentation runs: every ```python block of README.md and docs/**/*.md, and the README's shape.

Each block is one test (parametrised by file and block index), exec'd in a fresh namespace. Its working
directory is a temporary folder that mirrors the repository root (one symlink per top-level entry), so that
``urdf/aau_arm.urdf`` and the like resolve as from the root while a file the snippet writes by a bare name
lands in the temporary folder. matplotlib draws off-screen (Agg); opening a browser and connecting to the
network fail the snippet. Shell examples are ```bash blocks and are not run.

The API reference must name every public name (``manipdyn.__all__``), and the command-line page every
subcommand and option of ``manipdyn --help``.
"""
from __future__ import annotations

import argparse
import re
import socket
import webbrowser
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
README_MAX_LINES = 150
FENCE = re.compile(r"^```python[^\n]*\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)


def doc_files():
    return [README] + sorted((ROOT / "docs").rglob("*.md"))


def python_blocks(path):
    return [m.group(1) for m in FENCE.finditer(path.read_text(encoding="utf-8"))]


SNIPPETS = [(path.relative_to(ROOT).as_posix(), i) for path in doc_files() for i, _ in enumerate(python_blocks(path))]


def _refuse(*args, **kwargs):
    raise RuntimeError("documentation snippets must not open a browser or connect to the network")


@pytest.fixture
def sandbox(tmp_path, monkeypatch):
    """A working directory that reads like the repository root and keeps what is written; no browser, no
    network (loopback and Unix sockets stay allowed), matplotlib on Agg."""
    work = tmp_path / "root"
    work.mkdir()
    for entry in ROOT.iterdir():
        if entry.name != ".git":
            (work / entry.name).symlink_to(entry, target_is_directory=entry.is_dir())
    monkeypatch.chdir(work)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    try:
        import matplotlib
        matplotlib.use("Agg", force=True)
    except ImportError:
        pass
    for name in ("open", "open_new", "open_new_tab"):
        monkeypatch.setattr(webbrowser, name, _refuse)
    real_connect = socket.socket.connect

    def connect(sock, address):
        host = address[0] if isinstance(address, tuple) else None
        if sock.family in (socket.AF_INET, socket.AF_INET6) and host not in ("127.0.0.1", "::1", "localhost"):
            _refuse()
        return real_connect(sock, address)

    monkeypatch.setattr(socket.socket, "connect", connect)
    return work


@pytest.mark.parametrize("path, index", SNIPPETS, ids=[f"{p}#{i}" for p, i in SNIPPETS])
def test_python_snippet_runs(path, index, sandbox):
    code = python_blocks(ROOT / path)[index]
    namespace = {"__name__": "__snippet__"}
    exec(compile(code, f"{path} (python block {index})", "exec"), namespace)


def test_snippets_are_collected():
    assert any(p == "README.md" for p, _ in SNIPPETS), "README.md has no python block"
    assert len(SNIPPETS) >= 10, SNIPPETS


def test_readme_is_a_front_door():
    text = README.read_text(encoding="utf-8")
    lines = text.splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines (at most {README_MAX_LINES})"
    for marker in ("<!-- ci:setup -->", "<!-- ci:test -->"):
        # .ci/run reads the fenced block that follows the marker line
        assert lines.count(marker) == 1, f"README.md needs exactly one {marker} line"
        at = lines.index(marker)
        assert lines[at + 1] == "```bash", f"{marker} must be followed by a ```bash block"
        end = lines.index("```", at + 2)
        assert end > at + 2 and all(line.strip() for line in lines[at + 2:end]), f"{marker}: empty block"


def test_api_reference_names_every_public_name():
    """Functions and classes through mkdocstrings (``::: manipdyn.NAME``); plain constants (the joint kinds)
    may instead be a table row `` | `manipdyn.NAME` | value | `` whose value is checked here."""
    import manipdyn
    text = "\n".join(p.read_text(encoding="utf-8") for p in sorted((ROOT / "docs" / "api").glob("*.md")))
    documented = set(re.findall(r"^::: manipdyn\.(\w+)\s*$", text, re.MULTILINE))
    tabulated = dict(re.findall(r"^\| `manipdyn\.(\w+)` \| (-?\d+) \|", text, re.MULTILINE))
    for name, value in tabulated.items():
        constant = getattr(manipdyn, name, None)
        assert isinstance(constant, int) and constant == int(value), f"docs/api/: manipdyn.{name} is {constant!r}"
    missing = set(manipdyn.__all__) - documented - set(tabulated)
    assert not missing, f"names of manipdyn.__all__ missing from docs/api/: {sorted(missing)}"
    extra = (documented | set(tabulated)) - set(manipdyn.__all__)
    assert not extra, f"docs/api/ documents names outside manipdyn.__all__: {sorted(extra)}"


def test_cli_page_names_every_option():
    from manipdyn.cli import build_parser
    text = (ROOT / "docs" / "api" / "cli.md").read_text(encoding="utf-8")
    parser = build_parser()
    missing = []
    for name, sub in parser.commands.items():
        if f"manipdyn {name}" not in text:
            missing.append(f"manipdyn {name}")
        for action in sub._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            missing += [f"{name} {opt}" for opt in action.option_strings
                        if opt.startswith("--") and f"`{opt}" not in text]
    assert not missing, f"docs/api/cli.md does not mention: {missing}"

