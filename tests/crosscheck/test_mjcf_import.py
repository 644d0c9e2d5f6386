"""The MJCF reader (manipdyn.io.mjcf_read): MJCF files become Models whose M and τ are MuJoCo's and Pinocchio's.

References (independent of the reader): MuJoCo 4.0 compiling the same text (mj_fullM, with its armature as
ours; mj_rne with gravity, which leaves out armature — added back as armature ⊙ q̈ — and passive forces; body_mass / body_ipos / body_iquat / body_inertia;
site_xpos / site_xmat); Pinocchio 4.1's buildModelFromMJCF; and, for the round trip to_mjcf -> load_mjcf_string,
the URDF model the text was written from (two models of ours, built by two readers from two formats).

Measured (this VM, MuJoCo 4.0, Pinocchio 4.1), §3 error measure:
- round trip (aau_arm, ur5, panda, kinova, baxter, a random tree, solo12 with a free flyer): ≤ 2.2e-15 (the random
  tree; solo12 0: the text carries every number exactly) — RT = 5e-14;
- MuJoCo, hand-written snippets (defaults, the five orientations, eulerseq, fullinertia, every primitive's inertia,
  several joints per body, ref, a free joint, sites, <frame>, ball joints alone and after a slide in one body, under
  a free flyer, with armature) and the exports: M and τ ≤ 2.0e-15; 12 random MJCF trees drawing every feature at
  random (random_mjcf: 26 ball joints among them, 21 sharing a body with other joints): ≤ 3.8e-15 — MJ = 1e-13;
  masses, CoMs and inertias of each primitive and orientation against MuJoCo's body_* arrays ≤ 1.9e-15 —
  MASS = 5e-14; sites and bodies against site_xpos/site_xmat, xpos/xmat ≤ 2.0e-15 (random trees) — SITE = 5e-14;
- Pinocchio's buildModelFromMJCF (its JointModelSpherical for a ball, q [x y z w] as ours) on the exports, on
  snippets it reads as MuJoCo does and on 8 random trees of the features it reads as MuJoCo (random_mjcf(pin=True),
  11 ball joints): ≤ 4.3e-15 — PIN = 5e-14;
- third-party files (gymnasium's MuJoCo assets, pybullet_data/mjcf): tests/crosscheck/test_mjcf_third_party.py, docs/mjcf.md.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from conftest import ROOT, err, mujoco_full_m, urdf

import manipdyn as md
from manipdyn.io.mjcf import to_mjcf
from manipdyn.validation.zoo import arm_paths, floating_paths

mujoco = pytest.importorskip("mujoco")

RT = 5e-14      # measured ≤ 2.2e-15 (round trip, M and τ)
MJ = 1e-13      # measured ≤ 3.8e-15 (M, τ against MuJoCo; random_mjcf seed 7, 2 balls)
MASS = 5e-14    # measured ≤ 1.9e-15 (mass, CoM, inertia against MuJoCo's body arrays)
SITE = 5e-14    # measured ≤ 2.0e-15 (site and body placements against MuJoCo; random_mjcf seed 11)
PIN = 5e-14     # measured ≤ 4.3e-15 (M, τ against Pinocchio's buildModelFromMJCF; random_mjcf(0, pin=True))


def quiet(f, *a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return f(*a, **kw)


def random_state(model, rng):
    """q (free flyer: position ~ N(0, 1); every quaternion x y z w (free flyer, ball) uniform on S³; the rest
    uniform in [−π, π]), v, a ~ N(0, 1)."""
    q = rng.uniform(-np.pi, np.pi, model.nq)
    if model.floating:
        q[:3] = rng.normal(size=3)
    for k in model.quat_q:
        quat = rng.normal(size=4)
        q[k:k + 4] = quat / np.linalg.norm(quat)
    return q, rng.normal(size=model.nv), rng.normal(size=model.nv)


def mujoco_qpos(model, m, q):
    """MuJoCo's qpos of our q, joint by joint (the reader's order is MuJoCo's): quaternions w x y z first (ours
    x y z w: a free joint [x y z qw qx qy qz], a ball [qw qx qy qz]); hinge and slide the same number."""
    qpos = np.zeros(m.nq)
    for j in range(m.njnt):
        iq_, oq = m.jnt_qposadr[j], model.idx_q[j]
        if model.kind[j] == md.FREEFLYER:
            qpos[iq_:iq_ + 7] = np.concatenate([q[oq:oq + 3], [q[oq + 6]], q[oq + 3:oq + 6]])
        elif model.kind[j] == md.BALL:
            qpos[iq_:iq_ + 4] = np.concatenate([[q[oq + 3]], q[oq:oq + 3]])
        else:
            qpos[iq_] = q[oq]
    return qpos


def mujoco_errors(model, m, n=5, seed=0):
    """Worst err of our M and τ against MuJoCo's (M = mj_fullM, τ = mj_rne with q̈ + armature ⊙ q̈) over n random
    states, MuJoCo's conventions converted here: free joint qpos [x y z qw qx qy qz], qvel [R v_lin (world);
    ω (body)], qacc's linear part the origin's world acceleration R (a_lin + ω × v_lin), its generalized force
    and M rows for the linear dofs in world axes (τ_mj = Tᵀ τ, M_mj = Tᵀ M T with v = T v_mj); a ball joint's
    qpos [qw qx qy qz], its qvel and qacc the body-frame ω, ω̇ as ours."""
    names = [m.joint(j).name or f"joint{j}" for j in range(m.njnt)]         # the reader's names of unnamed ones
    assert names == list(model.joint_names), (names, model.joint_names)
    if not model.nv:
        return 0.0
    d, rng, worst = mujoco.MjData(m), np.random.default_rng(seed), 0.0
    iv = np.concatenate([np.arange(m.jnt_dofadr[j], m.jnt_dofadr[j] + model.nvs[j]) for j in range(m.njnt)]) \
        if m.njnt else np.zeros(0, int)
    for _ in range(n):
        q, v, a = random_state(model, rng)
        qpos, qvel, qacc = mujoco_qpos(model, m, q), np.zeros(m.nv), np.zeros(m.nv)
        for j in range(m.njnt):
            if model.kind[j] != md.FREEFLYER:
                iv_, ov, n = m.jnt_dofadr[j], model.idx_v[j], model.nvs[j]
                qvel[iv_:iv_ + n], qacc[iv_:iv_ + n] = v[ov:ov + n], a[ov:ov + n]
        T = np.eye(model.nv)
        d.qpos[:] = qpos
        mujoco.mj_kinematics(m, d)
        for j in np.flatnonzero(model.kind == md.FREEFLYER):    # every free body (objects beside a robot too)
            R, o, k = d.xmat[m.jnt_bodyid[j]].reshape(3, 3), model.idx_v[j], m.jnt_dofadr[j]
            T[o:o + 3, o:o + 3] = R.T
            w, x = v[o + 3:o + 6], v[o:o + 3]
            qvel[k:k + 3], qvel[k + 3:k + 6] = R @ x, w
            qacc[k:k + 3], qacc[k + 3:k + 6] = R @ (a[o:o + 3] + np.cross(w, x)), a[o + 3:o + 6]
        d.qpos[:], d.qvel[:] = qpos, qvel
        mujoco.mj_forward(m, d)
        d.qacc[:] = qacc
        tau_mj = np.zeros(m.nv)
        mujoco.mj_rne(m, d, 1, tau_mj)
        M_mj = mujoco_full_m(m, d)                            # with MuJoCo's armature, as ours (model.armature)
        tau_mj += m.dof_armature * qacc                # mj_rne leaves it out; rnea has it (Pinocchio's)
        tau, M = md.rnea(model, q, v, a), md.mass_matrix(model, q)
        for o in model.idx_v[model.kind == md.FREEFLYER]:     # MuJoCo's armature acts on d/dt of the world-frame
            arm = model.armature[o:o + 3]                     # linear velocity, ours (Pinocchio's) on the body
            tau[o:o + 3] += arm * np.cross(v[o + 3:o + 6], v[o:o + 3])   # frame's: quirk "free_armature"
        worst = max(worst, err(T.T @ tau, tau_mj[iv]), err(T.T @ M @ T, M_mj[np.ix_(iv, iv)]))
    return worst


def pin_errors(model, path, n=5, seed=1):
    """Worst err of our M and τ against Pinocchio's buildModelFromMJCF of the same file (armature in both)."""
    import pinocchio as pin
    pm = pin.buildModelFromMJCF(str(path))
    assert (pm.nq, pm.nv) == (model.nq, model.nv)
    pd, rng, worst = pm.createData(), np.random.default_rng(seed), 0.0
    for _ in range(n):
        q, v, a = random_state(model, rng)
        M = pin.crba(pm, pd, q)
        M = np.triu(M) + np.triu(M, 1).T
        tau = pin.rnea(pm, pd, q, v, a)
        worst = max(worst, err(md.rnea(model, q, v, a), tau), err(md.mass_matrix(model, q), M))
    return worst


