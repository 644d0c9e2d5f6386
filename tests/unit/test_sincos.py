"""spatial.sincos, the branch-free sin and cos of the lane kernels, against numpy's (libm's) sin and cos: within
1 ulp for |x| ≤ 256, within 2 ulp and 1.2e-16 absolute up to SINCOS_MAX, exact at 0."""
import numpy as np
import pytest

from manipdyn import _jit
from manipdyn.spatial import SINCOS_MAX, sincos

pytestmark = pytest.mark.skipif(_jit.NOJIT, reason="compiled with numba (uncompiled it runs as Python, slowly)")


@_jit.njit
def _table(x, s, c):
    for k in range(x.shape[0]):
        s[k], c[k] = sincos(x[k])


def _errors(x):
    """Worst error of sin and cos in ulps of libm's value, worst absolute error, and the share of equal values."""
    s, c = np.empty_like(x), np.empty_like(x)
    _table(x, s, c)
    ulps = max((np.abs(s - np.sin(x)) / np.spacing(np.abs(np.sin(x)))).max(),
               (np.abs(c - np.cos(x)) / np.spacing(np.abs(np.cos(x)))).max())
    return ulps, max(np.abs(s - np.sin(x)).max(), np.abs(c - np.cos(x)).max()), min(np.mean(s == np.sin(x)),
                                                                                    np.mean(c == np.cos(x)))


def test_within_one_ulp_of_libm_for_forty_turns():
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.uniform(-np.pi, np.pi, 200_000), rng.uniform(-256, 256, 400_000),
                        np.linspace(-7, 7, 100_001),
                        np.pi / 4 * np.arange(-320, 321) + rng.uniform(-1e-9, 1e-9, 641),   # quadrant switches
                        np.array([1e-300, 5e-324, -1e-17, 1e-8, 256.0, -256.0])])
    ulps, absolute, equal = _errors(x)
    assert ulps <= 1.0                        # measured 1.0
    assert absolute <= 1.2e-16                # measured 1.11e-16
    assert equal > 0.8                        # measured 0.84: most values equal libm's


def test_within_two_ulp_up_to_the_lane_limit():
    x = np.random.default_rng(1).uniform(-SINCOS_MAX, SINCOS_MAX, 400_000)
    ulps, absolute, _ = _errors(np.concatenate([x, [SINCOS_MAX, -SINCOS_MAX]]))
    assert ulps <= 2.0 and absolute <= 1.2e-16        # measured 2.0, 1.11e-16


def test_zero_and_signed_zero():
    s, c = np.empty(2), np.empty(2)
    _table(np.array([0.0, -0.0]), s, c)
    assert s[0] == 0.0 and c[0] == 1.0 and c[1] == 1.0 and s[1] == 0.0
