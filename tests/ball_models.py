"""Ball-joint models as MJCF text for the simulation, closure, reduction and playback tests: a spherical
pendulum and a seeded random tree of ball and hinge joints (random placements, axes, masses and full
inertia tensors), no damping, armature, limits or contacts."""
import numpy as np

PENDULUM_MASS, PENDULUM_LENGTH, PENDULUM_RADIUS = 1.3, 0.8, 0.05

PENDULUM = f"""<mujoco model="spherical_pendulum"><option gravity="0 0 -9.81" integrator="RK4" timestep="1e-4"/>
<worldbody><body name="bob"><joint name="ball" type="ball"/>
<geom type="sphere" size="{PENDULUM_RADIUS}" pos="0 0 -{PENDULUM_LENGTH}" mass="{PENDULUM_MASS}"/>
</body></worldbody></mujoco>"""


def pendulum_inertia():
    """Inertia (3, 3) of the pendulum about its pivot: a solid sphere at (0, 0, −L), Steiner's theorem."""
    m, L, r = PENDULUM_MASS, PENDULUM_LENGTH, PENDULUM_RADIUS
    c = np.array([0.0, 0.0, -L])
    return 0.4 * m * r * r * np.eye(3) + m * (c @ c * np.eye(3) - np.outer(c, c))


def _rotation(rng):
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return Q * np.sign(np.linalg.det(Q))


def random_tree(seed, kinds="BHBHBH", gravity=(0.0, 0.0, -9.81), one_root=False):
    """MJCF text of a tree: body k (joint 'j{k}', type ball for 'B', hinge for 'H') hangs on a random earlier
    body, at a random offset, with a random hinge axis, mass in [0.5, 2] and a full inertia tensor R diag Rᵀ
    whose principal moments obey the triangle inequality. one_root: every body below body 0 (Pinocchio's
    buildModelFromMJCF reads only the first body under <worldbody>)."""
    rng = np.random.default_rng(seed)
    bodies = {-1: []}
    for k, kind in enumerate(kinds):
        parent = int(rng.integers(0 if one_root else -1, k)) if k else -1
        pos = " ".join(f"{x:.6f}" for x in rng.uniform(-0.3, 0.3, 3))
        com = " ".join(f"{x:.6f}" for x in rng.uniform(-0.2, 0.2, 3))
        d = rng.uniform(0.01, 0.05, 3)
        d[2] = rng.uniform(abs(d[0] - d[1]) + 0.002, d[0] + d[1] - 0.002)
        R = _rotation(rng)
        I = R @ np.diag(d) @ R.T
        full = " ".join(f"{x:.9f}" for x in (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]))
        if kind == "B":
            joint = f'<joint name="j{k}" type="ball" pos="{rng.uniform(-0.05, 0.05):.6f} 0 0"/>'
        else:
            axis = rng.normal(size=3)
            joint = f'<joint name="j{k}" type="hinge" axis="{" ".join(f"{x:.6f}" for x in axis)}"/>'
        bodies[k] = [f'<body name="b{k}" pos="{pos}">{joint}'
                     f'<inertial pos="{com}" mass="{rng.uniform(0.5, 2.0):.6f}" fullinertia="{full}"/>']
        bodies[parent].append(k)

    def write(k):
        head, kids = bodies[k][0], bodies[k][1:]
        return head + "".join(write(c) for c in kids) + "</body>"
    g = " ".join(str(x) for x in gravity)
    return (f'<mujoco model="ball_tree_{seed}"><option gravity="{g}"/><worldbody>'
            + "".join(write(c) for c in bodies[-1]) + "</worldbody></mujoco>")


# A spatial four-bar (RSSR): crank (hinge z) — coupler (ball at the crank's tip) — rocker (hinge x), the coupler's
# far end tied to the rocker's tip by a connect (a spherical closure); 2 degrees of freedom: the crank and the
# coupler's spin about the line through its two spherical joints. {d}: the equality's solimp impedance.
RSSR = """<mujoco model="rssr"><option gravity="0 0 -9.81"/>
<worldbody>
 <body name="crank"><joint name="crank" axis="0 0 1"/>
  <inertial pos="0.15 0 0" mass="1.0" diaginertia="0.002 0.01 0.01"/>
  <body name="coupler" pos="0.3 0 0"><joint name="cball" type="ball"/>
   <inertial pos="0.15 0.25 0.2" mass="0.7" fullinertia="0.02 0.015 0.012 0.003 -0.002 0.001"/></body></body>
 <body name="rocker" pos="0.6 0.5 0"><joint name="rocker" axis="1 0 0"/>
  <inertial pos="0 0 0.2" mass="0.5" diaginertia="0.008 0.008 0.001"/></body>
</worldbody>
<equality><connect name="loop" body1="coupler" body2="rocker" anchor="0.3 0.5 0.4" solimp="{d} {d} 0.001 0.5 2"/>
</equality></mujoco>"""

# A Stewart-like leg hanging from a ball hip, a knee hinge, its foot tied to a world point by a connect; 1 degree
# of freedom (the leg's spin about the hip-foot line) plus a second, ball-jointed leg on the foot's body.
LEG = """<mujoco model="ball_leg"><option gravity="0 0 -9.81"/>
<worldbody>
 <body name="thigh" pos="0 0 1"><joint name="hip" type="ball"/>
  <inertial pos="0.02 0.01 -0.2" mass="1.2" fullinertia="0.03 0.028 0.004 0.001 0.002 -0.001"/>
  <body name="shank" pos="0.05 0 -0.45"><joint name="knee" axis="0 1 0"/>
   <inertial pos="0.1 0 -0.15" mass="0.8" diaginertia="0.015 0.014 0.002"/>
   <body name="foot" pos="0.25 0.05 -0.3" euler="0.2 0.1 0"><joint name="ankle" type="ball" pos="0 0 0.02"/>
    <inertial pos="0.05 0.02 -0.03" mass="0.3" fullinertia="0.002 0.003 0.0025 0.0002 0.0001 -0.0003"/>
   </body></body></body>
</worldbody>
<equality><connect name="toe" body1="shank" anchor="0.25 0.05 -0.3" solimp="{d} {d} 0.001 0.5 2"/>
</equality></mujoco>"""


def mujoco_state(model, m, q, v):
    """MuJoCo's (qpos, qvel) for our (q, v) and iv, MuJoCo's dof index of each entry of our v, joints matched by
    name: a ball's qpos is [w x y z] (ours x y z w), its qvel the same body-frame ω."""
    qpos, qvel, iv = np.empty(m.nq), np.empty(m.nv), np.empty(model.nv, int)
    for i, name in enumerate(model.joint_names):
        j = m.joint(name).id
        a, b, k, r, n = m.jnt_qposadr[j], m.jnt_dofadr[j], model.idx_q[i], model.idx_v[i], model.nvs[i]
        qpos[a:a + model.nqs[i]] = np.r_[q[k + 3], q[k:k + 3]] if model.nqs[i] == 4 else q[k]
        qvel[b:b + n] = v[r:r + n]
        iv[r:r + n] = np.arange(b, b + n)
    return qpos, qvel, iv