# ---- round trip: URDF -> Model -> to_mjcf -> load_mjcf_string -> the same M and τ ------------------------------

def random_tree_urdf(seed, n=9):
    rng = np.random.default_rng(seed)
    links, joints = {"base": ""}, []
    for k in range(1, n + 1):
        I = rng.uniform(0.01, 0.1, 3)
        links[f"l{k}"] = (f'<inertial><origin xyz="{rng.normal() * .1} {rng.normal() * .1} {rng.normal() * .1}" '
                          f'rpy="{rng.normal()} {rng.normal()} {rng.normal()}"/><mass value="{rng.uniform(0.5, 3)}"/>'
                          f'<inertia ixx="{I[0]}" iyy="{I[1]}" izz="{I[1] + I[0] * 0.5}" ixy="{I[2] * 0.1}" ixz="0" '
                          f'iyz="0"/></inertial>')
        par = "base" if k == 1 else f"l{rng.integers(1, k)}"
        kind = ("revolute", "prismatic", "continuous", "fixed")[rng.integers(0, 4) if k > 1 else 0]
        joints.append((f"j{k}", kind, par, f"l{k}", rng.normal(size=3) * 0.3, rng.normal(size=3),
                       rng.normal(size=3)))
    return urdf(links, joints)


def _round_trip_cases():
    zoo = [p for p in arm_paths() if p.stem in ("ur5_robot", "panda", "kinova", "baxter")]
    solo = [p for p in floating_paths() if p.stem == "solo12"]
    return ([("aau_arm", ROOT / "urdf" / "aau_arm.urdf", {})] + [(p.stem, p, {}) for p in zoo]
            + [(p.stem, p, {"root_joint": "free_flyer"}) for p in solo] + [("random_tree", None, {})])


@pytest.mark.parametrize("name,path,kw", _round_trip_cases(), ids=lambda x: x if isinstance(x, str) else "")
def test_round_trip_urdf_to_mjcf_and_back(name, path, kw):
    ours = quiet(md.load_urdf, path, **kw) if path else quiet(md.load_urdf_string, random_tree_urdf(3))
    back = quiet(md.load_mjcf_string, to_mjcf(ours))
    assert back.joint_names == ours.joint_names and (back.nq, back.nv) == (ours.nq, ours.nv)
    rng, worst = np.random.default_rng(0), 0.0
    for _ in range(10):
        q, v, a = random_state(ours, rng)
        worst = max(worst, err(md.mass_matrix(back, q), md.mass_matrix(ours, q)),
                    err(md.rnea(back, q, v, a), md.rnea(ours, q, v, a)))
    print(f"\n{name}: round trip M, τ: {worst:.1e}")
    assert worst <= RT
    m = mujoco.MjModel.from_xml_string(to_mjcf(ours))          # and MuJoCo on the same text
    e = mujoco_errors(back, m)
    print(f"{name}: MuJoCo M, τ: {e:.1e}")
    assert e <= MJ


