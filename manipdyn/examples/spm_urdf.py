"""The SPM as a URDF tree closed by <constraint>s: generator of urdf/spm.urdf and its states.

Spanning tree (joint names sorted so that q is natural): base -> proximal_i (leg<i>_theta, about u_i,
actuated) -> distal_i (leg<i>_psi, about v_i); distal_1 -> platform (leg1_xi, about w_1). Legs 2 and 3 meet
the platform through revolute closures on their w_i axes. q = [θ1, ψ1, ξ1, θ2, ψ2, θ3, ψ3]. Every joint
axis passes through O. Frames: proximal_i = base rotated by Rz(η_i) then by θ_i about u = −z; in it
v = [0, sin α1, −cos α1]; the distal frame coincides with it at ψ = 0, where w = cos α2 v + sin α2 x̂.
"""
from __future__ import annotations

import numpy as np

from ..spatial import axis_angle, matrix_rpy, rotation_between
from . import spm_params as P

V_LOCAL = np.array([0.0, np.sin(P.ALPHA1), -np.cos(P.ALPHA1)])
W_LOCAL = np.cos(P.ALPHA2) * V_LOCAL + np.sin(P.ALPHA2) * np.array([1.0, 0.0, 0.0])
U_LOCAL = np.array([0.0, 0.0, -1.0])


def _f(x):
    return " ".join(f"{v:.17g}" for v in np.atleast_1d(x))


def _inertial(m, com, R, diag):
    return (f'    <inertial>\n      <origin xyz="{_f(com)}" rpy="{_f(matrix_rpy(R))}"/>\n      <mass value="{float(m)!r}"/>\n'
            f'      <inertia ixx="{float(diag[0])!r}" iyy="{float(diag[1])!r}" izz="{float(diag[2])!r}" ixy="0" ixz="0" iyz="0"/>\n'
            f'    </inertial>\n')


def _cylinder(a, b, radius, rgba, material):
    """A cylinder visual from point a to point b (link frame)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    R = rotation_between([0.0, 0.0, 1.0], (b - a) / np.linalg.norm(b - a))
    return (f'    <visual>\n      <origin xyz="{_f((a + b) / 2)}" rpy="{_f(matrix_rpy(R))}"/>\n'
            f'      <geometry><cylinder radius="{radius}" length="{float(np.linalg.norm(b - a))!r}"/></geometry>\n'
            f'      <material name="{material}"><color rgba="{rgba}"/></material>\n    </visual>\n')


def _arc(p, q, rho, radius, rgba, material, n=5):
    """A link of a spherical mechanism: the great-circle arc from direction p to direction q on the sphere
    of radius rho about O, as n straight cylinders."""
    p, q = np.asarray(p, float), np.asarray(q, float)
    ang = np.arccos(np.clip(p @ q, -1.0, 1.0))
    k = np.cross(p, q) / np.linalg.norm(np.cross(p, q))
    pts = [rho * (np.cos(a) * p + np.sin(a) * np.cross(k, p)) for a in np.linspace(0.0, ang, n + 1)]
    return "".join(_cylinder(pts[j], pts[j + 1], radius, rgba, material) for j in range(n))


# Playback only (no effect on the dynamics): arcs on spheres about O, joint housings along their axes.
RHO_PROXIMAL, RHO_DISTAL, RHO_PLATFORM = 0.055, 0.075, 0.092     # m: sphere radii of the drawn links
TUBE, PIN = 0.0075, 0.009                                        # m: link tube and joint housing radii
GREY, RED, BLUE, GREEN, PIN_RGBA = "0.3 0.32 0.36 1", "0.85 0.33 0.2 1", "0.2 0.48 0.82 1", "0.2 0.68 0.35 1", \
    "0.85 0.86 0.88 1"


def _visuals_base():
    """The actuator stack along u = −z below O on a foot plate."""
    u = np.array([0.0, 0.0, -1.0])
    return (_cylinder(0.8 * RHO_PROXIMAL * u, 2.0 * RHO_PROXIMAL * u, 0.016, GREY, "grey")
            + _cylinder(2.0 * RHO_PROXIMAL * u, (2.0 * RHO_PROXIMAL + 0.008) * u, 0.05, GREY, "grey"))


def _visuals_proximal():
    return _arc(U_LOCAL, V_LOCAL, RHO_PROXIMAL, TUBE, RED, "red", n=4)


def _visuals_distal():
    """The distal arc (v to w) and the housing of the ψ joint along v, spanning both links' spheres."""
    return (_arc(V_LOCAL, W_LOCAL, RHO_DISTAL, TUBE, BLUE, "blue", n=5)
            + _cylinder((RHO_PROXIMAL - 0.008) * V_LOCAL, (RHO_DISTAL + 0.008) * V_LOCAL, PIN, PIN_RGBA, "pin"))


def _visuals_platform():
    """A three-spoke plate through the w_i* points (the legs stay visible behind it), the housings of the
    top joints along w_i*, and a stub along the platform normal (the tool side)."""
    w = [P.w_star(i) for i in range(3)]
    h = RHO_PLATFORM * w[0][2]
    out = _cylinder([0, 0, h - 0.004], [0, 0, h + 0.004], 0.024, GREEN, "green")
    out += _cylinder([0, 0, h], [0, 0, h + 0.03], 0.01, GREEN, "green")
    for wi in w:
        out += _cylinder([0, 0, h], [RHO_PLATFORM * wi[0], RHO_PLATFORM * wi[1], h], 0.0075, GREEN, "green")
        out += _cylinder((RHO_DISTAL - 0.008) * wi, (RHO_PLATFORM + 0.006) * wi, PIN, PIN_RGBA, "pin")
    return out


