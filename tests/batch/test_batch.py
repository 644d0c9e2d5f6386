"""A batch (N, nv) equals the stack of single-state calls to 1e-14 (DESIGN.md §3 measure)."""
import numpy as np
from conftest import AAU, assert_close, zoo_paths

from manipdyn import load_urdf, rnea, rnea_terms
from manipdyn.validation import random_states

BAXTER = next(p for p in zoo_paths() if p.name == "baxter.urdf")


def test_rnea_batch_equals_rows():
    for path in (AAU, BAXTER):
        model = load_urdf(path)
        Q, V, A = random_states(model, 64, np.random.default_rng(3))
        tau = rnea(model, Q, V, A)
        assert tau.shape == (64, model.nv)
        assert_close(tau, np.stack([rnea(model, q, v, a) for q, v, a in zip(Q, V, A)]), 1e-14, path.name)


def test_rnea_terms_batch_and_f_ext_batch():
    model = load_urdf(BAXTER)
    rng = np.random.default_rng(4)
    Q, V, A = random_states(model, 16, rng)
    F, M = rng.normal(size=(16, 3)), rng.normal(size=(16, 3))
    frame = model.body_names[5]
    batch = rnea_terms(model, Q, V, A, f_ext={frame: (F, M)}, f_ext_frame="world")
    for s in range(16):
        one = rnea_terms(model, Q[s], V[s], A[s], f_ext={frame: (F[s], M[s])}, f_ext_frame="world")
        for k in ("w", "dw", "v", "dv", "acc", "dvc", "fc", "nc", "f", "n", "tau"):
            assert one[k].shape == batch[k].shape[1:]
            assert_close(batch[k][s], one[k], 1e-14, k)