# ---- MuJoCo as the reference on hand-written MJCF ---------------------------------------------------------------

PRIMITIVES = """<mujoco model="primitives"><compiler angle="radian"/>
<worldbody>
 <body name="sphere" pos="0 0 1"><joint axis="1 0 0"/><geom type="sphere" size="0.1" pos="0.1 0.2 0"/></body>
 <body name="capsule" pos="1 0 1"><joint axis="0 1 0"/><geom type="capsule" size="0.05 0.3" euler="0.3 0.2 0.1"/></body>
 <body name="capsule_fromto" pos="2 0 1"><joint axis="0 0 1"/>
   <geom type="capsule" fromto="0 0 0 0.3 0.2 0.1" size="0.04"/></body>
 <body name="cylinder" pos="0 1 1"><joint axis="1 1 0"/><geom type="cylinder" size="0.07 0.2" quat="1 0.2 0.3 0.1"/></body>
 <body name="cylinder_fromto" pos="1 1 1"><joint type="slide" axis="0 0 1"/>
   <geom type="cylinder" fromto="0.1 0 0 -0.2 0.3 0.4" size="0.05" density="300"/></body>
 <body name="box" pos="2 1 1"><joint axis="1 0 0"/><geom type="box" size="0.1 0.2 0.3" xyaxes="0 1 0 -1 0 0.5"/></body>
 <body name="ellipsoid" pos="0 2 1"><joint axis="0 1 0"/>
   <geom type="ellipsoid" size="0.1 0.2 0.05" zaxis="1 1 1" mass="2"/></body>
 <body name="mixed" pos="1 2 1"><joint axis="0 0 1"/>
   <geom type="sphere" size="0.05" pos="0.2 0 0"/><geom type="box" size="0.05 0.1 0.02" pos="0 0.1 0" mass="0.3"/>
   <geom type="capsule" size="0.02 0.1" axisangle="1 0 0 0.7" pos="0 0 0.2"/>
   <geom type="sphere" size="0.5" group="4" density="0"/></body>
</worldbody></mujoco>"""

ORIENTATIONS = """<mujoco model="orientations"><compiler angle="degree" eulerseq="zYx"/>
<default><joint axis="0 1 0"/><default class="x"><joint axis="1 0 0"/></default></default>
<worldbody>
 <body name="a" pos="0.1 0.2 0.3" euler="10 20 30"><joint/>
  <inertial pos="0.1 0 0" euler="5 -10 40" mass="2" diaginertia="0.1 0.2 0.25"/>
  <body name="b" pos="0.3 0 0" axisangle="1 2 3 50"><joint class="x"/>
   <inertial pos="0.1 0.1 0" xyaxes="1 1 0 -1 2 0.3" mass="1.5" diaginertia="0.05 0.06 0.07"/>
   <body name="c" pos="0 0.2 0.1" xyaxes="0 1 0 -1 0 0"><joint axis="0 0 1" pos="0.05 0 0"/>
    <inertial pos="0 0 0.1" zaxis="0 1 1" mass="1" diaginertia="0.02 0.03 0.04"/>
    <body name="d" pos="0.1 0 0" zaxis="-1 0 0.2"><joint type="slide" axis="1 0 1"/>
     <inertial pos="0 0.1 0" mass="0.7" fullinertia="0.1 0.2 0.25 0.01 0.02 -0.01"/>
     <body name="e" pos="0 0 0.1" quat="0 0 0 1"><joint/>
      <inertial pos="0 0 0.05" mass="0.4" fullinertia="0.01 0.02 0.025 0.001 -0.002 0.001"/></body>
    </body></body></body></body>
</worldbody></mujoco>"""

DEFAULTS = """<mujoco model="defaults">
<default>
 <geom density="700" type="capsule" size="0.03 0.1"/><joint axis="1 0 0"/>
 <default class="arm"><joint axis="0 1 0"/><geom type="box" size="0.05 0.05 0.1"/>
  <default class="wrist"><geom type="sphere" size="0.04"/><joint type="slide"/></default></default>
</default>
<worldbody>
 <body name="base" pos="0 0 0.5"><geom type="cylinder" size="0.2 0.1"/>
  <body name="upper" childclass="arm" pos="0 0 0.2"><joint name="shoulder"/><geom pos="0 0 0.1"/>
   <body name="lower" pos="0 0 0.3"><joint name="elbow" class="main"/><geom pos="0 0 0.1"/>
    <body name="hand" childclass="wrist" pos="0 0 0.3"><joint name="wrist" axis="0 0 1"/><geom/>
      <geom class="arm" pos="0.1 0 0"/></body></body></body></body>
</worldbody></mujoco>"""

