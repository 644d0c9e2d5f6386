"""The identification example (manipdyn/examples/identify.py) on the AAU arm.

Without noise the base parameters are exact and predict a second trajectory's torques (from rnea) to
round-off. With torque noise σ the errors follow least-squares theory, with bounds derived here from the
regressor (not from the example's output): the prediction error e' = W₁'(β̂ − β) is a Gaussian vector with
covariance σ² W₁'(W₁ᵀW₁)⁻¹W₁'ᵀ, so its mean square ‖e'‖²/M' has expectation σ² tr(A)/M' and variance
2σ⁴ tr(A²)/M'² (A = W₁'(W₁ᵀW₁)⁻¹W₁'ᵀ); against the noisy measured torques the mean square adds the fresh
noise, σ² + ‖e'‖²/M', with a sample spread of σ² √(2/M'). Each check allows five standard deviations.
"""
import numpy as np
import pytest
from conftest import AAU, err

import manipdyn as md
from manipdyn.examples import identify as ex

ARM = md.load_urdf(AAU)


def test_without_noise_the_base_parameters_predict_rnea():
    res = ex.identify(ARM, sigma=0.0, seed=0)
    assert res.rank == 29 and res.n_params == 50          # the AAU arm: 29 identifiable combinations of 50
    (q, v, a) = res.trajectories[1]
    tau = md.rnea(ARM, q, v, a)
    Y = md.joint_torque_regressor(ARM, q, v, a).reshape(-1, 50)
    pred = (Y[:, res.columns] @ res.beta_hat).reshape(tau.shape)
    assert err(pred, tau) <= 1e-13                         # measured 1.8e-15
    assert res.max_test_err <= 1e-13                       # the example's own figure: measured 1.8e-15
    assert err(res.beta_hat, res.beta_true) <= 1e-13       # measured 1.5e-15
    # the base parameters of any π predict that π's torques: a physical π of a different arm
    other = md.model_with_parameters(ARM, md.dynamic_parameters(ARM) * 1.7)
    P, r, K = ex.base_parameters(md.joint_torque_regressor(ARM, *res.trajectories[0]).reshape(-1, 50))
    pi = md.dynamic_parameters(other)
    beta = pi[P[:r]] + K @ pi[P[r:]]
    assert err((Y[:, P[:r]] @ beta).reshape(tau.shape), md.rnea(other, q, v, a)) <= 5e-14   # measured 5.0e-16


def _bounds(res):
    """Expected mean square of the prediction error and its standard deviation (module docstring)."""
    (q1, v1, a1), (q2, v2, a2) = res.trajectories
    W1 = md.joint_torque_regressor(ARM, q1, v1, a1).reshape(-1, 50)[:, res.columns]
    W2 = md.joint_torque_regressor(ARM, q2, v2, a2).reshape(-1, 50)[:, res.columns]
    A = W2 @ np.linalg.solve(W1.T @ W1, W2.T)
    M, s2 = W2.shape[0], res.sigma ** 2
    return s2 * np.trace(A) / M, s2 * np.sqrt(2 * np.sum(A * A)) / M, M


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_with_noise_the_prediction_error_is_the_least_squares_one(seed):
    res = ex.identify(ARM, sigma=0.5, seed=seed)
    mean, std, M = _bounds(res)
    ms = res.rms_test_true ** 2
    assert abs(ms - mean) <= 5 * std, (ms, mean, std)     # seeds 0-2: −0.56, −0.33, −0.43 std
    assert res.rms_test_true < 0.05 * res.rms_tau          # a useful model: measured 0.96-1.3 % of RMS τ
    s2 = res.sigma ** 2                                    # against the noisy torques: ≈ σ
    spread = s2 * np.sqrt(2 / M) + 2 * res.sigma * res.rms_test_true / np.sqrt(M)
    assert abs(res.rms_test ** 2 - s2 - ms) <= 5 * spread        # measured −0.51, 0.14, 0.01 spreads
    assert abs(res.rms_test_expected ** 2 - mean) <= 1e-12 * mean   # the example reports the same expectation
    z = (res.beta_hat - res.beta_true) / res.beta_std      # each β̂ within 5 std: max |z| 1.8, 2.7, 3.3
    assert np.all(np.abs(z) <= 5), z


