"""The planted faults: named semantic bugs a developer could make, each one exact text replacement.

Every entry changes numbers (a sign, a dropped term, a wrong index, a wrong order), never the syntax. The
old snippet must occur exactly once in its file: when the code changes under a fault, the harness stops
with exit code 2 naming the fault (and tests/unit/test_fault_harness.py fails), so that no fault rots into
a no-op. ``tests`` lists the test paths (files or node ids) most likely to catch the fault; the harness runs
them first and the rest of the suite after.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Fault:
    """One planted fault: replace ``old`` by ``new`` in ``file`` (relative to the repo root)."""
    name: str
    area: str
    file: str
    old: str
    new: str
    tests: tuple
    what: str

    @property
    def relevant(self) -> tuple:
        """The fault's own test paths, then the strongest tests of its area (AREA_TESTS), without repeats."""
        return tuple(dict.fromkeys(self.tests + AREA_TESTS.get(self.area, ())))

    def __post_init__(self):
        if not isinstance(self.tests, tuple) or not self.tests:
            raise TypeError(f"fault {self.name!r}: tests must be a non-empty tuple of paths")


AREAS = ("loader", "kinematics", "rnea", "lagrange", "aba", "constraints", "integrators", "spm", "dh",
         "validation", "reduce", "viz", "regressor", "derivatives")

_LOADER = "tests/unit/test_loader.py"
_ZOO = "tests/crosscheck/test_rnea_terms.py"
_FAST = "tests/batch/test_fast_paths.py"
_ENGINES = "tests/crosscheck/test_engines.py"
_ABA = "tests/crosscheck/test_aba.py"
_CRBA = "tests/crosscheck/test_crba.py"
_FLOATBASE = "tests/crosscheck/test_floating_base.py"
_RNEA = "tests/crosscheck/test_rnea_kernel.py"
_ANALYTIC = "tests/unit/test_analytic.py"
_PROPS = "tests/unit/test_lagrange_properties.py"
_FOURBAR = "tests/unit/test_fourbar.py"
_CLOSED_FAST = "tests/batch/test_fast_paths.py::test_closed_chain_kernel_equals_reference"
_LOOPS = "tests/crosscheck/test_spatial_loops.py"
_CLOSED_KERNELS = "tests/batch/test_kernels_vs_readable.py::test_closed_chain_kernels_equal_readable"
_FLOAT = "tests/crosscheck/test_free_flyer_kinematics.py"
_SPM = "tests/unit/test_spm_chapter.py"
_DH = "tests/unit/test_dh.py"
_QUIRKS = "tests/unit/test_quirks.py"
_MIMIC = "tests/crosscheck/test_mimic.py"
_URDFPLUS = "tests/crosscheck/test_urdfplus_forms.py"
_REGRESSOR = "tests/crosscheck/test_regressor.py"
_DERIV = "tests/crosscheck/test_derivatives.py"
_MJCF = "tests/crosscheck/test_mjcf_export.py"

# The tests written to hold each area to an independent reference, run right after a fault's own tests.
AREA_TESTS = {
    "viz": ("tests/viz/test_play_signals.py", "tests/viz/test_play_page.py"),
    "loader": ("tests/unit/test_q_order.py", "tests/crosscheck/test_single_joint.py",
               "tests/robustness/test_urdf_structure.py", "tests/robustness/test_fuzz_urdf.py",
               "tests/properties/test_random_trees.py"),
    "kinematics": ("tests/unit/test_analytic_spatial.py", _FLOAT),
    "rnea": ("tests/crosscheck/test_rnea_kernel.py", "tests/unit/test_analytic_spatial.py"),
    "lagrange": ("tests/crosscheck/test_crba.py", "tests/unit/test_analytic_spatial.py", _FLOAT,
                 "tests/batch/test_kernels_vs_readable.py"),
    "aba": (_ABA, "tests/batch/test_fast_paths.py", "tests/crosscheck/test_floating_base.py"),
    "constraints": ("tests/crosscheck/test_spatial_loops.py", "tests/batch/test_kernels_vs_readable.py"),
    "integrators": ("tests/unit/test_symplectic_euler.py",),
    "validation": ("tests/crosscheck/test_single_joint.py",),
    "regressor": (_REGRESSOR,),
    "derivatives": ("tests/crosscheck/test_derivatives.py",
                    "tests/properties/test_random_trees.py::test_random_tree_dynamics_derivatives_agree_with_pinocchio"),
}