def distal_frame():
    """E = [e_x e_y e_z] of Eq. 47 (corrected) in the distal link frame."""
    v, w = V_LOCAL, W_LOCAL
    return np.column_stack([(v - w) / np.linalg.norm(v - w), (v + w) / np.linalg.norm(v + w),
                            np.cross(v, w) / np.linalg.norm(np.cross(v, w))])


def build_urdf() -> str:
    """URDF text of the co-axial SPM of Tables 2 and 3 with the choices documented in spm_params."""
    bis = (U_LOCAL + V_LOCAL) / np.linalg.norm(U_LOCAL + V_LOCAL)
    r_perp = P.R_L1 * np.linalg.norm(bis[:2])
    prox = _inertial(P.M_L1, P.R_L1 * bis, np.eye(3), [0.6e-3, 0.6e-3, P.I_L1 - P.M_L1 * r_perp**2])
    E = distal_frame()
    Ic = np.diag(P.I_L2) - P.M_L2 * P.R_L2**2 * np.array([1.0, 0.0, 1.0])   # parallel axis along e_y
    dist = _inertial(P.M_L2, P.R_L2 * E[:, 1], E, Ic)
    plat = _inertial(P.M_P, P.P_STAR, np.eye(3), np.diag(P.I_P))
    out = ['<?xml version="1.0"?>', f'<!-- {__doc__.strip().splitlines()[0]}', P.__doc__.strip(),
           "Generated by scripts/make_spm_urdf.py from manipdyn/examples/spm_params.py; do not edit. -->",
           '<robot name="spm">',
           f'  <link name="base">\n{_visuals_base()}  </link>']
    for i in range(3):
        out.append(f'  <link name="proximal{i + 1}">\n{prox}{_visuals_proximal()}  </link>')
        out.append(f'  <link name="distal{i + 1}">\n{dist}{_visuals_distal()}  </link>')
        out.append(_joint(f"leg{i + 1}_theta", "base", f"proximal{i + 1}", [0, 0, P.ETA[i]], U_LOCAL))
        out.append(_joint(f"leg{i + 1}_psi", f"proximal{i + 1}", f"distal{i + 1}", [0, 0, 0], V_LOCAL))
    out.append(f'  <link name="platform">\n{plat}{_visuals_platform()}  </link>')
    Rj = rotation_between(P.w_star(0), W_LOCAL)
    out.append(_joint("leg1_xi", "distal1", "platform", matrix_rpy(Rj), P.w_star(0)))
    for i in (1, 2):
        out.append(f'  <constraint name="leg{i + 1}_top" type="revolute">\n'
                   f'    <parent link="distal{i + 1}"/>\n    <parent_origin xyz="{_f(P.D_CLOSURE * W_LOCAL)}" rpy="0 0 0"/>\n'
                   f'    <parent_axis xyz="{_f(W_LOCAL)}"/>\n    <child link="platform"/>\n'
                   f'    <child_origin xyz="{_f(P.D_CLOSURE * P.w_star(i))}" rpy="0 0 0"/>\n'
                   f'    <child_axis xyz="{_f(P.w_star(i))}"/>\n  </constraint>')
    for i in range(3):
        out.append(f'  <transmission name="motor{i + 1}">\n    <type>transmission_interface/SimpleTransmission</type>\n'
                   f'    <joint name="leg{i + 1}_theta"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>\n'
                   f'    <actuator name="motor{i + 1}"><mechanicalReduction>1</mechanicalReduction></actuator>\n'
                   f'  </transmission>')
    out.append("</robot>\n")
    return "\n".join(out)


def _joint(name, parent, child, rpy, axis):
    return (f'  <joint name="{name}" type="continuous">\n    <parent link="{parent}"/>\n    <child link="{child}"/>\n'
            f'    <origin xyz="0 0 0" rpy="{_f(rpy)}"/>\n    <axis xyz="{_f(axis)}"/>\n  </joint>')


def tree_guess(model, Q, theta):
    """A guess of the tree coordinates for platform orientation Q (3, 3) and actuator angles θ (3,):
    each ψ_i turns w onto Q w_i*, ξ_1 turns the platform onto Q. Refine it with constraints.assemble."""
    q = np.zeros(model.nv)
    for i in range(3):
        q[model.joint_index(f"leg{i + 1}_theta")] = theta[i]
        Rprox = axis_angle(np.array([0, 0, 1.0]), np.array([P.ETA[i]]))[0] @ \
            axis_angle(U_LOCAL, np.array([theta[i]]))[0]
        wt = Rprox.T @ Q @ P.w_star(i)                      # target w in the proximal frame
        a, b = W_LOCAL - (W_LOCAL @ V_LOCAL) * V_LOCAL, wt - (wt @ V_LOCAL) * V_LOCAL
        psi = np.arctan2(V_LOCAL @ np.cross(a, b), a @ b)
        q[model.joint_index(f"leg{i + 1}_psi")] = psi
        if i == 0:
            Rd = Rprox @ axis_angle(V_LOCAL, np.array([psi]))[0] @ rotation_between(P.w_star(0), W_LOCAL)
            Rx = Rd.T @ Q                                   # remaining rotation about w_1*
            x0 = np.cross(P.w_star(0), np.eye(3)[np.argmin(np.abs(P.w_star(0)))])
            q[model.joint_index("leg1_xi")] = np.arctan2(P.w_star(0) @ np.cross(x0, Rx @ x0), x0 @ (Rx @ x0))
    return q
