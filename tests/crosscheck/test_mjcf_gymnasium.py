"""Third-party MJCF: gymnasium's MuJoCo assets (gymnasium supplies the files only; skipped without it). Each file
either loads and agrees with MuJoCo 4.0 (M = mj_fullM − armature, τ = mj_rne; conventions as in
test_mjcf_import.mujoco_errors) or is refused with an MJCFError naming the reason; docs/mjcf.md holds the table
(``python scripts/mjcf_table.py`` writes it) and must list every file with the same outcome.

Measured (gymnasium 1.4.0, MuJoCo 4.0): all 14 assets load; M and τ ≤ 1.8e-15 against MuJoCo (humanoid) —
GYM = 1e-13.
"""
from __future__ import annotations

import re
import warnings
from pathlib import Path

import pytest

from conftest import ROOT
from test_mjcf_import import mujoco_errors

import manipdyn as md

mujoco = pytest.importorskip("mujoco")
gymnasium = pytest.importorskip("gymnasium")

GYM = 1e-13          # measured ≤ 1.8e-15
ASSETS = sorted((Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets").glob("*.xml"))


def outcome(path):
    """("loads", worst err vs MuJoCo) or ("refused", the MJCFError's reason)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = md.load_mjcf(path)
            m = mujoco.MjModel.from_xml_path(str(path))
    except md.MJCFError as exc:
        return "refused", str(exc).split(": ", 1)[1]
    return "loads", mujoco_errors(model, m, n=5)


@pytest.mark.parametrize("path", ASSETS, ids=lambda p: p.stem)
def test_gymnasium_asset_loads_and_agrees_or_is_refused_by_name(path):
    kind, value = outcome(path)
    print(f"\n{path.name}: {kind} {value}")
    if kind == "loads":
        assert value <= GYM
    else:
        assert value and "not supported" in value
    row = next((r for r in (ROOT / "docs" / "mjcf.md").read_text().splitlines() if r.startswith(f"| {path.name} |")),
               None)
    assert row is not None, f"docs/mjcf.md has no row for {path.name}: run scripts/mjcf_table.py"
    assert re.split(r"\s*\|\s*", row)[2] == ("yes" if kind == "loads" else "no"), row