MULTI = """<mujoco model="multi"><compiler angle="radian" inertiafromgeom="true"/>
<worldbody>
 <site name="world_site" pos="0 0 1" euler="0.1 0.2 0.3"/>
 <body name="torso" pos="0 0 1.2" euler="0.1 0 0.2">
  <joint name="x" type="slide" axis="1 0 0"/><joint name="z" type="slide" axis="0 0 1" pos="0.1 0 0"/>
  <joint name="ry" axis="0 1 0" pos="0 0.05 0.02" ref="0.3"/>
  <inertial pos="0 0 0" mass="100" diaginertia="1 1 1"/>
  <geom type="capsule" fromto="-0.2 0 0 0.2 0 0" size="0.05"/><site name="torso_tip" pos="0.2 0 0" zaxis="1 0 0"/>
  <body name="thigh" pos="0.2 0 -0.1"><joint name="hip" axis="0 1 0" pos="0 0 0.1" ref="-0.4"/>
   <joint name="hip_x" axis="1 0 0" pos="0 0.02 0.1"/>
   <geom type="capsule" fromto="0 0 0.1 0 0 -0.3" size="0.04"/>
   <site name="knee" pos="0 0 -0.3" axisangle="0 0 1 0.5"/>
   <body name="shin" pos="0 0 -0.3"><joint name="knee" type="slide" axis="0 0 1" ref="0.05"/>
    <geom type="box" size="0.03 0.03 0.15" pos="0 0 -0.15"/></body></body></body>
 <body name="welded" pos="1 0 0"><geom type="sphere" size="0.1"/>
  <body name="arm" pos="0 0 0.2"><joint name="arm" axis="0 0 1" pos="0.1 0 0"/>
   <geom type="ellipsoid" size="0.1 0.05 0.02" pos="0.2 0 0"/></body></body>
</worldbody></mujoco>"""

FREE = """<mujoco model="free"><option gravity="0.5 -1 -9"/>
<worldbody><geom type="plane" size="5 5 0.1"/>
 <body name="torso" pos="0 0 1" quat="0.9 0.1 0.3 0.2"><freejoint name="root"/>
  <geom type="box" size="0.2 0.1 0.05"/><site name="imu" pos="0.1 0 0.05" quat="0 1 0 0"/>
  <body name="leg" pos="0.2 0 0" euler="0 30 0"><joint name="hip" axis="0 1 0" pos="0 0 0.02" range="-30 60"/>
   <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.03"/>
   <body name="foot" pos="0 0 -0.4"><joint name="ankle" type="slide" axis="0 0 1" range="-0.1 0.1"/>
    <geom type="sphere" size="0.05"/></body></body>
  <body name="arm" pos="-0.2 0 0"><joint name="sh1" axis="1 0 0"/><joint name="sh2" axis="0 0 1" pos="0 0.1 0"/>
   <geom type="cylinder" fromto="0 0 0 -0.3 0 0" size="0.02"/></body></body>
</worldbody></mujoco>"""

FRAMES = """<mujoco model="frames"><compiler angle="degree"/>
<default><default class="f"><geom type="box" size="0.05 0.1 0.02"/><joint axis="0 0 1"/></default></default>
<worldbody>
 <frame pos="0 0 1" euler="0 0 30">
  <site name="fs" pos="0.1 0 0"/>
  <body name="a" pos="0.2 0 0"><joint name="ja" axis="0 1 0"/><geom type="capsule" size="0.03 0.2"/>
   <frame pos="0.1 0.05 0" axisangle="1 0 0 40" childclass="f">
    <geom pos="0 0 0.1"/><site name="s1" pos="0 0.1 0"/><joint name="jb" pos="0 0.1 0"/>
    <frame pos="0 0 0.1" zaxis="0 1 1">
     <body name="b" pos="0.1 0 0"><joint name="jc" axis="1 0 0"/><site name="s2" pos="0 0 0.1"/>
      <inertial pos="0 0 0.05" quat="0.9 0 0.1 0" mass="1" diaginertia="0.01 0.02 0.03"/></body></frame>
   </frame></body>
 </frame>
 <body name="c" pos="1 0 0"><geom type="sphere" size="0.1" pos="0 0 -0.1"/>
  <frame euler="10 0 0"><inertial pos="0 0.1 0" mass="2" diaginertia="0.1 0.1 0.2"/>
   <joint name="jd" axis="0 1 1" pos="0 0 0.1"/></frame></body>
</worldbody></mujoco>"""

BALLS = """<mujoco model="balls"><compiler angle="radian"/>
<worldbody>
 <body name="upper" pos="0 0 1" euler="0.2 -0.1 0.3"><joint name="yaw" axis="0 0 1" armature="0.05"/>
  <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04"/>
  <body name="arm" pos="0.3 0 0" quat="0.9 0.1 -0.2 0.3"><joint name="shoulder" type="ball" pos="0.02 0.01 -0.03"
    armature="0.2" damping="1"/>
   <geom type="box" size="0.15 0.03 0.02" pos="0.15 0 0"/><site name="elbow_site" pos="0.3 0 0" euler="0 0.5 0"/>
   <body name="forearm" pos="0.3 0 0"><joint name="slide" type="slide" axis="1 0.2 0"/>
    <joint name="wrist" type="ball" pos="0 0.05 0" armature="0.01"/>
    <inertial pos="0.1 0.02 0" quat="0.8 0.2 0 0.1" mass="0.7" diaginertia="0.01 0.02 0.025"/>
    <site name="hand" pos="0.2 0 0" zaxis="1 1 0"/></body></body></body>
</worldbody></mujoco>"""

FREE_BALL = """<mujoco model="free_ball">
<worldbody>
 <body name="free" pos="1 0 1" euler="10 20 30"><freejoint name="root"/><geom type="sphere" size="0.1"/>
  <body name="pendulum" pos="0 0 -0.1"><joint name="pivot" type="ball" pos="0 0 0.05" armature="0.3"/>
   <geom type="cylinder" fromto="0 0 0 0 0.1 -0.3" size="0.02"/><site name="tip" pos="0 0.1 -0.3"/>
   <body name="bob" pos="0 0.1 -0.3"><joint name="spin" type="ball"/><geom type="box" size="0.05 0.02 0.01"/>
   </body></body></body>
</worldbody></mujoco>"""

