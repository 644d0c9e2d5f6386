"""Identifying the AAU arm's dynamic parameters from noisy joint torques, through the regressor.

τ = Y(q, q̇, q̈) π is linear in the 10 nb dynamic parameters π (``dynamics.regressor``), so K samples of a
trajectory stack into W π = τ with W (K nv × 10 nb). Not every parameter moves a torque: W has rank
r < 10 nb on any trajectory (the first link turns about a fixed axis, so only its I_zz counts; a link's mass
and the inertia of the next link about their common axis act together...). The identifiable combinations,
the *base parameters*, come out of a QR factorisation with column pivoting (Gautier & Khalil 1990; Khalil &
Dombre 2002, §12.4.3; Gautier 1991, "Numerical calculation of the base inertial parameters"):

    W P = Q R,  R = [[R₁₁, R₁₂], [0, R₂₂ ≈ 0]]  (R₁₁ r × r, |R_kk| > tol |R₀₀| for k < r)
    W₂ = W₁ K with K = R₁₁⁻¹ R₁₂,   so   W π = W₁ β,  β = π₁ + K π₂      (π₁, π₂: π in pivot order)

β (r,) are the base parameters; the least-squares estimate from noisy torques τ_m = τ + ε, ε ~ N(0, σ²):

    β̂ = argmin ‖W₁ β − τ_m‖ = R₁₁⁻¹ Q₁ᵀ τ_m,     Cov β̂ = σ² (W₁ᵀ W₁)⁻¹.

The exciting trajectory is a finite Fourier series per joint (Swevers, Ganseman, Tükel, De Schutter & Van
Brussel 1997, Eq. 8), with q, q̇, q̈ analytic:

    q_j(t) = q_j0 + Σ_{l=1..L} a_jl/(ω_f l) sin(ω_f l t) − b_jl/(ω_f l) cos(ω_f l t)
    q̇_j(t) = Σ a_jl cos(ω_f l t) + b_jl sin(ω_f l t),   q̈_j(t) = Σ ω_f l (b_jl cos(ω_f l t) − a_jl sin(ω_f l t))

The torques are the model's own (``rnea``, gravity included) plus noise. With the joints' own dynamics (the
default arm has them: ``DEMO_JOINT_DYNAMICS``) the drive torque adds the rotor and the losses, and π grows by
3 nv parameters, each linear in τ: τ_j += armature_j q̈_j (in ``rnea``) + damping_j q̇_j + friction_j tanh(q̇_j/ε)
(``aba.passive_torques``), so W gains the columns q̈_j, q̇_j, tanh(q̇_j/ε) in joint j's rows. The first joint's
armature acts with its link's I_zz (both multiply q̈_1 alone): one base parameter holds their sum. The identified β̂ predicts the
torques of a second, different trajectory, τ̂' = W₁' β̂ (W₁' the same pivoted columns of its regressor);
the prediction error there, against the noise-free torques, has expected mean square
σ² ‖W₁' R₁₁⁻¹‖_F² / (K' nv) — small when the first trajectory excites every base parameter — and against the
noisy measured torques it is about σ.
"""
from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from ..dynamics.aba import passive_torques
from ..dynamics.regressor import PARAMETER_NAMES, dynamic_parameters, joint_torque_regressor
from ..dynamics.rnea import rnea
from ..model import FRICTION_EPS, JOINT_DYNAMICS
from ..paths import bundled_dir

RANK_TOL = 1e-8          # |R_kk| / |R_00| below this: a column that depends on the earlier ones
# the default arm's drives: rotor inertia reflected through a gearbox (kg m²), viscous damping (N m s/rad) and
# Coulomb friction (N m) per joint, of the size a harmonic drive of a 5-10 kg arm has (illustrative values)
DEMO_JOINT_DYNAMICS = {f"joint{j + 1}": dict(armature=a, damping=d, friction=f) for j, (a, d, f) in enumerate(
    ((0.20, 2.0, 3.0), (0.20, 2.0, 3.0), (0.10, 1.0, 2.0), (0.05, 0.5, 1.0), (0.02, 0.2, 0.5)))}


