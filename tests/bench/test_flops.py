"""The flop counter of the bench (manipdyn/bench/flops.py): it counts what it is shown, and the lane kernels'
counts grow with the bodies as the algorithms do — O(n) for the RNEA and the ABA, O(n²) for the CRBA on a chain
(RBDA §6.2: its column pass carries each column to the root)."""
import numpy as np

from manipdyn.bench import flops
from manipdyn.bench.flops import Flop
from manipdyn.spatial import cross


def test_flop_counts_each_operation_once():
    flops._COUNT[0] = 0
    a, b = (Flop(1.0), Flop(2.0), Flop(3.0)), (4.0, 5.0, 6.0)
    c = getattr(cross, "py_func", cross)(a, b)   # as Python (the counter runs the kernels so): 6 products, 3 differences
    assert flops._COUNT[0] == 9 and np.allclose(c, np.cross([1, 2, 3], [4, 5, 6]))
    d = -c[0] / 2.0 + abs(c[1])                   # a sign and an absolute value are not flops
    assert flops._COUNT[0] == 11 and isinstance(d, Flop)


def test_lane_kernel_counts_grow_with_the_bodies_as_the_algorithms_do():
    n = {f"chain{k}": f"chain:{k}" for k in (4, 8, 16)}
    c = flops.counts(n)
    for call in ("rnea", "aba"):                  # linear: equal increments per 4, 8 bodies (per body: 8)
        per_body = (c["chain16"][call] - c["chain8"][call]) / 8
        assert abs((c["chain8"][call] - c["chain4"][call]) / 4 - per_body) <= 0.02 * per_body, call
        assert 100 < per_body < 2000, (call, per_body)
    m = [c[f"chain{k}"]["mass_matrix"] for k in (4, 8, 16)]
    d1, d2 = m[1] - m[0], m[2] - m[1]             # quadratic: second differences over doubling spans
    assert d2 / d1 > 2.5, m