SNIPPETS = {"balls": BALLS, "free_ball": FREE_BALL, "frames": FRAMES, "primitives": PRIMITIVES, "orientations": ORIENTATIONS, "defaults": DEFAULTS, "multi": MULTI,
            "free": FREE}


@pytest.mark.parametrize("name", list(SNIPPETS))
def test_snippet_m_and_tau_against_mujoco(name):
    ours = quiet(md.load_mjcf_string, SNIPPETS[name])
    m = mujoco.MjModel.from_xml_string(SNIPPETS[name])
    assert (ours.nq, ours.nv) == (m.nq, m.nv)
    e = mujoco_errors(ours, m)
    print(f"\n{name}: M, τ against MuJoCo: {e:.1e}")
    assert e <= MJ


def _write(tmp_path, name, text):
    p = tmp_path / f"{name}.xml"
    p.write_text(text)
    return p


_UNIT = " ".join(repr(float(x)) for x in (np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)))

# Pinocchio 4.1's buildModelFromMJCF, where it differs from MuJoCo 4.0 (found here; MuJoCo is the reference):
# it reads only the first top-level body, does not normalise an axisangle's axis, ignores eulerseq, <option
# gravity> and joint ref, stops (IndexError) on childclass / class="main", and leaves out the bodies inside a <frame>
# (a "No such node (body)" error, or fewer joints). Its cases avoid those features.
PIN_CASES = {
    "balls": BALLS, "free_ball": FREE_BALL,
    "orientations": ORIENTATIONS.replace(' eulerseq="zYx"', "").replace('axisangle="1 2 3 50"', f'axisangle="{_UNIT} 50"'),
    "multi": MULTI.split('<body name="welded"')[0].replace(' ref="0.3"', "").replace(' ref="-0.4"', "")
                  .replace(' ref="0.05"', "") + "</worldbody></mujoco>",
    "free": FREE.replace('<option gravity="0.5 -1 -9"/>', ""),
    "defaults": DEFAULTS.replace(' childclass="arm"', "").replace(' childclass="wrist"', "").replace(' class="main"', ""),
}


@pytest.mark.parametrize("name", list(PIN_CASES) + ["aau_arm", "ur5_robot", "panda"])
def test_against_pinocchio(name, tmp_path):
    pytest.importorskip("pinocchio")
    if name in PIN_CASES:
        text = PIN_CASES[name]
    else:
        path = ROOT / "urdf" / "aau_arm.urdf" if name == "aau_arm" else next(p for p in arm_paths() if p.stem == name)
        text = to_mjcf(quiet(md.load_urdf, path))
    ours = quiet(md.load_mjcf_string, text)
    e = pin_errors(ours, _write(tmp_path, name, text))
    print(f"\n{name}: M, τ against Pinocchio's buildModelFromMJCF: {e:.1e}")
    assert e <= PIN


@pytest.mark.parametrize("name", ["primitives", "orientations"])
def test_body_inertias_against_mujoco(name):
    # one joint per body: our body i is MuJoCo's body i + 1, so mass, CoM (body_ipos) and inertia (R(body_iquat)
    # diag(body_inertia) Rᵀ) compare one by one — each primitive's formula, each orientation — once moved into our
    # body frame (the joint frame: the MJCF body's frame is the Frame of its name there)
    ours = quiet(md.load_mjcf_string, SNIPPETS[name])
    m = mujoco.MjModel.from_xml_string(SNIPPETS[name])
    worst = 0.0
    for i in range(ours.njoints):
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, m.body_iquat[i + 1])
        R, fr = R.reshape(3, 3), ours.frames[m.body(i + 1).name or f"body{i + 1}"]
        I = fr.R @ R @ np.diag(m.body_inertia[i + 1]) @ R.T @ fr.R.T
        worst = max(worst, err([ours.mass[i]], [m.body_mass[i + 1]]), err(ours.com[i], fr.p + fr.R @ m.body_ipos[i + 1]),
                    err(ours.inertia[i], I))
    print(f"\n{name}: masses, CoMs, inertias against MuJoCo: {worst:.1e}")
    assert worst <= MASS


def placement_errors(ours, m, d, q, bodies=True):
    """Worst err of our frame_placement of every MuJoCo site (and body) against MuJoCo's at q (mj_kinematics)."""
    d.qpos[:] = mujoco_qpos(ours, m, q)
    mujoco.mj_kinematics(m, d)
    worst = 0.0
    for k in range(m.nsite):
        R, p = md.frame_placement(ours, q, m.site(k).name)
        worst = max(worst, err(p, d.site_xpos[k]), err(R, d.site_xmat[k].reshape(3, 3)))
    for k in range(1, m.nbody if bodies else 1):
        R, p = md.frame_placement(ours, q, m.body(k).name)
        worst = max(worst, err(p, d.xpos[k]), err(R, d.xmat[k].reshape(3, 3)))
    return worst


@pytest.mark.parametrize("name", ["multi", "free", "frames", "balls", "free_ball"])
def test_sites_and_bodies_are_frames_at_mujocos_placements(name):
    ours = quiet(md.load_mjcf_string, SNIPPETS[name])
    m = mujoco.MjModel.from_xml_string(SNIPPETS[name])
    d, rng, worst = mujoco.MjData(m), np.random.default_rng(2), 0.0
    for _ in range(3):
        q, _, _ = random_state(ours, rng)
        worst = max(worst, placement_errors(ours, m, d, q))
    print(f"\n{name}: sites and bodies against MuJoCo: {worst:.1e}")
    assert worst <= SITE