FAULTS = (
    # ---------------------------------------------------------------- loader (io/urdf.py, spatial.py)
    Fault("urdf-q-order-by-link-name", "loader", "manipdyn/io/urdf.py",
          "for j in sorted(robot.joints, key=lambda j: j.name):",
          "for j in sorted(robot.joints, key=lambda j: j.child):",
          (_LOADER,), "children of a link visited in order of their child link names, not joint names"),
    Fault("urdf-merge-drops-fixed-link-mass", "loader", "manipdyn/io/urdf.py",
          "inertias = [combine_inertias(parts[i]) for i in range(nb)]",
          "inertias = [combine_inertias(parts[i][:1]) for i in range(nb)]",
          (_LOADER,), "a body keeps only its own link's inertia: links merged by fixed joints lose their mass"),
    Fault("urdf-axis-not-normalised", "loader", "manipdyn/io/urdf.py",
          "    u = u / np.linalg.norm(u)\n",
          "    u = u / np.linalg.norm(u) * np.linalg.norm(a / scale) * scale\n",
          (_LOADER, "tests/properties/test_random_trees.py"),
          "a joint axis of length ≠ 1 is noted as normalised but kept as written"),
    Fault("urdf-inertial-rpy-ignored", "loader", "manipdyn/io/urdf.py",
          "I = To[:3, :3] @ np.asarray(inertial.inertia, float) @ To[:3, :3].T",
          "I = np.asarray(inertial.inertia, float)",
          (_LOADER, "tests/properties/test_random_trees.py"),
          "the <inertial><origin rpy> rotation of the inertia tensor is ignored"),
    Fault("urdf-rpy-roll-yaw-swapped", "loader", "manipdyn/spatial.py",
          "r, p, y = (float(x) for x in rpy)",
          "y, p, r = (float(x) for x in rpy)",
          (_LOADER, _DH, _FOURBAR), "rpy read as (yaw, pitch, roll): constraint origins and D-H tool frames turn wrongly"),
    Fault("spatial-parallel-axis-sign", "loader", "manipdyn/spatial.py",
          "[-x * y, x * x + z * z, -y * z],",
          "[x * y, x * x + z * z, -y * z],",
          (_LOADER, "tests/crosscheck/test_reduce.py"),
          "parallel-axis theorem with one product term of the wrong sign: merged (fixed-joint) and reduced bodies get wrong inertia"),
    # ---------------------------------------------------------------- kinematics (dynamics/kinematics.py)
    Fault("kin-jdot-local-term-sign", "kinematics", "manipdyn/dynamics/kinematics.py",
          "                dJ[o, r] = u[o] - (wl[1] * t[o + 2] - wl[2] * t[o + 1])\n"
          "                dJ[o + 1, r] = u[o + 1] - (wl[2] * t[o] - wl[0] * t[o + 2])\n"
          "                dJ[o + 2, r] = u[o + 2] - (wl[0] * t[o + 1] - wl[1] * t[o])\n",
          "                dJ[o, r] = u[o] + (wl[1] * t[o + 2] - wl[2] * t[o + 1])\n"
          "                dJ[o + 1, r] = u[o + 1] + (wl[2] * t[o] - wl[0] * t[o + 2])\n"
          "                dJ[o + 2, r] = u[o + 2] + (wl[0] * t[o + 1] - wl[1] * t[o])\n",
          ("tests/unit/test_aau_example.py", _FLOAT, _ZOO), "local J̇ = Rᵀ J̇_w + [ω]× Rᵀ J_w (the frame-rotation term's sign)"),
    Fault("kin-local-jacobian-rows-swapped", "kinematics", "manipdyn/dynamics/kinematics.py",
          "J[:3, r], J[3:, r] = t[:3], t[3:]",
          "J[:3, r], J[3:, r] = t[3:], t[:3]",
          (_FLOAT, _ZOO), "local Jacobian rows [angular; linear] instead of [linear; angular]"),
    Fault("kin-jdot-joint-origin-velocity", "kinematics", "manipdyn/dynamics/kinematics.py",
          "ux, uy, uz = xd[0] - vw[j, 0], xd[1] - vw[j, 1], xd[2] - vw[j, 2]",
          "ux, uy, uz = xd[0], xd[1], xd[2]",
          (_FOURBAR, _FLOAT, _ZOO), "J̇ column uses the point's velocity, not relative to the joint origin"),
    Fault("kin-lever-arm-from-body-origin", "kinematics", "manipdyn/dynamics/kinematics.py",
          "    J[:, :] = 0.0\n    j = b\n    while j >= 0:\n        dx, dy, dz = x[0] - pw[j, 0], x[1] - pw[j, 1], x[2] - pw[j, 2]\n",
          "    J[:, :] = 0.0\n    j = b\n    while j >= 0:\n        dx, dy, dz = x[0] - pw[b, 0], x[1] - pw[b, 1], x[2] - pw[b, 2]\n",
          (_FOURBAR, _LOOPS, _FLOAT), "Jacobian column [l + a × (x − o_b); a]: lever arm from the point's own body "
          "origin, not joint j's (Jacobians, the Lagrange route and the closure rows alike)"),
    Fault("kin-jdot-axis-rate-dropped", "kinematics", "manipdyn/dynamics/kinematics.py",
          "dJ[0, r] = wy * lz - wz * ly + by * dz - bz * dy + ay * uz - az * uy",
          "dJ[0, r] = by * dz - bz * dy + ay * uz - az * uy",
          (_FLOAT, _LOOPS), "J̇ linear x row without l̇ = ω_j × l (a free flyer's or prismatic column turning with its body)"),
    # ---------------------------------------------------------------- RNEA (dynamics/rnea.py, state.py, fast.py)
    Fault("rnea-coriolis-sign", "rnea", "manipdyn/dynamics/rnea.py",
          "put(dw, i, add(add(dw_in, AA), cross(w_in, VA)))",
          "put(dw, i, add(add(dw_in, AA), cross(VA, w_in)))",
          (_RNEA, _ANALYTIC), "Eq. 5: ω̇ gains θ̇ z × ω instead of ω × θ̇ z"),
    Fault("rnea-gravity-sign", "rnea", "manipdyn/dynamics/rnea.py",
          "dv_in = rot_t(Rl, i, (mg[0], mg[1], mg[2]))",
          "dv_in = rot_t(Rl, i, (-mg[0], -mg[1], -mg[2]))",
          (_RNEA, _ANALYTIC), "v̇'_0 = +g instead of −g"),
    Fault("rnea-eq7-centripetal-dropped", "rnea", "manipdyn/dynamics/rnea.py",
          "dvc_i = add(vec(dv, i), add(cross(dwi, c), cross(wi, cross(wi, c))))",
          "dvc_i = add(vec(dv, i), cross(dwi, c))",
          (_RNEA, _ANALYTIC), "Eq. 7 without ω × (ω × p_C) (the CoM acceleration of Eq. 32d as printed)"),
    Fault("rnea-prismatic-coriolis-factor", "rnea", "manipdyn/dynamics/rnea.py",
          "add(scale(2.0, cross(w_in, VL)), cross(VA, VL))",
          "add(cross(w_in, VL), cross(VA, VL))",
          (_RNEA, _ANALYTIC), "Eq. 12 with ω × ḋ z instead of 2 ω × ḋ z (prismatic Coriolis)"),
    Fault("rnea-free-flyer-va-cross-vl-dropped", "rnea", "manipdyn/dynamics/rnea.py",
          "add(scale(2.0, cross(w_in, VL)), cross(VA, VL))",
          "scale(2.0, cross(w_in, VL))",
          (_RNEA,), "a joint moving both ways (the free flyer) loses va × vl from the origin's acceleration"),
    Fault("rnea-eq16-lever-dropped", "rnea", "manipdyn/dynamics/rnea.py",
          "put(n, j, add(vec(n, j), add(rot(Rl, i, vec(n, i)), cross(vec(pl, i), Rf))))",
          "put(n, j, add(vec(n, j), rot(Rl, i, vec(n, i))))",
          (_RNEA, _ANALYTIC), "Eq. 16 without p^{i−1}_i × R f'_i: a child's force exerts no moment on its parent"),
    Fault("rnea-fext-frame-transposed", "rnea", "manipdyn/dynamics/state.py",
          "f, m = f @ fr.R.T, m @ fr.R.T",
          "f, m = f @ fr.R, m @ fr.R",
          (_ANALYTIC, _PROPS), "f_ext in a frame's axes rotated into the body by Rᵀ instead of R"),
    Fault("rnea-fext-world-rotation-transposed", "rnea", "manipdyn/dynamics/rnea.py",
          "fe, ne = rot_t(Rw, b, fe), rot_t(Rw, b, ne)",
          "fe, ne = rot(Rw, b, fe), rot(Rw, b, ne)",
          (_RNEA, "tests/batch/test_batch.py"), "a world-axes f_ext turned into the body by Rw instead of Rwᵀ"),
    # ---------------------------------------------------------------- CRBA / Lagrange (dynamics/lagrange.py, fast.py)
    Fault("lagrange-christoffel-sign", "lagrange", "manipdyn/dynamics/lagrange.py",
          '- np.einsum("nijk,nk->nij", dM, V))',
          '+ np.einsum("nijk,nk->nij", dM, V))',
          (_PROPS,), "Christoffel symbol with + ∂M_jk/∂q_i instead of −"),
    Fault("lagrange-dM-symmetrisation", "lagrange", "manipdyn/dynamics/lagrange.py",
          "dM[:, k] += sym + np.swapaxes(sym, 1, 2)",
          "dM[:, k] += 2.0 * sym",
          (_PROPS,), "∂M/∂q_k = 2 Jᵀ ∂J instead of ∂Jᵀ J + Jᵀ ∂J (not symmetrised)"),
    Fault("lagrange-g-sign", "lagrange", "manipdyn/dynamics/lagrange.py",
          'g = -np.einsum("b,bnki,k->ni", model.mass, J[:, :, :3], model.gravity)',
          'g = np.einsum("b,bnki,k->ni", model.mass, J[:, :, :3], model.gravity)',
          (_PROPS, "tests/unit/test_integrate.py"), "g(q) = +Σ m Jᵀ g (sign of ∂V/∂q)"),
    Fault("fast-crba-shift-factor", "lagrange", "manipdyn/dynamics/crba.py",
          "W[i, 0], W[i, 1], W[i, 2] = m1 / m, m2 / m, m1 * m2 / m",
          "W[i, 0], W[i, 1], W[i, 2] = m1 / m, m2 / m, m1",
          (_CRBA, _PROPS), "CRBA: composites merged with the parallel-axis term m₁(|d|²1 − ddᵀ) instead of "
                           "m₁m₂/(m₁ + m₂)(|d|²1 − ddᵀ)"),
    Fault("crba-unit-motion-linear-part", "lagrange", "manipdyn/dynamics/crba.py",
          "fx = m * (lx + ay * c[2] - az * c[1])",
          "fx = m * (ay * c[2] - az * c[1])",
          (_CRBA,), "CRBA: F = I^c s drops the x component of s's linear part (prismatic joints, free flyer)"),
    Fault("lagrange-free-flyer-bracket-dropped", "lagrange", "manipdyn/dynamics/lagrange.py",
          "    out[:, :6, :] -= np.swapaxes(ad, 1, 2) @ M[:, :6, :]\n",
          "",
          (_FLOAT,), "free-flyer C without the third bracket term −ad_ξᵀ M (Christoffel symbols as if the root's "
          "directions commuted)"),
    Fault("lagrange-dM-lift-rule-dropped", "lagrange", "manipdyn/dynamics/lagrange.py",
          "            dJ[:, :3, lift] = np.cross(np.swapaxes(a[:, lift], 1, 2), Jv[:, :, k, None], axis=1)\n",
          "",
          (_PROPS, _FLOAT), "∂J_j/∂q_k without [a_j × J_v,k; 0] for j supporting k (the CoM moving under joint j's axis)"),
    # ---------------------------------------------------------------- ABA (dynamics/aba.py, fast.py)
    Fault("aba-bias-force-sign", "aba", "manipdyn/dynamics/aba.py",
          "cross_force(vel[i], t, pA[i])",
          "cross_force(vel[i], vJ, pA[i])",
          (_PROPS, _FLOATBASE), "ABA bias force v ×* S q̇ instead of v ×* I v (Table 7.1, pass 1)"),
    Fault("aba-gravity-sign", "aba", "manipdyn/dynamics/aba.py",
          "a0[a], a0[3 + a] = mg[a], 0.0",
          "a0[a], a0[3 + a] = -mg[a], 0.0",
          (_PROPS, _FLOATBASE), "ABA base acceleration +g"),
    Fault("aba-fext-sign", "aba", "manipdyn/dynamics/aba.py",
          "pA[b, a] -= t[a]",
          "pA[b, a] += t[a]",
          (_PROPS, _ANALYTIC), "ABA: the external wrench added to the bias force instead of subtracted"),
    Fault("aba-pa-sign", "aba", "manipdyn/dynamics/aba.py",
          "x += Y[r, k1] * t[r]",
          "x -= Y[r, k1] * t[r]",
          (_PROPS, _FLOATBASE), "ABA: pᵃ = pᴬ + Iᵃ c − U D⁻¹ u"),
    Fault("aba-inertia-shift-sign", "aba", "manipdyn/dynamics/aba.py",
          "hx, hy, hz = py * z - pz * y, pz * x - px * z, px * y - py * x",
          "hx, hy, hz = pz * y - py * z, px * z - pz * x, py * x - px * y",
          (_ABA,), "ABA pass 2: I^A_λ += Xᵀ Iᵃ X with the P B'ᵀ − B' P terms of the shift negated"),
    Fault("aba-cholesky-upper-triangle", "aba", "manipdyn/dynamics/aba.py",
          "y -= L[m, r] * x[m]",
          "y -= L[r, m] * x[m]",
          (_ABA, _FLOATBASE), "ABA pass 3: back substitution reads D's upper triangle instead of Lᵀ (joints with "
                              "several velocities only: the free flyer)"),
    Fault("aba-fext-world-rotation", "aba", "manipdyn/dynamics/aba.py",
          "t[a] = Rw[b, 0, a] * w[k, 0] + Rw[b, 1, a] * w[k, 1] + Rw[b, 2, a] * w[k, 2]",
          "t[a] = Rw[b, a, 0] * w[k, 0] + Rw[b, a, 1] * w[k, 1] + Rw[b, a, 2] * w[k, 2]",
          (_ABA, _PROPS), "ABA: a world-axes external force turned into body axes by Rw instead of Rwᵀ"),
    # ---------------------------------------------------------------- constraints (constraints/*)
    Fault("closure-orientation-bias-offset", "constraints", "manipdyn/constraints/closures.py",
          "bias[row] = gyro + acc",
          "bias[row] = gyro + acc + 0.1",
          (_LOOPS, _CLOSED_KERNELS, _FOURBAR), "closure rows: a constant 0.1 added to every orientation row's Φ̇_q q̇"),
    Fault("closure-fixed-pair-index", "constraints", "manipdyn/constraints/closures.py",
          "return [(A[:, 1], B[:, 2]), (A[:, 2], B[:, 0]), (A[:, 0], B[:, 1])]",
          "return [(A[:, 1], B[:, 2]), (A[:, 2], B[:, 0]), (A[:, 0], B[:, 2])]",
          (_LOOPS, _CLOSED_KERNELS, _FOURBAR), "fixed closure's third pair (x_A, z_B) instead of (x_A, y_B): rotation about z free"),
    Fault("closure-pair-slot", "constraints", "manipdyn/constraints/closures.py",
          "flts[k, 6 + 3 * m:9 + 3 * m], flts[k, 15 + 3 * m:18 + 3 * m] = a, b",
          "flts[k, 6 + 3 * m:9 + 3 * m], flts[k, 12 + 3 * m:15 + 3 * m] = a, b",
          (_LOOPS, _CLOSED_KERNELS, _FOURBAR), "closure rows: b vectors stored one slot early (a fixed closure reads b2, b3, 0)"),
    Fault("closure-position-bias-sign", "constraints", "manipdyn/constraints/closures.py",
          "acc += (dJ[0, d, r] - dJ[1, d, r]) * v[r]",
          "acc += (dJ[1, d, r] - dJ[0, d, r]) * v[r]",
          (_LOOPS, _CLOSED_KERNELS, _FOURBAR), "closure rows: position rows' Φ̇_q q̇ of p_B − p_A (Φ of p_A − p_B)"),
    Fault("closure-baumgarte-alpha-sign", "constraints", "manipdyn/constraints/dynamics.py",
          'c = c - 2.0 * alpha * np.einsum("nij,nj->ni", Jc, V) - beta**2 * Phi',
          'c = c + 2.0 * alpha * np.einsum("nij,nj->ni", Jc, V) - beta**2 * Phi',
          (_CLOSED_FAST, "tests/unit/test_closed_sim.py"), "readable Baumgarte: + 2α Φ_q q̇ (destabilising)"),
    Fault("closure-fast-baumgarte-beta-sign", "constraints", "manipdyn/constraints/fast.py",
          "c = -bias - 2.0 * alpha * (Jc @ V[s]) - beta * beta * Phi",
          "c = -bias - 2.0 * alpha * (Jc @ V[s]) + beta * beta * Phi",
          (_CLOSED_FAST, "tests/unit/test_closed_sim.py"), "compiled Baumgarte: + β² Φ (pushes away from the closure)"),
    Fault("closure-fast-bias-sign", "constraints", "manipdyn/constraints/fast.py",
          "c = -bias - 2.0 * alpha * (Jc @ V[s])",
          "c = bias - 2.0 * alpha * (Jc @ V[s])",
          (_CLOSED_FAST, _FOURBAR), "compiled Eq. 26: Φ_q q̈ = +Φ̇_q q̇"),
    Fault("closure-fast-rank-tolerance-ignores-gap", "constraints", "manipdyn/constraints/fast.py",
          "tol = max(rtol, 100.0 * phimax / max(scale, 1e-300))",
          "tol = rtol",
          ("tests/unit/test_closed_sim.py", _FOURBAR, _CLOSED_FAST),
          "compiled rank test ignores |Φ| off the closures: redundant rows count as rank mid-step"),
    # ---------------------------------------------------------------- integrators (simulation.py)
    Fault("integrate-explicit-euler", "integrators", "manipdyn/simulation.py",
          "return plus(q, h * v1), v1",
          "return plus(q, h * v), v1",
          ("tests/unit/test_integrate.py",), "explicit Euler (q from v_k) in place of symplectic Euler (q from v_k+1)"),
    Fault("integrate-rk4-weight", "integrators", "manipdyn/simulation.py",
          "v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)",
          "v + h / 6 * (k1v + k2v + 2 * k3v + 2 * k4v)",
          ("tests/unit/test_integrate.py",), "RK4 velocity update with weights 1, 1, 2, 2 (still consistent, wrong order)"),
    Fault("integrate-rkmk-bracket-sign", "integrators", "manipdyn/simulation.py",
          "out[:, :6] += 0.5 * a1 + ad(xi, a1) / 12.0",
          "out[:, :6] += -0.5 * a1 + ad(xi, a1) / 12.0",
          ("tests/unit/test_floating_simulate.py",), "RK4 on a free flyer with dexp⁻¹ = v − ½[ξ, v] + …: second order"),
    # ---------------------------------------------------------------- the chapter's SPM model (examples/spm.py)
    Fault("spm-eq59a-drop-term", "spm", "manipdyn/examples/spm.py",
          "Ad = np.cross(vd, L.w) + np.cross(L.v, wd)",
          "Ad = np.cross(vd, L.w)",
          (_SPM, "tests/crosscheck/test_fig7.py"), "Eq. 59a without v_i × ẇ_i"),
    Fault("spm-psi-33-as-printed", "spm", "manipdyn/examples/spm.py",
          "[1 - ct, 0.0, ct]])",
          "[1 - ct, 0.0, cf]])",
          (_SPM,), "Ψ(3,3) = cos φ, the chapter's misprint, instead of cos θ"),
    Fault("spm-distal-frame-axes-swapped", "spm", "manipdyn/examples/spm.py",
          "cols = (v - w, v + w, np.cross(v, w))",
          "cols = (v + w, v - w, np.cross(v, w))",
          (_SPM, "tests/crosscheck/test_fig7.py"), "Eq. 47: e_x and e_y of the distal frame exchanged"),
    Fault("spm-platform-inertia-about-P", "spm", "manipdyn/examples/spm.py",
          "out.append((Apl, Q @ I_O @ Q.T, dom, P.M_P, Q @ P.P_STAR))",
          "out.append((Apl, Q @ P.I_P @ Q.T, dom, P.M_P, Q @ P.P_STAR))",
          (_SPM, "tests/crosscheck/test_fig7.py"), "Eq. 52 as printed: platform inertia about P used as if about O"),
    Fault("spm-eq57-psidot-term-dropped", "spm", "manipdyn/examples/spm.py",
          "return Bd * qd[:3] - Ad @ om - L.A @ (Psi_dot(q[3:], qd[3:]) @ qd[3:])",
          "return Bd * qd[:3] - Ad @ om",
          (_SPM, "tests/crosscheck/test_fig7.py"), "Eq. 57 as printed: Ċ_q q̇ without −A Ψ̇ φ̇"),
    # ---------------------------------------------------------------- D-H tool (io/dh.py)
    Fault("dh-convention-swapped", "dh", "manipdyn/io/dh.py",
          "pre, post, kind = _pre_post(row, i, convention)",
          'pre, post, kind = _pre_post(row, i, {"standard": "modified", "modified": "standard"}.get(convention, '
          "convention))",
          (_DH,), "a standard table read as modified and vice versa"),
    Fault("dh-alpha-sign", "dh", "manipdyn/io/dh.py",
          "return _T(np.array([[1, 0, 0], [0, c, -s], [0, s, c]]))",
          "return _T(np.array([[1, 0, 0], [0, c, s], [0, -s, c]]))",
          (_DH,), "Rx(α) built as Rx(−α): every link twist with the wrong sign"),
    # ---------------------------------------------------------------- validation (validation/compare.py)
    Fault("compare-lagrange-M-with-own-crba", "validation", "manipdyn/validation/compare.py",
          'theirs.update(M_crba=theirs["M"], M_lagrange=theirs["M"],',
          'theirs.update(M_crba=theirs["M"], M_lagrange=ours["M_crba"][s],',
          ("tests/crosscheck/test_planted_fault.py",),
          "validate compares the Lagrange-route M with our own CRBA instead of Pinocchio's"),
    # ---------------------------------------------------------------- other engines (validation/engines.py)
    Fault("engines-link-inertia-not-rotated-into-body", "validation", "manipdyn/validation/engines.py",
          "parts[fr.body].append((m, fr.p + fr.R @ c, fr.R @ I @ fr.R.T))",
          "parts[fr.body].append((m, fr.p + fr.R @ c, I))",
          (_ENGINES,), "an engine's link inertia merged into our body without the fixed joint's rotation"),
    Fault("engines-mujoco-iquat-conjugated", "validation", "manipdyn/validation/engines.py",
          "w, x, y, z = (float(t) for t in qwxyz)", "w, x, y, z = (-float(t) if i == 0 else float(t) "
          "for i, t in enumerate(qwxyz))",
          (_ENGINES,), "MuJoCo's body_iquat read as its inverse: principal axes of every read-back inertia turned"),
    Fault("engines-damping-sign", "validation", "manipdyn/validation/engines.py",
          "tau = rnea(model, Q, V, A) + arm * A + (damp * V if damp_in_id else 0.0)",
          "tau = rnea(model, Q, V, A) + arm * A - (damp * V if damp_in_id else 0.0)",
          (_ENGINES,), "neutralised τ with the engine's joint damping subtracted instead of added"),
    Fault("engines-triangle-test-inverted", "validation", "manipdyn/validation/engines.py",
          "return bool(lam[0] + lam[1] < lam[2] - 1e-9 * max(np.sum(np.abs(lam)), 1e-300))",
          "return bool(lam[0] + lam[1] > lam[2] - 1e-9 * max(np.sum(np.abs(lam)), 1e-300))",
          (_ENGINES,), "the referee's triangle-inequality test inverted: the cause is misnamed"),
    # ---------------------------------------------------------------- floating base (joints.py, configuration.py)
    Fault("ff-log6-coefficient-cancels", "integrators", "manipdyn/joints.py",
          "return (1.0 - 0.5 * th / np.tan(0.5 * th)) / th2",
          "return (1.0 - th * np.sin(th) / (2.0 * (1.0 - np.cos(th)))) / th2",
          ("tests/crosscheck/test_floating_base.py",),
          "free-flyer difference: V(ω)⁻¹'s coefficient through 1 − cos θ, which cancels at small angles (1e-11 m off)"),
    Fault("config-random-quaternion-cube", "integrators", "manipdyn/configuration.py",
          "u = rng.normal(size=(N, 4))", "u = rng.uniform(-1.0, 1.0, size=(N, 4))",
          ("tests/crosscheck/test_floating_base.py",),
          "random_configuration normalises a uniform cube: orientations not uniform on SO(3)"),
    Fault("reference-continuous-sin-cos-swapped", "validation", "manipdyn/validation/reference.py",
          "pq[k:k + n] = (np.cos(q[a]), np.sin(q[a]))", "pq[k:k + n] = (np.sin(q[a]), np.cos(q[a]))",
          ("tests/crosscheck/test_floating_base.py",),
          "our continuous-joint angle handed to Pinocchio as (sin, cos) instead of (cos, sin)"),
    # ---------------------------------------------------------------- reduce (reduce.py)
    Fault("reduce-locked-value-ignored", "reduce", "manipdyn/reduce.py",
          "Ri, pi = _fixed_placement(model, i, values[model.joint_names[i]])",
          "Ri, pi = _fixed_placement(model, i, 0.0)",
          ("tests/crosscheck/test_reduce.py",), "a locked joint is frozen at 0 whatever value it was locked at"),
    # ---------------------------------------------------------------- viz (playback plots and framing)
    Fault("viz-rates-first-order", "viz", "manipdyn/viz/plots.py",
          "V = np.gradient(Q, t, axis=0, edge_order=2 if T > 2 else 1)",
          "V = np.vstack([np.diff(Q, axis=0) / np.diff(t)[:, None], (Q[-1:] - Q[-2:-1]) / (t[-1] - t[-2])])",
          ("tests/viz/test_play_signals.py",), "a trajectory file's rates by one-sided first-order differences"),
    Fault("viz-closed-chain-rates-not-completed", "viz", "manipdyn/viz/plots.py",
          "            Q, V, A, _ = complete_state(model, Q, V[:, act], A[:, act])",
          "            pass",
          ("tests/viz/test_play_signals.py",),
          "a closed chain's passive rates taken from finite differences instead of the closures"),
    Fault("viz-slider-does-not-seek", "viz", "manipdyn/viz/page.py",
          'slider.addEventListener("input", function () { pause(); seek(parseFloat(slider.value)); });',
          'slider.addEventListener("input", function () { pause(); });',
          ("tests/viz/test_play_page.py::test_slider_seeks_and_cursor_follows",),
          "moving the time slider pauses but does not seek"),
    Fault("viz-ground-at-base-origin", "viz", "manipdyn/viz/scene.py",
          "    else:\n        ground_z = base_low", "    else:\n        ground_z = 0.0",
          ("tests/viz/test_play_page.py::test_ground_is_under_the_robot",),
          "the ground at the base frame's origin whatever lies below it (the SPM's base sinks into it)"),
    Fault("reduce-locked-free-flyer-quaternion-conjugated", "reduce", "manipdyn/reduce.py",
          "np.ascontiguousarray(np.atleast_1d(value), float), 0, R, p)",
          "np.ascontiguousarray(np.atleast_1d(value) * np.r_[1, 1, 1, -1, -1, -1, 1][:np.size(value)], float), 0, R, p)",
          ("tests/crosscheck/test_reduce.py",),
          "a locked free flyer's orientation inverted (quaternion conjugated): the fixed base sits rotated the wrong way"),
    Fault("reduce-root-keeps-its-joint", "reduce", "manipdyn/reduce.py",
          "above = set(_ancestors(model, rb))",
          "above = set(_ancestors(model, rb)[1:])",
          ("tests/crosscheck/test_reduce.py",),
          "root=: the joint carrying the root link keeps moving (a floating robot's free flyer is not locked)"),
    # ---------------------------------------------------------------- closed chains on a free flyer
    Fault("closure-dofs-q-index", "constraints", "manipdyn/constraints/dynamics.py",
          "return [int(model.idx_v[j]) + k for j in joints for k in range(int(model.nvs[j]))]",
          "return [int(model.idx_q[j]) + k for j in joints for k in range(int(model.nvs[j]))]",
          ("tests/crosscheck/test_floating_closures.py",),
          "q index for v index: behind a free flyer every joint's entry of v is read one place late"),
    Fault("assembly-moves-the-base", "constraints", "manipdyn/constraints/dynamics.py",
          "and (world or model.kind[j] != FREEFLYER)])",
          "and (world or model.kind[j] != FREEFLYER or True)])",
          ("tests/crosscheck/test_floating_closures.py",),
          "assembly and projection move a floating base under closures internal to the robot"),
    # ---------------------------------------------------------------- loader quirks, URDF+, mimic (io/urdf.py ...)
    Fault("coupling-row-successor-sign", "constraints", "manipdyn/constraints/closures.py",
          "Jrow[iv[B]] -= 1.0", "Jrow[iv[B]] += 1.0",
          (_QUIRKS + "::test_coupling_rows_are_the_gear_equation",
           _QUIRKS + "::test_coupling_dynamics_equal_pinocchios_mimic_model"),
          "a coupling's Jacobian row adds the successor's joints instead of subtracting them (Φ keeps its sign)"),
    Fault("coupling-row-ratio-dropped", "constraints", "manipdyn/constraints/closures.py",
          "phi += ratio * q[iq[A]]", "phi += q[iq[A]]",
          (_QUIRKS + "::test_coupling_rows_are_the_gear_equation",),
          "a coupling's gap Φ forgets the ratio (its Jacobian row keeps it): projection and assembly go wrong"),
    Fault("mimic-map-multiplier-dropped", "loader", "manipdyn/io/urdf.py",
          "G[model.idx_v[i], k + shift_v] = mult", "G[model.idx_v[i], k + shift_v] = 1.0",
          (_MIMIC, _QUIRKS + "::test_mimic_model_matches_pinocchio"),
          "the mimic velocity map G ignores the multiplier (a mimic joint moves at its target's rate)"),
    Fault("mimic-map-offset-dropped", "loader", "manipdyn/io/urdf.py",
          "off[model.idx_q[i]] = c", "off[model.idx_q[i]] = 0.0",
          (_MIMIC,), "the mimic map's q offset is dropped: q_mimic = multiplier · q_target"),
    Fault("free-root-hang-threshold", "loader", "manipdyn/io/urdf.py",
          "HANG = 0.6 ", "HANG = 0.8 ",
          (_QUIRKS + "::test_free_root_flags_the_legged_robots_and_drones_not_the_arms",),
          "a subtree must hang 0.8 (not 0.6) of the robot's extent below the root: short-legged robots pass as arms"),
    Fault("free-root-mass-share", "loader", "manipdyn/io/urdf.py",
          "if hanging == 1 and m_root >= 0.5 * m_all:", "if hanging == 1 and m_root >= 0.8 * m_all:",
          (_QUIRKS + "::test_free_root_flags_the_legged_robots_and_drones_not_the_arms",),
          "a heavy body with one hanging appendage needs 80 % (not 50 %) of the mass: flying arms pass as fixed"),
    Fault("triangle-quirks-first-link-only", "loader", "manipdyn/io/urdf.py",
          'quirks += [Quirk("triangle", name, msg) for name, msg in bad]',
          'quirks += [Quirk("triangle", name, msg) for name, msg in bad[:1]]',
          (_QUIRKS + "::test_triangle_names_every_link_and_non_psd_lists_all",),
          "only the first link violating the triangle inequality is reported (Model.quirks, the warning)"),
    Fault("non-psd-lists-first-only", "loader", "manipdyn/io/urdf.py",
          'f"{what[i]}: eigenvalues {lam[i].tolist()}" for i in bad[:50]',
          'f"{what[i]}: eigenvalues {lam[i].tolist()}" for i in bad[:1]',
          (_QUIRKS + "::test_triangle_names_every_link_and_non_psd_lists_all",),
          "the non-PSD refusal names only the first bad inertia instead of all"),
    Fault("zero-mass-inertia-policy-inverted", "loader", "manipdyn/io/urdf.py",
          'if m == 0.0 and zero_mass_inertia == "drop":', 'if m == 0.0 and zero_mass_inertia == "keep":',
          (_QUIRKS + "::test_zero_mass_inertia_keep_is_pinocchios_model_and_drop_is_the_massless_link",),
          "zero_mass_inertia 'keep' drops the rotational inertia of a massless link and 'drop' keeps it"),
    Fault("urdfplus-loop-axis-not-rotated", "loader", "manipdyn/io/urdf.py",
          "sides.append(_side(model, el, org, R @ axis, where, role, source))",
          "sides.append(_side(model, el, org, axis, where, role, source))",
          (_URDFPLUS,), "a URDF+ <loop>'s axis is read in the link frame, not turned by the side's <origin rpy>"),
    Fault("urdfplus-loop-origin-dropped", "loader", "manipdyn/io/urdf.py",
          'org = None if el is None else el.find("origin")', "org = None",
          (_URDFPLUS,), "a URDF+ <loop>'s <predecessor>/<successor> <origin> is ignored (the closure at the link origin)"),
    # ---------------------------------------------------------------- regressor (dynamics/regressor.py)
    Fault("regressor-first-moment-torque-sign", "regressor", "manipdyn/dynamics/regressor.py",
          "W[1 + k, 3] = e1 * gz - e2 * gy", "W[1 + k, 3] = e2 * gy - e1 * gz",
          (_REGRESSOR,), "the first moment's moment h × v̇' with the wrong sign in its x component"),
    Fault("regressor-gyroscopic-term-dropped", "regressor", "manipdyn/dynamics/regressor.py",
          "W[k, 5] = Ia[2] + w[0] * Iw[1] - w[1] * Iw[0]", "W[k, 5] = Ia[2]",
          (_REGRESSOR,), "the inertia columns without ω × I ω (z component)"),
    Fault("regressor-Ixy-unit-inertia", "regressor", "manipdyn/dynamics/regressor.py",
          "inertia_column(W, 5, (ay, ax, 0.0), (wy, wx, 0.0), (wx, wy, wz))",
          "inertia_column(W, 5, (ax, ay, 0.0), (wx, wy, 0.0), (wx, wy, wz))",
          (_REGRESSOR,), "I_xy's column built from the wrong unit inertia (I ω with the xy entries on the diagonal)"),
    Fault("regressor-lever-arm-dropped", "regressor", "manipdyn/dynamics/regressor.py",
          "motion_to_child(Rl[i], pl[i], Sx[lam, r], Sx[i, r])", "motion_to_child(Rl[i], pl[i] * 0.0, Sx[lam, r], Sx[i, r])",
          (_REGRESSOR,), "ancestors' motion subspaces carried to the child without the ω × p lever arm (Eq. 4)"),
    Fault("regressor-own-joint-only", "regressor", "manipdyn/dynamics/regressor.py",
          "        j = parent[j]\n", "        j = -1\n",
          (_REGRESSOR,), "each body's block reaches its own joint only, not its ancestors' (Y block diagonal)"),
    Fault("parameters-parallel-axis-sign", "regressor", "manipdyn/dynamics/regressor.py",
          "I = Ic + m[:, None, None] * (", "I = Ic - m[:, None, None] * (",
          (_REGRESSOR,), "dynamic_parameters: the inertia about the origin by the parallel-axis theorem with a minus sign"),
    Fault("parameters-back-about-origin", "regressor", "manipdyn/dynamics/regressor.py",
          "Ic = I - m * (c @ c * np.eye(3) - np.outer(c, c))", "Ic = I",
          (_REGRESSOR,), "model_with_parameters keeps the inertia about the origin as if it were about the CoM"),
    Fault("identify-base-parameters-without-K", "regressor", "manipdyn/examples/identify.py",
          "beta = pi[P[:r]] + K @ pi[P[r:]]", "beta = pi[P[:r]]",
          ("tests/unit/test_identify.py",), "the true base parameters without the dependent columns' share K π₂"),
    # ---------------------------------------------------------------- derivatives (dynamics/derivatives.py)
    Fault("deriv-dadq-own-velocity", "derivatives", "manipdyn/dynamics/derivatives.py",
          "cross_motion(vl, Vc[r], u)",
          "cross_motion(vel[i], Vc[r], u)",
          (_DERIV,), "∂a/∂q_j = a_λ × J_j + v_j × V_j (the joint's own body) instead of v_λ(j) × V_j. (The same "
                     "slip in V_j = v_λ × J_j changes nothing: v_j × J_j = v_λ × J_j for one column.)"),
    Fault("deriv-dadq-velocity-term-sign", "derivatives", "manipdyn/dynamics/derivatives.py",
          "Ac[r, x] += u[x]",
          "Ac[r, x] -= u[x]",
          (_DERIV,), "∂a/∂q_j = a_λ × J_j − v_λ × V_j (the velocity term's sign)"),
    Fault("deriv-force-cross-angular-sign", "derivatives", "manipdyn/dynamics/derivatives.py",
          "hx, hy, hz, nx, ny, nz = h[0], h[1], h[2], h[3], h[4], h[5]",
          "hx, hy, hz, nx, ny, nz = h[0], h[1], h[2], -h[3], -h[4], -h[5]",
          (_DERIV,), "Ẏ: the angular block of h ×̄ is +[h_a]× instead of −[h_a]×"),
    Fault("deriv-ancestor-rigid-term-sign", "derivatives", "manipdyn/dynamics/derivatives.py",
          "Fq[c, x] += t[x]",
          "Fq[c, x] -= t[x]",
          (_DERIV,), "∂τ_j/∂q_i (j an ancestor): − J_i ×* F_i instead of + (the subtree moved rigidly)"),
    Fault("deriv-dv-descendant-drops-ydot", "derivatives", "manipdyn/dynamics/derivatives.py",
          "Dv[k, r] = dot6(YJ[c], Bc[r]) + dot6(dYJ[c], Jc[r])",
          "Dv[k, r] = dot6(YJ[c], Bc[r])",
          (_DERIV,), "∂τ_i/∂q̇_j (j an ancestor) without the (Ẏ^cᵀ J_i)ᵀ J_j term"),
    Fault("deriv-world-fext-ancestor-term-dropped", "derivatives", "manipdyn/dynamics/derivatives.py",
          "+ AJ[c, 0] * Jc[r, 3] + AJ[c, 1] * Jc[r, 4] + AJ[c, 2] * Jc[r, 5])",
          ")",
          (_DERIV,), "a world-axes f_ext: ∂τ_i/∂q_j (j an ancestor) without J_iᵀ A^c_i ω_j, the wrench "
                     "that does not turn with the body"),
    Fault("deriv-local-fext-turned-back", "derivatives", "manipdyn/dynamics/derivatives.py",
          "Rw[b, y, 0] * x[k, z] + Rw[b, y, 1] * x[k, z + 1] + Rw[b, y, 2] * x[k, z + 2]",
          "Rw[b, 0, y] * x[k, z] + Rw[b, 1, y] * x[k, z + 1] + Rw[b, 2, y] * x[k, z + 2]",
          (_DERIV,), "a body-axes f_ext turned into world axes by Rwᵀ instead of Rw"),
    Fault("mjcf-fullinertia-products-swapped", "validation", "manipdyn/io/mjcf.py",
          "fullinertia=_vec([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]])",
          "fullinertia=_vec([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[1, 2], I[0, 2]])",
          (_MJCF,), "the MJCF export writes ixz and iyz in each other's place (MuJoCo's order is ixx iyy izz "
                    "ixy ixz iyz)"),
    Fault("mjcf-revolute-axis-wrong-frame", "validation", "manipdyn/io/mjcf.py",
          "c.pc + s * revolute_arm * c.axis_c)", "c.pc + s * revolute_arm * c.axis_p)",
          (_MJCF,), "the MJCF export places a revolute closure's child-side axis point along the parent's "
                    "axis vector (parent-frame coordinates read in the child's frame)"),
    Fault("deriv-minv-upper-triangle", "derivatives", "manipdyn/dynamics/derivatives.py",
          "x -= L[m, r] * out[m, c]",
          "x -= L[r, m] * out[m, c]",
          (_DERIV,), "M⁻¹ by Cholesky: the back substitution reads L's upper triangle (never written) instead of Lᵀ"),
)


def by_name(names):
    """The faults named, in the order given; KeyError names an unknown one."""
    table = {f.name: f for f in FAULTS}
    missing = [n for n in names if n not in table]
    if missing:
        raise KeyError(f"unknown fault(s): {', '.join(missing)}; see --list")
    return [table[n] for n in names]
