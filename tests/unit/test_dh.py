"""D-H -> URDF: frames and mass properties against the D-H products computed here, via Pinocchio's FK."""
import importlib.util

import numpy as np
import pinocchio as pin
import pytest
from conftest import ROOT, AAU, assert_close

import manipdyn as md
from manipdyn.errors import URDFError


def Rz(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def Rx(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def Tr(x, y, z):
    T = np.eye(4)
    T[:3, 3] = x, y, z
    return T


def dh_frames(table, q, convention):
    """World poses of D-H frames 1..n, straight from the D-H definitions."""
    T, out = np.eye(4), []
    for row, qi in zip(table, q):
        th = row["theta"] + (qi if row["type"] == "revolute" else 0.0)
        d = row["d"] + (qi if row["type"] == "prismatic" else 0.0)
        if convention == "standard":
            T = T @ Rz(th) @ Tr(0, 0, d) @ Tr(row["a"], 0, 0) @ Rx(row["alpha"])
        else:
            T = T @ Rx(row["alpha"]) @ Tr(row["a"], 0, 0) @ Rz(th) @ Tr(0, 0, d)
        out.append(T)
    return out


def random_table(rng, n):
    rows = []
    for _ in range(n):
        d = rng.uniform(0.01, 0.1, 3)
        m = rng.uniform(0.5, 3.0)
        Rr = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        I = Rr @ np.diag(m * np.array([d[1] + d[2], d[0] + d[2], d[0] + d[1]])) @ Rr.T
        rows.append(dict(type=rng.choice(["revolute", "prismatic"]), alpha=rng.uniform(-np.pi, np.pi),
                         a=rng.uniform(-0.5, 0.5), d=rng.uniform(-0.5, 0.5), theta=rng.uniform(-np.pi, np.pi),
                         mass=m, com=rng.uniform(-0.2, 0.2, 3), inertia=I))
    return rows


@pytest.mark.parametrize("convention", ["standard", "modified"])
@pytest.mark.parametrize("seed", range(4))
def test_frames_and_mass_properties(convention, seed):
    rng = np.random.default_rng(seed)
    table = random_table(rng, 5)
    text = md.dh_to_urdf(table, convention=convention, tool={"name": "tool", "xyz": [0.1, 0.2, 0.3],
                                                            "rpy": [0.3, -0.2, 0.1]})
    pm = pin.buildModelFromXML(text)
    pd = pm.createData()
    T_tool = Tr(0.1, 0.2, 0.3) @ _rpy(0.3, -0.2, 0.1)
    for _ in range(5):
        q = rng.uniform(-1, 1, 5)
        pin.forwardKinematics(pm, pd, q)
        pin.updateFramePlacements(pm, pd)
        frames = dh_frames(table, q, convention)
        tool = pd.oMf[pm.getFrameId("tool")]
        assert_close(tool.homogeneous, frames[-1] @ T_tool, 5e-14, "tool pose")  # measured 1.7e-15
        for i, (row, T) in enumerate(zip(table, frames)):
            oMi = pd.oMi[i + 1]
            inert = pm.inertias[i + 1]             # the massless tool merged into link 5 changes nothing
            c_world = oMi.act(inert.lever)
            I_world = oMi.rotation @ inert.inertia @ oMi.rotation.T
            assert_close(c_world, T[:3, :3] @ row["com"] + T[:3, 3], 5e-14, f"CoM of link {i + 1}")  # measured 1.4e-15
            assert_close(I_world, T[:3, :3] @ row["inertia"] @ T[:3, :3].T, 5e-14, f"inertia of link {i + 1}")  # measured 1.4e-15


def _rpy(r, p, y):
    from manipdyn.spatial import rpy_matrix
    T = np.eye(4)
    T[:3, :3] = rpy_matrix([r, p, y])
    return T


def test_aau_urdf_is_regenerated_by_its_script():
    spec = importlib.util.spec_from_file_location("make_aau", ROOT / "scripts" / "make_aau_urdf.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert AAU.read_text() == mod.build()
    pm = pin.buildModelFromUrdf(str(AAU))
    assert pm.nq == pm.nv == 5 and tuple(pm.names[1:]) == tuple(f"joint{i}" for i in range(1, 6))
    model = md.load_urdf(AAU)
    assert model.frame("tool").body == 4


@pytest.mark.parametrize("row,match", [
    (dict(alpha=0, a=0, d=0), r"row 1: missing key 'theta'"),
    (dict(alpha=0, a=0, d=0, theta="x"), r"row 1: theta = 'x' is not a number"),
    (dict(alpha=0, a=0, d=0, theta=0, mass=-1), r"row 1: negative mass"),
    (dict(alpha=0, a=0, d=0, theta=0, type="ball"), r"row 1: type 'ball'"),
    (dict(alpha=np.nan, a=0, d=0, theta=0), r"row 1: alpha = nan is not finite"),
    (dict(alpha=0, a=0, d=0, theta=0, inertia=[[1, 2, 0], [0, 1, 0], [0, 0, 1]]), "not symmetric"),
])
def test_bad_tables_name_the_row(row, match):
    with pytest.raises(URDFError, match=match):
        md.dh_to_urdf([row])
    with pytest.raises(URDFError, match="convention"):
        md.dh_to_urdf([dict(alpha=0, a=0, d=0, theta=0)], convention="craig")