def test_quirks_name_each_joint_and_value():
    text = MULTI.replace('name="hip" axis', 'name="hip" armature="0.1" damping="2" frictionloss="0.3" axis') \
        .replace('name="arm" axis', 'name="arm" stiffness="5" springref="0.2" axis') \
        .replace('name="x" type', 'name="x" springdamper="0.5 1" type')
    with pytest.warns(md.QuirkWarning, match="joint_dynamics"):
        model = md.load_mjcf_string(text)
    q = {x.name: x.detail for x in model.quirks if x.kind == "joint_dynamics"}
    assert set(q) == {"arm", "x"} and "springdamper 0.5 1" in q["x"]        # hip's armature, damping, frictionloss:
    assert "stiffness 5" in q["arm"] and "springref 0.2" in q["arm"]         # applied, not quirked
    k = model.joint_index("hip")
    assert (model.armature[k], model.damping[k], model.friction[k]) == (0.1, 2.0, 0.3)
    assert np.count_nonzero(model.armature) == 1 and np.count_nonzero(model.friction) == 1
    assert {x.name for x in model.quirks if x.kind == "joint_ref"} == {"ry", "hip", "knee"}


def test_option_gravity_flag_and_fluid_forces():
    text = FREE.replace('<option gravity="0.5 -1 -9"/>', '<option gravity="0.5 -1 -9" density="1.2" viscosity="1e-5">'
                        '<flag gravity="disable"/></option>')
    with pytest.warns(md.QuirkWarning, match="passive_force"):
        ours = md.load_mjcf_string(text)
    assert not ours.gravity.any()
    assert {q.name for q in ours.quirks if q.kind == "passive_force"} == {"option density", "option viscosity"}
    assert mujoco_errors(ours, mujoco.MjModel.from_xml_string(text)) <= MJ       # measured 4.4e-16


def test_inertiafromgeom_false_and_true():
    base = ('<mujoco><compiler inertiafromgeom="{}"/><worldbody><body><joint/>'
            '<inertial pos="0.1 0 0" mass="2" diaginertia="0.1 0.1 0.1"/><geom type="sphere" size="0.2"/>'
            '</body></worldbody></mujoco>')
    for mode in ("false", "true", "auto"):
        text = base.format(mode)
        ours, m = quiet(md.load_mjcf_string, text), mujoco.MjModel.from_xml_string(text)
        assert err([ours.mass[0]], [m.body_mass[1]]) <= MASS and err(ours.com[0], m.body_ipos[1]) <= MASS


def test_settotalmass_scales_every_body():
    text = PRIMITIVES.replace('<compiler angle="radian"/>', '<compiler angle="radian" settotalmass="7.5"/>')
    ours, m = quiet(md.load_mjcf_string, text), mujoco.MjModel.from_xml_string(text)
    assert err(ours.mass, m.body_mass[1:]) <= MASS and abs(ours.mass.sum() - 7.5) <= 1e-14   # measured 2.2e-17, 8.9e-16
    assert mujoco_errors(ours, m) <= MJ


def test_joint_limits_in_radians_and_metres():
    ours, m = quiet(md.load_mjcf_string, FREE), mujoco.MjModel.from_xml_string(FREE)
    for j in range(1, m.njnt):
        i = ours.joint_index(m.joint(j).name)
        lo, hi = (m.jnt_range[j] if m.jnt_limited[j] else (-np.inf, np.inf))
        assert (ours.lower[i], ours.upper[i]) == pytest.approx((lo, hi), rel=1e-15)
        assert ours.continuous[i] == (not m.jnt_limited[j] and m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE)


def test_load_keywords(tmp_path):
    path = _write(tmp_path, "defaults", DEFAULTS)
    assert np.array_equal(quiet(md.load_mjcf, path, gravity=(0, 0, -1)).gravity, [0, 0, -1])
    locked = quiet(md.load_mjcf, path, locked={"elbow": 0.3})
    full = quiet(md.load_mjcf, path)
    q = np.array([0.2, 0.3, -0.1])
    assert locked.joint_names == ("shoulder", "wrist")
    assert err(md.mass_matrix(locked, q[[0, 2]]), md.mass_matrix(full, q)[np.ix_([0, 2], [0, 2])]) <= 1e-15
    zero = DEFAULTS.replace('<geom/>', '<geom/><inertial pos="0 0 0" mass="0" diaginertia="0.1 0.1 0.1"/>')
    kept, dropped = (quiet(md.load_mjcf_string, zero, zero_mass_inertia=k) for k in ("keep", "drop"))
    assert kept.inertia[2].trace() == pytest.approx(0.3) and not dropped.inertia[2].any()
    assert ("zero_mass_inertia", "hand") in {(x.kind, x.name) for x in kept.quirks}
    bad = DEFAULTS.replace('<geom/>', '<geom/><inertial pos="0 0 0" mass="1" fullinertia="1 1 1 2 0 0"/>')
    with pytest.raises(md.ModelError, match="not positive semi-definite"):
        quiet(md.load_mjcf_string, bad)
    assert "non_psd_inertia" in {x.kind for x in quiet(md.load_mjcf_string, bad, non_psd_inertia="keep").quirks}


def test_load_model_chooses_the_reader_by_content(tmp_path):
    mj = _write(tmp_path, "arm.urdf", DEFAULTS)                 # MJCF behind a .urdf name
    ur = tmp_path / "arm.xml"
    ur.write_text((ROOT / "urdf" / "aau_arm.urdf").read_text())
    assert quiet(md.load_model, mj).joint_names == ("shoulder", "elbow", "wrist")
    assert quiet(md.load_model, ur).joint_names == quiet(md.load_urdf, ROOT / "urdf" / "aau_arm.urdf").joint_names
    other = _write(tmp_path, "other", "<sdf version='1.6'><model name='m'/></sdf>")
    with pytest.raises(md.ManipdynError, match="<sdf>"):
        md.load_model(other)


