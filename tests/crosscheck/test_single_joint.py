"""One-joint arms validate against Pinocchio: eigenpy hands 6 × 1 Jacobians back as (6,) vectors, and a
broadcast of (6, 1) against (6,) once failed correct models (and the error measure now refuses mismatched
shapes instead of broadcasting them)."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import inertial_xml, urdf

from manipdyn import load_urdf_string
from manipdyn.errors import ManipdynError
from manipdyn.validation import validate
from manipdyn.validation.measure import error

BODY = inertial_xml(1.3, (0.1, -0.05, 0.2), (0.1, 0.12, 0.08, 0.01, -0.02, 0.005))


@pytest.mark.parametrize("jtype,axis", [("revolute", (1, 0, 0)), ("revolute", (0, 0, 1)),
                                        ("continuous", (0, 1, 0)), ("prismatic", (0.3, -0.4, 0.866))])
def test_one_joint_arm_passes_every_term(tmp_path, jtype, axis):
    text = urdf({"base": "", "arm": BODY}, [("j", jtype, "base", "arm", (0.1, 0, 0.2), (0.3, 0, 0), axis)])
    path = tmp_path / "one.urdf"
    path.write_text(text)
    rep = validate(load_urdf_string(text), path, n_states=20, seed=3, tol=1e-13)
    worst = max(t.err for t in rep.terms)
    assert rep.passed, [t.label for t in rep.terms if not t.passed]
    assert worst <= 1e-13                # measured 2.0e-15 (worst term, prismatic)


def test_error_measure_refuses_mismatched_shapes():
    with pytest.raises(ManipdynError, match="shapes"):
        error(np.zeros((6, 1)), np.zeros(6))


def test_validate_holds_the_lagrange_mass_matrix_to_pinocchio(tmp_path, monkeypatch):
    """Both our M routes shifted alike: validate must flag each against Pinocchio, not one against the other."""
    import manipdyn.validation.compare as compare
    text = urdf({"base": "", "arm": BODY}, [("j", "revolute", "base", "arm", (0.1, 0, 0.2), (0.3, 0, 0), (0, 0, 1))])
    path = tmp_path / "one.urdf"
    path.write_text(text)
    real = compare.mass_matrix
    monkeypatch.setattr(compare, "mass_matrix", lambda *a, **k: real(*a, **k) + 1e-6)
    rep = validate(load_urdf_string(text), path, n_states=5, seed=3, tol=1e-13)
    failed = {t.term for t in rep.terms if not t.passed}
    assert {"M_crba", "M_lagrange"} <= failed, failed
