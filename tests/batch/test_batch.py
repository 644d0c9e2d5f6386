"""A batch (N, nv) equals the stack of single-state calls to 1e-14 (docs/design.md §3 measure); rnea's batches run the lane kernel (§4c)."""
import numpy as np
from conftest import AAU, assert_close, err, zoo_paths

from manipdyn import load_urdf, rnea, rnea_terms
from manipdyn.validation import random_states

BAXTER = next(p for p in zoo_paths() if p.name == "baxter.urdf")


def test_rnea_batch_equals_rows():
    for path in (AAU, BAXTER):
        model = load_urdf(path)
        Q, V, A = random_states(model, 64, np.random.default_rng(3))
        tau = rnea(model, Q, V, A)
        assert tau.shape == (64, model.nv)
        assert_close(tau, np.stack([rnea(model, q, v, a) for q, v, a in zip(Q, V, A)]), 1e-15, path.name)  # measured ≤ 2.1e-16 (lanes)


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
            assert_close(batch[k][s], one[k], 1e-15, k)  # measured 0 (bit-identical)


def test_lagrange_and_forward_batch_equals_rows():
    import manipdyn as md
    model = load_urdf(BAXTER)
    Q, V, A = random_states(model, 8, np.random.default_rng(9))
    calls = {
        "mass_matrix": lambda q, v, a: md.mass_matrix(model, q),
        "mass_matrix_lagrange": lambda q, v, a: md.mass_matrix(model, q, method="lagrange"),
        "coriolis_matrix": lambda q, v, a: md.coriolis_matrix(model, q, v),
        "gravity_torques": lambda q, v, a: md.gravity_torques(model, q),
        "nonlinear_effects": lambda q, v, a: md.nonlinear_effects(model, q, v),
        "aba": lambda q, v, a: md.aba(model, q, v, a),
        "cholesky": lambda q, v, a: md.forward_dynamics(model, q, v, a, method="cholesky"),
        "frame_jacobian": lambda q, v, a: md.frame_jacobian(model, q, model.body_names[7]),
        "frame_jacobian_local": lambda q, v, a: md.frame_jacobian(model, q, model.body_names[7], "local"),
        "frame_jacobian_dot": lambda q, v, a: md.frame_jacobian_dot(model, q, v, model.body_names[7], "local"),
        "frame_placement": lambda q, v, a: np.concatenate(
            [x.reshape(x.shape[:-2] + (-1,)) if x.ndim >= 2 and x.shape[-1] == 3 and x.shape[-2] == 3 else x
             for x in md.frame_placement(model, q, model.body_names[7])], axis=-1),
    }
    for name, f in calls.items():
        batch = f(Q, V, A)
        rows = np.stack([f(q, v, a) for q, v, a in zip(Q, V, A)])
        assert batch.shape == rows.shape, name
        assert_close(batch, rows, 1e-15, name)  # measured 0 (bit-identical)


def test_energy_and_closed_chain_batch_equals_rows():
    import manipdyn as md
    from conftest import ROOT
    from manipdyn.validation.closed import manifold_states
    arm = load_urdf(AAU)
    Q, V, A = random_states(arm, 8, np.random.default_rng(12))
    for f in (lambda q, v: md.kinetic_energy(arm, q, v), lambda q, v: md.potential_energy(arm, q)):
        assert_close(f(Q, V), np.array([f(q, v) for q, v in zip(Q, V)]), 1e-15, "energy")  # measured 2.8e-17
    spm = load_urdf(ROOT / "urdf" / "spm.urdf")
    rng = np.random.default_rng(13)
    Qm, Vm = manifold_states(spm, 6, rng)
    T = rng.normal(size=Qm.shape)
    qdd, lam = md.constrained_forward_dynamics(spm, Qm, Vm, T, baumgarte=(5.0, 5.0))
    for s in range(6):
        one = md.constrained_forward_dynamics(spm, Qm[s], Vm[s], T[s], baumgarte=(5.0, 5.0))
        assert_close(qdd[s], one[0], 1e-15, "q̈ rows")  # measured 0 (bit-identical)
        assert_close(lam[s], one[1], 1e-15, "λ rows")  # measured 0 (bit-identical)
    Ad = qdd                                                       # a motion consistent with the closures
    ta, _ = md.constrained_inverse_dynamics(spm, Qm, Vm, Ad)
    assert_close(ta, np.stack([md.constrained_inverse_dynamics(spm, q, v, a)[0] for q, v, a in zip(Qm, Vm, Ad)]),
                 1e-15, "τ_a rows")  # measured 0 (bit-identical)


def test_one_state_f_ext_fast_path_equals_the_checked_batch():
    """One float64 state with f_ext takes the per-model wrench rows (state.fast_wrench_rows); a batch takes the
    checked conversion (arguments.wrench_rows): the rows must agree, both frames, a frame with an offset in its body."""
    import manipdyn as md
    model = load_urdf(BAXTER)
    rng = np.random.default_rng(14)
    Q, V, A = random_states(model, 6, rng)
    F, M = rng.normal(size=(6, 3)), rng.normal(size=(6, 3))
    turned = next(f for f, fr in model.frames.items() if fr.body >= 0 and np.any(fr.p)
                  and not np.allclose(fr.R, np.eye(3)))              # offset and turned in its body
    names = [model.body_names[5], turned]
    worst = 0.0                                                      # measured 3.2e-15
    for frame in ("local", "world"):
        for subset in ([names[0]], [names[1]], names):          # one wrench (the fast path) and two
            fx = {n: (F, M) for n in subset}
            for call in (lambda q, v, a, f: md.rnea(model, q, v, a, f_ext=f, f_ext_frame=frame),
                         lambda q, v, a, f: md.aba(model, q, v, a, f_ext=f, f_ext_frame=frame),
                         lambda q, v, a, f: md.forward_dynamics(model, q, v, a, f_ext=f, f_ext_frame=frame,
                                                                method="cholesky")):
                batch = call(Q, V, A, fx)
                rows = np.stack([call(Q[s], V[s], A[s], {n: (F[s], M[s]) for n in subset}) for s in range(6)])
                worst = max(worst, err(batch, rows))
                # docs/design.md §5; batches fuse multiply-adds (_jit.CONTRACT)
                assert_close(batch, rows, 1e-14, frame)
    print(f"\nworst {worst:.1e}")