def test_includes_inside_the_folder(tmp_path):
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "arm.xml").write_text(
        '<mujoco><body name="upper" pos="0 0 0.2"><joint name="shoulder" axis="0 1 0"/>'
        '<geom type="box" size="0.05 0.05 0.1"/></body></mujoco>')
    (tmp_path / "parts" / "defaults.xml").write_text('<mujoco><compiler angle="radian"/></mujoco>')
    main = _write(tmp_path, "main", '<mujoco><include file="parts/defaults.xml"/><worldbody><body name="base">'
                  '<include file="parts/arm.xml"/></body></worldbody></mujoco>')
    ours = quiet(md.load_mjcf, main)
    m = mujoco.MjModel.from_xml_path(str(main))
    assert ours.joint_names == ("shoulder",)
    assert mujoco_errors(ours, m) <= MJ


def test_an_included_file_rooted_at_mujocoinclude_loads_as_one_rooted_at_mujoco(tmp_path):
    """Files written for MuJoCo before 2.1 root an included file at <mujocoinclude>: read as a <mujoco> root (the
    same model, which MuJoCo compiles from the <mujoco> form); any other root is refused by name."""
    (tmp_path / "parts").mkdir()
    arm = ('<body name="upper" pos="0 0 0.2"><joint name="shoulder" axis="0 1 0"/><geom type="box" size="0.05 0.05 '
           '0.1" mass="1.3"/><body name="lower" pos="0 0 0.3"><joint name="elbow" axis="1 0 0"/><geom type="capsule" '
           'fromto="0 0 0 0 0 0.25" size="0.03"/></body></body>')
    main = '<mujoco><worldbody><body name="base"><include file="parts/arm.xml"/></body></worldbody></mujoco>'
    models = {}
    for root in ("mujoco", "mujocoinclude"):
        folder = tmp_path / root
        (folder / "parts").mkdir(parents=True)
        (folder / "parts" / "arm.xml").write_text(f"<{root}>{arm}</{root}>")
        models[root] = quiet(md.load_mjcf, _write(folder, "main", main))
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "mujoco" / "main.xml"))
    assert models["mujocoinclude"].joint_names == ("shoulder", "elbow")
    assert mujoco_errors(models["mujocoinclude"], m) <= MJ
    (tmp_path / "mujoco" / "parts" / "arm.xml").write_text(f"<robot>{arm}</robot>")
    with pytest.raises(md.MJCFError, match=r"root element is <robot>, expected <mujoco> \(or <mujocoinclude>"):
        md.load_mjcf(tmp_path / "mujoco" / "main.xml")


def test_bodies_and_sites_have_name_spaces_of_their_own(tmp_path):
    """A site may share a body's name, as in MuJoCo: the body's frame keeps the name, the site's is 'site:<name>';
    both placed as MuJoCo places them (xpos/xmat, site_xpos/site_xmat) at a random configuration."""
    main = _write(tmp_path, "main", '<mujoco><worldbody><body name="arm" pos="0 0 0.5"><joint name="j1" axis="0 1 0"/>'
                  '<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/><site name="arm" pos="0.3 0.02 0" '
                  'euler="0.1 0.2 0.3"/><body name="hand" pos="0.3 0 0"><joint name="j2" axis="0 0 1"/>'
                  '<geom type="sphere" size="0.05"/><site name="tip" pos="0.05 0 0"/></body></body></worldbody>'
                  '</mujoco>')
    ours = quiet(md.load_mjcf, main)
    assert {"arm", "site:arm", "hand", "tip"} <= set(ours.frames)
    m = mujoco.MjModel.from_xml_path(str(main))
    d = mujoco.MjData(m)
    q = np.array([0.7, -1.1])
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    for frame, (R_mj, p_mj) in {"arm": (d.xmat[1], d.xpos[1]), "site:arm": (d.site_xmat[0], d.site_xpos[0]),
                                "tip": (d.site_xmat[1], d.site_xpos[1])}.items():
        R, p = md.frame_placement(ours, q, frame)
        assert np.allclose(R, R_mj.reshape(3, 3), rtol=0, atol=1e-15) and np.allclose(p, p_mj, rtol=0, atol=1e-15), frame


# ---- random MJCF: every feature drawn at random, MuJoCo the reference -------------------------------------------

def _f(x):
    return repr(float(x))


def _n(rng, k, s=1.0):
    return " ".join(repr(float(x)) for x in rng.normal(size=k) * s)


def _orientation(rng, deg, pin=False):
    kind = rng.choice(["none", "quat", "euler", "xyaxes", "zaxis"] + ([] if pin else ["axisangle"]))
    ang = lambda: repr(float(rng.uniform(-180, 180) if deg else rng.uniform(-3, 3)))  # noqa: E731
    return {"none": "", "quat": f'quat="{_n(rng, 4)}"', "euler": f'euler="{ang()} {ang()} {ang()}"',
            "axisangle": f'axisangle="{_n(rng, 3)} {ang()}"', "xyaxes": f'xyaxes="{_n(rng, 6)}"',
            "zaxis": f'zaxis="{_n(rng, 3)}"'}[kind]


def _geom(rng, deg, pin=False):
    kind = rng.choice(["sphere", "capsule", "cylinder", "box", "ellipsoid"])
    size = {"sphere": 1, "capsule": 2, "cylinder": 2, "box": 3, "ellipsoid": 3}[kind]
    size = " ".join(repr(float(x)) for x in rng.uniform(0.02, 0.2, size))
    mass = f' mass="{_f(rng.uniform(0.1, 3))}"' if rng.random() < 0.3 else ""
    if kind in ("capsule", "cylinder") and rng.random() < 0.5:
        return f'<geom type="{kind}" size="{size.split()[0]}" fromto="{_n(rng, 6, 0.2)}"{mass}/>'
    return f'<geom type="{kind}" size="{size}" pos="{_n(rng, 3, 0.1)}" {_orientation(rng, deg, pin)}{mass}/>'


