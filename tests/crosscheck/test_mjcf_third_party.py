"""Third-party MJCF: gymnasium's MuJoCo assets (gymnasium supplies the files only; its set is skipped without it) and
PyBullet's pybullet_data/mjcf (the engines extra). A file MuJoCo 4.0 loads either loads here and agrees with MuJoCo
(M = mj_fullM, τ = mj_rne + armature ⊙ q̈: armature applied as MuJoCo does; conventions as in test_mjcf_import.mujoco_errors) or is refused with an
MJCFError naming what is not supported; a file MuJoCo refuses (old MJCF: global coordinates, a tendon on a missing
joint, unknown attributes) is loaded or refused by an MJCFError, never another exception. docs/mjcf.md holds the
table (``PYTHONPATH=. python scripts/mjcf_table.py`` writes it) and must list every file with the same outcome.

Measured (gymnasium 1.4.0, pybullet 3.2.7, MuJoCo 4.0): gymnasium, all 14 load, M and τ ≤ 1.8e-15 against MuJoCo;
pybullet_data, all 18 files MuJoCo loads load here, ≤ 5.4e-15 (humanoid_symmetric_no_ground; striker and thrower hold
a second free body, striker's with armature: the "free_armature" term added as in mujoco_errors); of the 8 MuJoCo 4 refuses, manipdyn refuses 3 (global coordinates, a
"fixed" joint type) and loads 5 whose faults touch nothing it reads — THIRD = 1e-13.
"""
from __future__ import annotations

import importlib
import re
import warnings
from pathlib import Path

import pytest

from conftest import ROOT
from test_mjcf_import import mujoco_errors

import manipdyn as md

mujoco = pytest.importorskip("mujoco")

THIRD = 1e-13          # measured ≤ 5.4e-15


def _assets(package, *sub):
    try:
        mod = importlib.import_module(package)
    except ImportError:
        return []
    return sorted(Path(mod.__file__).parent.joinpath(*sub).glob("*.xml"))


SETS = {"gymnasium": _assets("gymnasium", "envs", "mujoco", "assets"), "pybullet_data": _assets("pybullet_data", "mjcf")}
ASSETS = [(name, p) for name, paths in SETS.items() for p in paths]


def outcome(path):
    """(MuJoCo's reason for refusing the file or None, ("loads", worst err vs MuJoCo or None) or ("refused",
    the MJCFError's reason))."""
    try:
        m = mujoco.MjModel.from_xml_path(str(path))
        mj = None
    except ValueError as exc:
        m, mj = None, str(exc).splitlines()[0]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = md.load_mjcf(path)
    except md.MJCFError as exc:
        return mj, ("refused", str(exc).split(": ", 1)[1])
    return mj, ("loads", None if m is None else mujoco_errors(model, m, n=5))


@pytest.mark.parametrize("name,path", ASSETS, ids=lambda x: x.name if isinstance(x, Path) else x)
def test_third_party_file_loads_and_agrees_or_is_refused_by_name(name, path):
    mj, (kind, value) = outcome(path)
    print(f"\n{name}/{path.name}: MuJoCo {'refuses: ' + mj if mj else 'loads'}; manipdyn {kind} {value}")
    if mj is None and kind == "loads":
        assert value <= THIRD
    elif mj is None:
        assert "not supported" in value
    row = next((r for r in (ROOT / "docs" / "mjcf.md").read_text().splitlines()
                if r.startswith(f"| {name}/{path.name} |")), None)
    assert row is not None, f"docs/mjcf.md has no row for {name}/{path.name}: run scripts/mjcf_table.py"
    cells = re.split(r"\s*\|\s*", row)
    assert cells[2:4] == ["no" if mj else "yes", "yes" if kind == "loads" else "no"], row