@dataclass
class FourierTrajectory:
    """q(t) = q0 + Σ_l a_l/(ω_f l) sin(ω_f l t) − b_l/(ω_f l) cos(ω_f l t), per joint (module docstring)."""
    q0: np.ndarray        # (nv,) offset, rad
    a: np.ndarray         # (nv, L) sine coefficients of q̇, rad/s
    b: np.ndarray         # (nv, L) cosine coefficients of q̇, rad/s
    wf: float             # base angular frequency ω_f, rad/s

    def sample(self, t):
        """q, q̇, q̈ (K, nv) at the times t (K,)."""
        t = np.asarray(t, float)
        w = self.wf * np.arange(1, self.a.shape[1] + 1)              # ω_f l, (L,)
        s, c = np.sin(np.outer(t, w)), np.cos(np.outer(t, w))       # (K, L)
        q = self.q0 + s @ (self.a / w).T - c @ (self.b / w).T
        v = c @ self.a.T + s @ self.b.T
        a = (c @ (self.b * w).T) - (s @ (self.a * w).T)
        return q, v, a

    @classmethod
    def random(cls, nv, rng, harmonics=5, period=10.0, speed=0.6):
        """Random coefficients, a, b ~ N(0, (speed/√L)²) rad/s, q0 ~ U(−1, 1) rad: a peak joint speed of a
        few times ``speed``."""
        k = speed / np.sqrt(harmonics)
        return cls(rng.uniform(-1.0, 1.0, nv), rng.normal(0.0, k, (nv, harmonics)),
                   rng.normal(0.0, k, (nv, harmonics)), 2 * np.pi / period)


@dataclass
class Identification:
    """What ``identify`` found (β: base parameters, in SI units of the parameters they combine)."""
    labels: list              # (r,) each base parameter as its combination of π's entries
    beta_true: np.ndarray     # (r,) β of the model's own π
    beta_hat: np.ndarray      # (r,) identified from the noisy torques
    beta_std: np.ndarray      # (r,) standard deviation of β̂, σ √diag((W₁ᵀW₁)⁻¹)
    rank: int                 # r, of n_params = 10 nb
    columns: np.ndarray       # (r,) the entries of π whose regressor columns W₁ holds (P[:r], pivot order)
    n_params: int             # 10 nb inertial parameters (+ 3 nv armature, damping, friction)
    cond: float               # cond(W₁): the excitation of the base parameters
    sigma: float              # torque noise σ, N·m
    seed: int
    samples: int              # K per trajectory
    rms_fit: float            # RMS of W₁ β̂ − τ_m on the identification trajectory
    rms_test: float           # RMS of τ̂' − τ'_m on the second trajectory (noisy measurements)
    rms_test_true: float      # RMS of τ̂' − τ' (noise-free torques)
    rms_test_expected: float  # σ ‖W₁' R₁₁⁻¹‖_F / √(K nv): the expected value of rms_test_true
    rms_tau: float            # RMS of τ' (the scale the errors compare with)
    max_test_err: float       # max|τ̂' − τ'| / max(max|τ'|, 1) (docs/design.md §3 measure)
    trajectories: tuple       # ((q, q̇, q̈) identification, (q, q̇, q̈) test), each (K, nv)

    @property
    def relative_test_error(self) -> float:
        """rms_test_true / rms_tau."""
        return self.rms_test_true / self.rms_tau


def base_parameters(W, tol=RANK_TOL):
    """(P, r, K): column order P (n,) from QR with column pivoting of W, the rank r (|R_kk| > tol |R_00|),
    and K (r, n − r) = R₁₁⁻¹ R₁₂, so that W[:, P[r:]] = W[:, P[:r]] K and β = π[P[:r]] + K π[P[r:]]."""
    from scipy.linalg import qr, solve_triangular
    _, R, P = qr(W, mode="economic", pivoting=True)
    d = np.abs(np.diag(R))
    r = int(np.sum(d > tol * d[0])) if d.size and d[0] > 0 else 0
    K = solve_triangular(R[:r, :r], R[:r, r:]) if r else np.zeros((0, W.shape[1]))
    return P, r, K


