"""Large URDFs: deep chains and wide stars load without RecursionError, in time linear in the number of
links, and the algorithms run on them. Sizes far beyond any robot (5 000–10 000 links); the time bounds
are generous (a quadratic loader took 85 s on a 40 000-link star), and the scaling test compares two sizes
in CPU time so a busy machine does not make it fail.
"""
import sys
import time

import numpy as np
import pytest
from conftest import assert_close

import manipdyn as md
from manipdyn import URDFError

G, M, L = 9.81, 1.0, 0.125   # gravity, link mass (kg), link length (m; exact in binary)


def chain(n, dx=L):
    """n links in a row along x, revolute about y, mass M at each joint's origin."""
    parts = ['<?xml version="1.0"?>\n<robot name="chain">', '<link name="l0"/>']
    for i in range(1, n + 1):
        parts.append(f'<link name="l{i}"><inertial><mass value="{M}"/><inertia ixx="0.01" ixy="0" ixz="0" '
                     f'iyy="0.01" iyz="0" izz="0.01"/></inertial></link>')
        parts.append(f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
                     f'<origin xyz="{dx} 0 0"/><axis xyz="0 1 0"/>'
                     f'<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')
    return "\n".join(parts + ["</robot>"])


def star(n):
    """n links hanging off one root link."""
    parts = ['<?xml version="1.0"?>\n<robot name="star">', '<link name="l0"/>']
    for i in range(1, n + 1):
        parts.append(f'<link name="l{i}"><inertial><mass value="{M}"/><inertia ixx="0.01" ixy="0" ixz="0" '
                     f'iyy="0.01" iyz="0" izz="0.01"/></inertial></link>')
        parts.append(f'<joint name="j{i}" type="revolute"><parent link="l0"/><child link="l{i}"/>'
                     f'<origin xyz="0 {L} 0"/><axis xyz="1 0 0"/>'
                     f'<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')
    return "\n".join(parts + ["</robot>"])


def cpu_load(text):
    t = time.process_time()
    model = md.load_urdf_string(text)
    return model, time.process_time() - t


@pytest.fixture(scope="module")
def chain5000():
    return md.load_urdf_string(chain(5000))


def test_chain_5000_loads_below_the_recursion_limit(chain5000):
    assert sys.getrecursionlimit() < 5000 * 2            # a recursive walk would have failed
    assert chain5000.nv == 5000 and list(chain5000.parent) == list(range(-1, 4999))


def test_rnea_on_chain_5000_is_the_closed_form(chain5000):
    # horizontal chain at q = 0, at rest: τ_i = -M g Σ_{k>=i} (x_k - x_i) = -M g L (n-i)(n-i+1)/2
    n = chain5000.nv
    tau = md.rnea(chain5000, np.zeros(n), np.zeros(n), np.zeros(n))
    m = n - np.arange(n) - 1.0
    assert_close(tau, -M * G * L * m * (m + 1) / 2, 1e-13, "gravity torques")   # measured 1.7e-14


def test_jacobian_on_chain_5000_is_the_closed_form(chain5000):
    # tip velocity along z from joint j (about y): y × (x_tip - x_j) e_x = -(x_tip - x_j) e_z
    n = chain5000.nv
    J = md.frame_jacobian(chain5000, np.zeros(n), f"l{n}")
    expected = np.zeros((6, n))
    expected[2] = -L * (n - np.arange(n) - 1.0)
    expected[4] = 1.0
    assert_close(J, expected, 1e-15, "tip Jacobian")                              # measured 0 (exact)


def test_reduce_chain_5000(chain5000):
    # lock every other joint at 0: the kept joints' gravity torques are those of the full chain
    n = chain5000.nv
    locked = {f"j{i}": 0.0 for i in range(2, n + 1, 2)}
    reduced = md.reduce(chain5000, locked=locked)
    assert reduced.nv == n // 2 and reduced.mass.sum() == chain5000.mass.sum()
    full = md.rnea(chain5000, np.zeros(n), np.zeros(n), np.zeros(n))
    tau = md.rnea(reduced, np.zeros(reduced.nv), np.zeros(reduced.nv), np.zeros(reduced.nv))
    assert_close(tau, full[::2], 1e-13, "reduced gravity torques")               # measured 1.5e-14
    tips = md.reduce(chain5000, root="l0", tips=[f"l{n // 2}"])
    assert tips.nv == n // 2


@pytest.mark.parametrize("kind", ["chain", "star"])
def test_10000_links_load_in_seconds(kind):
    model, cpu = cpu_load({"chain": chain, "star": star}[kind](10_000))
    assert model.nv == 10_000
    assert cpu < 60.0                        # measured 2.2 s (chain), 2.4 s (star) CPU; generous


def test_load_time_is_linear_in_links():
    # a quadratic step would scale ~16x between the two sizes; linear scales 4x (measured 0.21 s ->
    # 0.83 s CPU); the bound is 8x
    small = min(cpu_load(star(1_000))[1] for _ in range(2))
    large = min(cpu_load(star(4_000))[1] for _ in range(2))
    assert large < 8.0 * small, (small, large)


def test_duplicate_name_in_a_large_file_is_named():
    text = star(10_000).replace('<link name="l9999">', '<link name="l17">')
    with pytest.raises(URDFError, match="duplicate link name"):
        md.load_urdf_string(text)


def test_long_dangling_chain_is_named():
    # 2 000 links whose first joint hangs off a link that does not exist: the message names it
    text = chain(2000).replace('<parent link="l0"/>', '<parent link="nowhere"/>')
    with pytest.raises(URDFError, match="joint 'j1': parent link 'nowhere' is not defined"):
        md.load_urdf_string(text)
