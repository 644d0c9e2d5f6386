"""Closed chains assemble from poor guesses (restarts when Newton from the guess fails); the result is
checked independently: the closure gap from frame_placement of both sides of the loop."""
import dataclasses

import numpy as np
import pytest
from conftest import ROOT

import manipdyn as md

TEXT = (ROOT / "urdf" / "fourbar.urdf").read_text()
FOURBAR = md.load_urdf_string(TEXT)


def closure_gap(model, q):
    """Independent check of the revolute closure 'loop': the coupler's end (0.35, 0, 0) and the rocker's
    end (0.3, 0, 0) coincide and their y axes are parallel; returns the largest violation."""
    Rc, pc = md.frame_placement(model, q, "coupler")
    Rr, pr = md.frame_placement(model, q, "rocker")
    gap = (pc + Rc @ [0.35, 0, 0]) - (pr + Rr @ [0.3, 0, 0])
    return max(np.max(np.abs(gap)), abs(1.0 - Rc[:, 1] @ Rr[:, 1]))


GUESSES = {
    "zeros": [0.0, 0.0, 0.0], "all_pi": [np.pi] * 3, "large_angles": [10.0, -7.0, 3.0],
    "crank_only": [0.5, 0.0, 0.0], "folded": [0.0, 3.0, -3.0], "twos": [2.0, 2.0, 2.0],
    "minus_pi": [-np.pi, 0.0, 0.0], "huge": [1e3, -1e3, 1e3],
}


@pytest.mark.parametrize("guess", list(GUESSES.values()), ids=list(GUESSES))
def test_fourbar_assembles_from_poor_guesses(guess):
    asm = md.assemble(FOURBAR, np.array(guess))
    assert closure_gap(FOURBAR, asm.q) <= 1e-12          # measured ≤ 4e-14
    assert asm.q[0] == guess[0]                          # the actuated crank is held at the guess
    assert asm.residual <= 1e-12


@pytest.mark.parametrize("guess", [GUESSES["zeros"], GUESSES["folded"]], ids=["zeros", "folded"])
def test_all_coordinates_free(guess):
    asm = md.assemble(FOURBAR, np.array(guess), fixed=[])
    assert closure_gap(FOURBAR, asm.q) <= 1e-12


def test_restarts_are_what_assembles_the_zero_guess():
    with pytest.raises(md.ConstraintError, match="did not converge.*closure 'loop' violated"):
        md.assemble(FOURBAR, np.zeros(3), restarts=0)


def test_restarts_are_seeded_and_reproducible():
    a, b = md.assemble(FOURBAR, np.zeros(3)), md.assemble(FOURBAR, np.zeros(3))
    assert np.array_equal(a.q, b.q)


def test_unassemblable_closure_names_the_closure_and_residual():
    short = md.load_urdf_string(TEXT.replace('<child_origin xyz="0.3 0 0"', '<child_origin xyz="0.9 0 0"'))
    with pytest.raises(md.ConstraintError,
                       match=r"nor from 4 seeded restarts: closure 'loop' violated .*smallest max\|Φ\| reached: "):
        md.assemble(short, [0.3, -1.3, -2.0], fixed=[], restarts=4)


def test_batch_is_assembled_row_by_row():
    # one type for one guess and a batch: an Assembly, its fields with a leading axis for the batch
    G = np.array([GUESSES["zeros"], GUESSES["twos"], GUESSES["large_angles"]])
    out = md.assemble(FOURBAR, G)
    assert type(out) is md.constraints.Assembly and out.q.shape == (3, 3)
    for k, g in enumerate(G):
        one = md.assemble(FOURBAR, g)
        assert type(one) is type(out) and one.q.shape == (3,)
        for field in dataclasses.fields(one):
            row, single = getattr(out, field.name)[k], getattr(one, field.name)
            assert np.shape(row) == np.shape(single) and np.array_equal(row, single), field.name
        assert closure_gap(FOURBAR, out.q[k]) <= 1e-12


def test_complete_state_batch_row_by_row():
    G = np.array([GUESSES["zeros"], GUESSES["twos"]])
    q, v, a, asm = md.complete_state(FOURBAR, G, [[1.0], [-2.0]], [0.5])
    assert q.shape == v.shape == a.shape == (2, 3) and asm.q.shape == (2, 3) and asm.residual.shape == (2,)
    assert np.array_equal(asm.q, q)
    for k in range(2):
        q1, v1, a1, _ = md.complete_state(FOURBAR, G[k], [[1.0], [-2.0]][k], [0.5])
        assert np.array_equal(q[k], q1) and np.array_equal(v[k], v1) and np.array_equal(a[k], a1)
        _, J, bias = md.constraints.closure_terms(FOURBAR, q[k], v[k])
        assert np.max(np.abs(J @ v[k])) <= 1e-12 and np.max(np.abs(J @ a[k] + bias)) <= 1e-11


def test_actuation_status_of_a_batch_is_per_row():
    Q = np.array([md.assemble(FOURBAR, g).q for g in (GUESSES["zeros"], GUESSES["twos"])])
    assert md.constraints.actuation_status(FOURBAR, Q) == ["fully", "fully"]


@pytest.mark.parametrize("call", [
    pytest.param(lambda x: md.assemble(FOURBAR, x), id="assemble"),
    pytest.param(lambda x: md.complete_state(FOURBAR, x, [1.0], [0.0]), id="complete_state"),
    pytest.param(lambda x: md.project(FOURBAR, x, np.zeros(3)), id="project"),
])
@pytest.mark.parametrize("bad", [[np.nan, 0, 0], [0, np.inf, 0], [0, 0, -np.inf]], ids=["nan", "inf", "-inf"])
def test_non_finite_guesses_are_refused(call, bad):
    with pytest.raises(md.InputError, match=r"^q\[\d\] \(joint 'j\d_\w+'\) is (nan|-?inf)"):
        call(np.array(bad))
