"""The error measure (docs/design.md §3), used by validate, the bench and the tests alike.

For a term x against a reference y (vector or matrix, SI units):
    err = max|x − y| / max(max|y|, 1)
over the whole term — relative to its largest entry, absolute for terms below 1; never element-wise
relative error (a Coriolis entry near zero would make it meaningless).
"""
from __future__ import annotations

import numpy as np

from ..errors import ManipdynError


def error(x, y) -> float:
    """err = max|x − y| / max(max|y|, 1)  (docs/design.md §3)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    if x.shape != y.shape:     # never let broadcasting compare the wrong entries
        raise ManipdynError(f"validation compares arrays of shapes {x.shape} and {y.shape}")
    return float(np.max(np.abs(x - y)) / max(np.max(np.abs(y)), 1.0)) if y.size else 0.0