def random_mjcf(seed, n=7, pin=False):
    """An MJCF tree of n bodies drawing each feature at random: angle unit, eulerseq, every orientation form, defaults
    with childclass, <frame>, 0-3 hinge/slide/ball joints per body with anchors, ref and armature, <inertial> diag or
    full or the geoms' inertia, sites. pin=True: without what Pinocchio 4.1's buildModelFromMJCF reads otherwise
    than MuJoCo (PIN_CASES below: eulerseq, ref, childclass, axisangle; one top-level body; and <frame>, whose
    bodies it leaves out)."""
    rng = np.random.default_rng(seed)
    deg = bool(rng.random() < 0.5)
    seq = "".join(rng.choice(list("xyzXYZ"), 3))
    out = [f'<mujoco model="random{seed}"><compiler angle="{"degree" if deg else "radian"}"'
           + ("/>" if pin else f' eulerseq="{seq}"/>'),
           f'<default><geom density="{_f(rng.uniform(300, 3000))}"/><default class="c"><joint axis="{_n(rng, 3)}"/>'
           f'<geom type="box" size="0.05 0.06 0.07"/></default></default><worldbody>']
    close = []
    for k in range(n):
        depth_back = int(rng.integers(0, len(close) + (0 if pin else 1))) if k else 0
        for _ in range(depth_back):
            out.append(close.pop())
        cc = ' childclass="c"' if rng.random() < 0.2 and not pin else ""
        if rng.random() < 0.2 and not pin:
            out.append(f'<frame pos="{_n(rng, 3, 0.1)}" {_orientation(rng, deg, pin)}>')
            close.append("</frame>")
        out.append(f'<body name="b{k}" pos="{_n(rng, 3, 0.3)}" {_orientation(rng, deg, pin)}{cc}>')
        close.append("</body>")
        ball = False                  # MuJoCo refuses a rotation after a ball in one body, and over 6 dofs in one
        for j in range(int(rng.integers(0 if k else 1, 4))):
            kind = "slide" if ball else str(rng.choice(["hinge", "hinge", "slide", "ball"]))
            ball = ball or kind == "ball"
            ref = f' ref="{_f(rng.uniform(-1, 1))}"' if rng.random() < 0.2 and not pin else ""
            axis = "" if cc and rng.random() < 0.5 else f' axis="{_n(rng, 3)}"'
            arm = f' armature="{_f(rng.uniform(0, 0.5))}"' if rng.random() < 0.3 else ""
            out.append(f'<joint name="j{k}_{j}" type="{kind}" pos="{_n(rng, 3, 0.1)}"{axis}{ref}{arm}/>')
        r = rng.random()
        if r < 0.3:
            I = rng.uniform(0.05, 0.1, 3)                                         # the triangle inequality holds
            out.append(f'<inertial pos="{_n(rng, 3, 0.1)}" {_orientation(rng, deg, pin)} mass="{_f(rng.uniform(0.5, 3))}" '
                       f'diaginertia="{_f(I[0])} {_f(I[1])} {_f((I[0] + I[1]) * 0.7)}"/>')
        elif r < 0.45:
            Q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
            I = Q @ np.diag(rng.uniform(0.05, 0.1, 3)) @ Q.T                       # principal moments: a triangle
            out.append(f'<inertial pos="{_n(rng, 3, 0.1)}" mass="{_f(rng.uniform(0.5, 3))}" fullinertia="'
                       + " ".join(repr(float(x)) for x in (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])) + '"/>')
        out += [_geom(rng, deg, pin) for _ in range(int(rng.integers(1, 3)))]
        if rng.random() < 0.5:
            out.append(f'<site name="s{k}" pos="{_n(rng, 3, 0.1)}" {_orientation(rng, deg, pin)}/>')
    out += close[::-1] + ["</worldbody></mujoco>"]
    return "\n".join(out)


@pytest.mark.parametrize("seed", range(12))
def test_random_mjcf_against_mujoco(seed):
    text = random_mjcf(seed)
    ours, m = quiet(md.load_mjcf_string, text), mujoco.MjModel.from_xml_string(text)
    e = mujoco_errors(ours, m, seed=seed)
    q, _, _ = random_state(ours, np.random.default_rng(seed))
    placed = placement_errors(ours, m, mujoco.MjData(m), q, bodies=False)
    print(f"\nrandom MJCF {seed} (nv = {ours.nv}): M, τ {e:.1e}, sites {placed:.1e}")
    assert e <= MJ and placed <= SITE


def test_random_mjcf_draws_ball_joints_alone_and_with_others_in_one_body():
    # the random trees cover what the ball tests are for: a ball alone in its body and after other joints in one
    models = [quiet(md.load_mjcf_string, random_mjcf(s)) for s in range(12)]
    balls = [(m, i) for m in models for i in range(m.njoints) if m.kind[i] == md.BALL]
    shared = [(m, i) for m, i in balls if ":" in m.body_names[i] or f"{m.body_names[i]}:" in " ".join(m.body_names)]
    assert len(balls) >= 20 and len(shared) >= 10 and len(balls) > len(shared)


@pytest.mark.parametrize("seed", range(8))
def test_random_mjcf_against_pinocchio(seed, tmp_path):
    pytest.importorskip("pinocchio")
    text = random_mjcf(seed, pin=True)
    ours = quiet(md.load_mjcf_string, text)
    e = pin_errors(ours, _write(tmp_path, f"random{seed}", text), seed=seed)
    print(f"\nrandom MJCF {seed} (Pinocchio's subset, nv = {ours.nv}, {int(np.sum(ours.kind == md.BALL))} ball(s)): "
          f"M, τ against Pinocchio {e:.1e}")
    assert e <= PIN
