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


def random_tree(seed, kinds="BHBHBH", gravity=(0.0, 0.0, -9.81)):
    """MJCF text of a tree: body k (joint 'j{k}', type ball for 'B', hinge for 'H') hangs on a random earlier
    body, at a random offset, with a random hinge axis, mass in [0.5, 2] and a full inertia tensor R diag Rᵀ
    whose principal moments obey the triangle inequality."""
    rng = np.random.default_rng(seed)
    bodies = {-1: []}
    for k, kind in enumerate(kinds):
        parent = int(rng.integers(-1, k)) if k else -1
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
