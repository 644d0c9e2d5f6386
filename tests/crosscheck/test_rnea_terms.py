"""Every Newton–Euler term against Pinocchio, on the AAU arm and every zoo arm: 1000 random states each."""
import warnings

import pytest
from conftest import AAU, zoo_paths

from manipdyn import load_urdf
from manipdyn.validation import validate
from manipdyn.validation.zoo import ARMS

PATHS = [AAU] + zoo_paths()


def test_the_zoo_is_complete():
    # a missing robot must fail loudly, not shrink the cross-check silently
    assert AAU.is_file()
    assert len(PATHS) - 1 == len(ARMS) >= 10


@pytest.mark.parametrize("path", PATHS, ids=lambda p: p.stem)
def test_every_term_matches_pinocchio(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = load_urdf(path)
    rep = validate(model, path, n_states=1000, seed=1, tol=5e-13)   # measured ≤ 7.4e-15 on every term (talos nle)
    bad = [f"{t.label}: {t.err:.2e}" for t in rep.terms if not t.passed]
    assert not bad, f"{path.name}: {bad}; {rep.fault}"
    assert rep.fault is None
    assert {t.term for t in rep.terms} >= {"w", "v", "dw", "acc", "fc", "nO", "f", "n", "tau", "tau_ext"}
