"""The planted-fault harness itself: its catalogue matches the current sources, and one fault runs end to end."""
import dataclasses
import importlib.util
import sys

import pytest
from conftest import ROOT


def _load():
    """scripts/plant_faults.py as a module (it imports scripts/fault_catalog.py next to it)."""
    spec = importlib.util.spec_from_file_location("plant_faults", ROOT / "scripts" / "plant_faults.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["plant_faults"] = mod          # dataclasses look their module up while the class is made
    spec.loader.exec_module(mod)
    return mod


PF = _load()
FAULTS = PF.FAULTS


@pytest.mark.parametrize("fault", FAULTS, ids=lambda f: f.name)
def test_snippet_matches_exactly_once(fault):
    # an edit that breaks a fault's snippet must update the fault, or the fault silently stops planting
    text = (ROOT / fault.file).read_text(encoding="utf-8")
    assert text.count(fault.old) == 1, f"fault {fault.name!r}: snippet no longer matches {fault.file} once"
    assert fault.old != fault.new
    assert all((ROOT / t.split("::")[0]).exists() for t in fault.tests), fault.tests


def test_catalogue_is_large_unique_and_covers_every_area():
    names = [f.name for f in FAULTS]
    assert len(names) == len(set(names))
    assert len(FAULTS) >= 25
    assert {f.area for f in FAULTS} == set(PF.AREAS)
    assert PF.check_faults(FAULTS) == []
    required = {"closure-orientation-bias-offset", "closure-fixed-pair-index", "spm-eq59a-drop-term",
                "lagrange-christoffel-sign", "urdf-q-order-by-link-name", "kin-jdot-local-term-sign",
                "integrate-explicit-euler"}
    assert required <= set(names)


def test_stale_snippet_is_bad_usage(tmp_path):
    fault = dataclasses.replace(FAULTS[0], old="this text is in no source file")
    assert any(fault.name in p for p in PF.check_faults([fault]))
    assert PF.main(["--only", "no-such-fault"]) == 2


def test_rotation_is_deterministic_and_cycles():
    a, b = PF.rotation(3, seed=7), PF.rotation(3, seed=7)
    assert [f.name for f in a] == [f.name for f in b] and len(a) == 3
    days = -(-len(FAULTS) // 3)
    seen = {f.name for s in range(days) for f in PF.rotation(3, seed=s)}
    assert seen == {f.name for f in FAULTS}


def test_one_fault_end_to_end_is_caught(tmp_path):
    # Ψ(3,3) = cos φ (the chapter's misprint) against the finite-difference test of Ψ: pure numpy, no compile
    fault = dataclasses.replace(
        PF.by_name(["spm-psi-33-as-printed"])[0],
        tests=("tests/unit/test_spm_chapter.py::test_psi_and_its_derivative_against_finite_differences",))
    out = PF.run_fault(fault, rest=False, timeout=600)
    assert out.status == "caught", out
    assert "test_spm_chapter.py" in out.caught_by
    PF.write_report([out], tmp_path / "r.md", dict(argv="", date="today", commit="x", jobs=1, seconds=1.0))
    assert "1/1 caught" in (tmp_path / "r.md").read_text()
    assert (tmp_path / "r.json").exists()