def parameter_names(model, joint_dynamics):
    """The names of π's entries: 'p[body]' of the 10 nb inertial parameters, then (joint_dynamics)
    'armature[v]', 'damping[v]', 'friction[v]' of each velocity v."""
    names = [f"{PARAMETER_NAMES[c % 10]}[{model.body_names[c // 10]}]" for c in range(10 * model.njoints)]
    return names + ([f"{k}[{v}]" for k in JOINT_DYNAMICS for v in model.v_names] if joint_dynamics else [])


def _labels(names, P, r, K, terms=3):
    """Each base parameter as 'p[body] + k p'[body'] …' (the few largest of its combination)."""
    out = []
    for k in range(r):
        extra = [(K[k, m], names[P[r + m]]) for m in np.argsort(-np.abs(K[k])) if abs(K[k, m]) > 1e-10]
        text = names[P[k]] + "".join(f" {'+' if x > 0 else '−'} {abs(x):.3g} {n}" for x, n in extra[:terms])
        out.append(text + (f" + … ({len(extra) - terms} more)" if len(extra) > terms else ""))
    return out


def regressor(model, q, v, a, joint_dynamics):
    """W (K nv, n) with τ = W π: the inertial parameters' columns (``joint_torque_regressor``), then with
    joint_dynamics the columns of each velocity's armature (q̈_j), damping (q̇_j) and friction (tanh(q̇_j/ε)),
    nonzero in that velocity's rows only."""
    W = joint_torque_regressor(model, q, v, a).reshape(-1, 10 * model.njoints)
    if not joint_dynamics:
        return W
    E = np.eye(model.nv)
    extra = [(x[:, :, None] * E).reshape(-1, model.nv) for x in (a, v, np.tanh(v / FRICTION_EPS))]
    return np.hstack([W] + extra)


def parameters(model, joint_dynamics):
    """π: ``dynamic_parameters`` then, with joint_dynamics, model.armature, damping, friction."""
    pi = dynamic_parameters(model)
    return np.concatenate([pi] + [np.asarray(getattr(model, k), float) for k in JOINT_DYNAMICS]) \
        if joint_dynamics else pi


def drive_torques(model, q, v, a, joint_dynamics):
    """What the drives deliver: rnea (with the rotors' armature ⊙ q̈) and, with joint_dynamics, the losses."""
    tau = rnea(model, q, v, a)
    loss = passive_torques(model, v) if joint_dynamics else None
    return tau if loss is None else tau + loss


def _stack(model, traj, t, jd):
    q, v, a = traj.sample(t)
    return (q, v, a), regressor(model, q, v, a, jd), drive_torques(model, q, v, a, jd)


