"""Bad arguments raise InputError naming the array, joint or frame at fault."""
import numpy as np
import pytest
from conftest import AAU

from manipdyn import InputError, load_urdf, rnea

MODEL = load_urdf(AAU)
Z = np.zeros(MODEL.nv)


@pytest.mark.parametrize("q,v,a,match", [
    (np.zeros(3), Z, Z, r"q has shape \(3,\)"),
    (Z, np.zeros((2, MODEL.nv)), Z, r"v has shape"),
    (Z, Z, np.zeros((2, 3, MODEL.nv)), r"a has shape"),
    (np.r_[Z[:-1], np.nan], Z, Z, r"q\[4\] \(joint 'joint5'\) is nan"),
    (Z, np.r_[np.inf, Z[1:]], Z, r"v\[0\] \(joint 'joint1'\) is inf"),
    ("abc", Z, Z, r"q: cannot be read"),
])
def test_bad_state(q, v, a, match):
    with pytest.raises(InputError, match=match):
        rnea(MODEL, q, v, a)


def test_bad_f_ext():
    with pytest.raises(InputError, match="no link or frame named 'nowhere'"):
        rnea(MODEL, Z, Z, Z, f_ext={"nowhere": (np.zeros(3), np.zeros(3))})
    with pytest.raises(InputError, match=r"f_ext\['tool'\]"):
        rnea(MODEL, Z, Z, Z, f_ext={"tool": (np.zeros(2), np.zeros(3))})
    with pytest.raises(InputError, match="f_ext_frame"):
        rnea(MODEL, Z, Z, Z, f_ext={"tool": (np.zeros(3), np.zeros(3))}, f_ext_frame="base")
    with pytest.raises(InputError, match=r"f_ext\['tool'\].* is nan"):
        rnea(MODEL, Z, Z, Z, f_ext={"tool": (np.array([0, np.nan, 0]), np.zeros(3))})