def test_the_example_is_deterministic_and_prints_its_numbers(capsys, tmp_path):
    a, b = ex.identify(ARM, samples=50, seed=4), ex.identify(ARM, samples=50, seed=4)
    assert np.array_equal(a.beta_hat, b.beta_hat) and a.rms_test == b.rms_test
    assert ex.main(["--samples", "60", "--seed", "1", "--csv", str(tmp_path / "b.csv")]) == 0
    out = capsys.readouterr().out                          # the default arm has drives: + 15 joint parameters
    assert "rank 42 of 65" in out and "prediction error RMS" in out and "friction[joint1]" in out
    assert len((tmp_path / "b.csv").read_text().splitlines()) == 43


def test_the_cli_example_runs(tmp_path, capsys):
    from manipdyn.cli import main
    assert main(["example", "identify", "--out", str(tmp_path), "--samples", "80"]) == 0
    assert (tmp_path / "identify_aau.csv").is_file()
    assert "rank 42 of 65" in capsys.readouterr().out


ARM_JD = md.load_urdf(AAU, joint_dynamics=ex.DEMO_JOINT_DYNAMICS)


def _drive(q, v, a):
    """The drives' torque, written out: rnea (rigid bodies + armature ⊙ q̈) + damping ⊙ q̇ + friction ⊙ tanh(q̇/ε)."""
    return md.rnea(ARM_JD, q, v, a) + ARM_JD.damping * v + ARM_JD.friction * np.tanh(v / md.model.FRICTION_EPS)


def test_joint_dynamics_are_identified_with_the_inertial_parameters():
    """armature, damping and friction of every joint join π (65 parameters, 42 identifiable: joint 1's and 2's
    armature act with link inertias about their axes); without noise every base parameter, and so every damping
    and friction and the armatures of joints 3-5, comes back exact, and predicts the drive torques."""
    res = ex.identify(ARM_JD, sigma=0.0, seed=0)
    assert res.rank == 42 and res.n_params == 65
    assert err(res.beta_hat, res.beta_true) <= 1e-13                           # measured 5.0e-15
    alone = {lab: k for k, lab in enumerate(res.labels) if " " not in lab}     # a parameter that is its own base
    for key, values in (("damping", ARM_JD.damping), ("friction", ARM_JD.friction)):
        for j, name in enumerate(ARM_JD.v_names):
            assert abs(res.beta_hat[alone[f"{key}[{name}]"]] - values[j]) <= 1e-12 * max(values[j], 1)
    for j in (2, 3, 4):
        assert abs(res.beta_hat[alone[f"armature[joint{j + 1}]"]] - ARM_JD.armature[j]) <= 1e-12
    (q, v, a) = res.trajectories[1]
    W = ex.regressor(ARM_JD, q, v, a, True)
    assert err((W[:, res.columns] @ res.beta_hat).reshape(q.shape), _drive(q, v, a)) <= 1e-13   # measured 1.9e-15
    rigid = ex.identify(ARM_JD, sigma=0.0, seed=0, joint_dynamics=False)       # without the joints' columns, rnea's
    assert rigid.rank == 29 and rigid.max_test_err > 1e-3                      # armature ⊙ q̈ is missed: 1.0e-2


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_with_noise_the_joint_dynamics_are_within_their_error_bars(seed):
    res = ex.identify(ARM_JD, sigma=0.5, seed=seed)
    z = (res.beta_hat - res.beta_true) / res.beta_std
    assert np.all(np.abs(z) <= 5), z                       # measured max |z| 1.8, 2.9, 2.7 over the 42
    assert res.rms_test_true < 0.05 * res.rms_tau          # measured 1.1-1.5 % of RMS τ