def identify(model=None, *, samples=400, sigma=0.5, seed=0, duration=10.0, harmonics=5,
             joint_dynamics=None) -> Identification:
    """Identify the base parameters of ``model`` (default: the bundled AAU arm, with the drives of
    ``DEMO_JOINT_DYNAMICS``) from ``samples`` noisy torque samples (noise σ, N·m) of one random Fourier
    trajectory, and test them on a second one. joint_dynamics: also identify each joint's armature, damping
    and friction (None: when the model has any).

    Deterministic for a given seed: the trajectories and the noise come from numpy's default_rng(seed).
    """
    if model is None:
        from ..io.urdf import load_urdf
        model = load_urdf(bundled_dir() / "aau_arm.urdf", joint_dynamics=DEMO_JOINT_DYNAMICS)
    jd = bool(model.passive or np.any(model.armature)) if joint_dynamics is None else bool(joint_dynamics)
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, duration, samples, endpoint=False)
    fit, test = (FourierTrajectory.random(model.nv, rng, harmonics, period=duration) for _ in range(2))
    (s1, W, tau), (s2, W2, tau2) = _stack(model, fit, t, jd), _stack(model, test, t, jd)
    tau_m, tau2_m = tau + rng.normal(0.0, sigma, tau.shape), tau2 + rng.normal(0.0, sigma, tau2.shape)
    P, r, K = base_parameters(W)
    pi = parameters(model, jd)
    beta = pi[P[:r]] + K @ pi[P[r:]]
    W1 = W[:, P[:r]]
    beta_hat = np.linalg.lstsq(W1, tau_m.ravel(), rcond=None)[0]
    _, R1 = np.linalg.qr(W1)
    R1inv = np.linalg.inv(R1)                                   # Cov β̂ = σ² R₁⁻¹ R₁⁻ᵀ
    pred = (W2[:, P[:r]] @ beta_hat).reshape(tau2.shape)
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))      # noqa: E731
    return Identification(
        labels=_labels(parameter_names(model, jd), P, r, K), beta_true=beta, beta_hat=beta_hat,
        beta_std=sigma * np.sqrt(np.sum(R1inv ** 2, axis=1)), rank=r, columns=P[:r], n_params=pi.size,
        cond=float(np.linalg.cond(W1)), sigma=float(sigma), seed=seed, samples=samples,
        rms_fit=rms(W1 @ beta_hat - tau_m.ravel()), rms_test=rms(pred - tau2_m), rms_test_true=rms(pred - tau2),
        rms_test_expected=float(sigma * np.linalg.norm(W2[:, P[:r]] @ R1inv) / np.sqrt(tau2.size)),
        rms_tau=rms(tau2), max_test_err=float(np.max(np.abs(pred - tau2)) / max(np.max(np.abs(tau2)), 1.0)),
        trajectories=(s1, s2))


def format_result(res: Identification) -> str:
    """The identified against the true base parameters, and the prediction errors."""
    lines = [f"AAU arm identification: seed {res.seed}, {res.samples} samples per trajectory, torque noise "
             f"σ = {res.sigma:g} N·m",
             f"base parameters: rank {res.rank} of {res.n_params} (QR with column pivoting), cond(W₁) = "
             f"{res.cond:.3g}",
             f"  {'true':>12} {'identified':>12} {'± 1 std':>10}  combination"]
    for lab, x, y, s in zip(res.labels, res.beta_true, res.beta_hat, res.beta_std):
        lines.append(f"  {x:12.5g} {y:12.5g} {s:10.2g}  {lab}")
    lines += [f"fit residual RMS {res.rms_fit:.4g} N·m (noise σ = {res.sigma:g})",
              f"second trajectory: RMS τ {res.rms_tau:.4g} N·m; prediction error RMS {res.rms_test_true:.4g} N·m "
              f"against the true torques ({100 * res.relative_test_error:.3g} %; expected "
              f"{res.rms_test_expected:.4g}), {res.rms_test:.4g} N·m against the noisy ones",
              f"  max error measure (docs/design.md §3) {res.max_test_err:.3g}"]
    return "\n".join(lines)


def write_csv(path, res: Identification):
    """One row per base parameter: true, identified, standard deviation, combination."""
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("true,identified,std,combination\n")
        for lab, x, y, s in zip(res.labels, res.beta_true, res.beta_hat, res.beta_std):
            fh.write(f"{x!r},{y!r},{s!r},\"{lab}\"\n")


def main(argv=None) -> int:
    """Command line: identify the AAU arm's base parameters and print the comparison."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--samples", type=int, default=400, help="samples per trajectory (default 400)")
    p.add_argument("--sigma", type=float, default=0.5, help="torque noise σ, N·m (default 0.5)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--csv", help="also write the base parameters to this CSV file")
    args = p.parse_args(argv)
    if args.samples < 2 or not (np.isfinite(args.sigma) and args.sigma >= 0) or args.seed < 0:
        p.error("--samples must be ≥ 2, --sigma finite and ≥ 0, --seed ≥ 0")
    res = identify(samples=args.samples, sigma=args.sigma, seed=args.seed)
    print(format_result(res))
    if args.csv:
        write_csv(args.csv, res)
        print(f"wrote {args.csv}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
