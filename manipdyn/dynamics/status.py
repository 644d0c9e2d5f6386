"""A kernel's status: the one convention of every compiled kernel's return value, and its reading.

Every kernel returns an int, its status (rnea, crba, aba, the M⁻¹ route, the derivatives, the regressor, the
Coriolis matrix, the energies, the frame kernels, forward kinematics, the closure rows, closed-chain dynamics):

  OK                −1: every state was computed
  bad_input(s)      s ≥ 0: state s (the row of the batch) has a non-finite input, or an angle too large to
                    turn accurately (spatial.SINCOS_MAX); the arguments are checked again in Python to name
                    the array and entry (``arguments.raise_kernel_error``)
  singular_joint(i) −2 − i: joint i moves a subtree without mass or inertia in some direction of its motion (a
                    vanishing pivot of the articulated or the joint-space inertia; ``singular_row`` finds the
                    joint of a row of M)
  bad_result(nb, k) −2 − nb − k: entry k (flat index) of the call's result in batch form is not finite: an
                    intermediate overflowed; for a call with several results, k runs through them in order
  WRONG_SIZES       2⁶²: an array of a one-state kernel has another length than the model's (nq, nv: the
                    kernel checks this before it reads anything, ``kernel_inputs.sized``; Python checks the types
                    and dimensions, which numba's unboxing needs)

A batch cut into chunks (threads, lane blocks, Dask) reads a chunk's status as the whole batch's with
``shift``; ``reading`` turns a status back into (what, index) for the error.
"""
from __future__ import annotations

from .._jit import njit

OK = -1
WRONG_SIZES = 2 ** 62


@njit(cache=True, inline="always")
def bad_input(s):
    """The status of state s with a non-finite input."""
    return s


@njit(cache=True, inline="always")
def singular_joint(i):
    """The status of a vanishing pivot in joint i's rows (of nb joints)."""
    return -2 - i


@njit(cache=True, inline="always")
def singular_row(I, r):
    """The status of a vanishing pivot in row r of M: ``singular_joint`` of the joint that owns velocity r (I: the
    model's kernel ints, rows idx_v and nv_j: ``model_arrays``)."""
    i = 0
    while I[3, i] + I[4, i] <= r:
        i += 1
    return singular_joint(i)


@njit(cache=True, inline="always")
def bad_result(nb, k):
    """The status of a non-finite result at flat index k, in a model of nb joints."""
    return -2 - nb - k


@njit(cache=True, inline="always")
def shift(status, s0, nb, size):
    """A chunk's status as the status of the whole batch, the chunk starting at row s0 (size: the result's entries
    per state): a state index moves by s0, a result's flat index by s0 · size; a joint's status is as it is."""
    if status >= 0:
        return status + s0
    if status <= -2 - nb:
        return status - s0 * size
    return status


def reading(status, nb):
    """(what, index): ("ok", -1), ("sizes", -1), ("input", state), ("joint", joint index) or ("result", flat
    index)."""
    status = int(status)
    if status == OK:
        return "ok", -1
    if status == WRONG_SIZES:
        return "sizes", -1
    if status >= 0:
        return "input", status
    if status >= -1 - nb:
        return "joint", -2 - status
    return "result", -2 - nb - status
