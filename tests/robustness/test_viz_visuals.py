"""Hostile visuals and trajectories: bad numbers in <visual> are skipped with a GeometryWarning naming the link
and the value; playback work is bounded (frame cap) and bad trajectories raise InputError; a closed chain
that cannot be assembled raises ConstraintError naming the frame."""
from __future__ import annotations

import time
import warnings

import numpy as np
import pytest
from conftest import assert_close, inertial_xml, urdf

import manipdyn as md
from manipdyn import viz
from manipdyn.errors import GeometryWarning
from manipdyn.paths import bundled_dir
from manipdyn.viz import scene as vscene
from manipdyn.viz.geometry import load_visuals

INERTIAL = inertial_xml(1.0, I=(0.01, 0.01, 0.01, 0, 0, 0))


def arm_with_visual(tmp_path, visual_xml, extra=""):
    """URDF path of a one-joint arm whose link 'arm' holds ``visual_xml``; meshes/ok.stl and meshes/x.ply exist."""
    (tmp_path / "meshes").mkdir(exist_ok=True)
    (tmp_path / "meshes" / "ok.stl").write_text("solid a\nendsolid a\n")
    (tmp_path / "meshes" / "x.ply").write_text("ply\n")
    (tmp_path / "meshes" / "bad.dae").write_bytes(b"\xff\xfe<COLLADA>\x80\x81")
    text = urdf({"base": "", "arm": INERTIAL + visual_xml},
                [("j1", "revolute", "base", "arm", (0, 0, 0.1), (0, 0, 0), (0, 0, 1))])
    path = tmp_path / "r.urdf"
    path.write_text(text.replace("</robot>", extra + "</robot>"))
    return path


def geom(inner, origin="", material=""):
    return f"<visual>{origin}<geometry>{inner}</geometry>{material}</visual>"


BAD = {   # id: (visual xml, text the warning must quote)
    "box-negative": (geom('<box size="-1 1 1"/>'), "-1 1 1"),
    "box-zero": (geom('<box size="0 1 1"/>'), "0 1 1"),
    "box-nan": (geom('<box size="nan 1 1"/>'), "nan 1 1"),
    "box-inf": (geom('<box size="inf 1 1"/>'), "inf 1 1"),
    "box-overflow": (geom('<box size="1e999 1 1"/>'), "1e999 1 1"),
    "box-two-numbers": (geom('<box size="1 1"/>'), "'1 1'"),
    "box-four-numbers": (geom('<box size="1 1 1 1"/>'), "1 1 1 1"),
    "box-underscore-digits": (geom('<box size="1_0 1 1"/>'), "1_0 1 1"),
    "box-hex": (geom('<box size="0x1 1 1"/>'), "0x1 1 1"),
    "box-arabic-digits": (geom('<box size="\u0661 1 1"/>'), "size="),
    "box-missing-size": (geom("<box/>"), "no size"),
    "sphere-negative": (geom('<sphere radius="-0.1"/>'), "-0.1"),
    "sphere-zero": (geom('<sphere radius="0"/>'), "'0'"),
    "sphere-nan": (geom('<sphere radius="NaN"/>'), "NaN"),
    "cylinder-negative-radius": (geom('<cylinder radius="-1" length="1"/>'), "-1"),
    "cylinder-inf-length": (geom('<cylinder radius="1" length="inf"/>'), "inf"),
    "cylinder-missing-length": (geom('<cylinder radius="1"/>'), "no length"),
    "mesh-scale-two": (geom('<mesh filename="meshes/ok.stl" scale="1 1"/>'), "1 1"),
    "mesh-scale-nan": (geom('<mesh filename="meshes/ok.stl" scale="nan 1 1"/>'), "nan 1 1"),
    "mesh-scale-inf": (geom('<mesh filename="meshes/ok.stl" scale="1 -inf 1"/>'), "-inf"),
    "mesh-scale-zero": (geom('<mesh filename="meshes/ok.stl" scale="1 0 1"/>'), "1 0 1"),
    "mesh-unknown-format": (geom('<mesh filename="meshes/x.ply"/>'), ".ply"),
    "mesh-missing-file": (geom('<mesh filename="meshes/none.stl"/>'), "none.stl"),
    "mesh-not-utf8": (geom('<mesh filename="meshes/bad.dae"/>'), "bad.dae"),
    "mesh-empty-filename": (geom('<mesh filename=""/>'), "''"),
    "rgba-above-one": (geom('<box size="1 1 1"/>', material='<material name="m"><color rgba="1 0 0 2"/></material>'),
                       "1 0 0 2"),
    "rgba-negative": (geom('<box size="1 1 1"/>', material='<material name="m"><color rgba="-0.1 0 0 1"/></material>'),
                      "-0.1 0 0 1"),
    "rgba-nan": (geom('<box size="1 1 1"/>', material='<material name="m"><color rgba="nan 0 0 1"/></material>'),
                 "nan 0 0 1"),
    "rgba-three-numbers": (geom('<box size="1 1 1"/>', material='<material name="m"><color rgba="1 0 0"/></material>'),
                           "1 0 0"),
    "origin-nan": (geom('<box size="1 1 1"/>', origin='<origin xyz="nan 0 0"/>'), "nan 0 0"),
    "origin-rpy-two": (geom('<box size="1 1 1"/>', origin='<origin rpy="1 2"/>'), "'1 2'"),
    "geometry-empty": (geom(""), "found 0"),
    "geometry-two-shapes": (geom('<box size="1 1 1"/><sphere radius="1"/>'), "found 2"),
}


@pytest.mark.parametrize("visual,quoted", list(BAD.values()), ids=list(BAD))
def test_bad_visual_is_skipped_with_a_warning(visual, quoted, tmp_path):
    path = arm_with_visual(tmp_path, visual)
    with pytest.warns(GeometryWarning) as caught:
        assert load_visuals(path) == []
    texts = [str(w.message) for w in caught if issubclass(w.category, GeometryWarning)]
    assert len(texts) == 1 and "link 'arm'" in texts[0] and quoted in texts[0], texts
    try:                                    # the model loader may refuse the file outright (also safe) ...
        model = md.load_urdf(path)
    except md.URDFError as exc:
        assert "r.urdf" in str(exc)
        return
    with warnings.catch_warnings():         # ... else playback still draws the arm (its joint housing)
        warnings.simplefilter("ignore", GeometryWarning)
        sc = viz.scene_for(model, path, [0.0, 1.0], [[0.0], [0.5]])
    assert any(c.lower()["path"].endswith("/arm/joint") for c in sc.commands if "path" in c.lower())


def test_good_visuals_placements(tmp_path):
    # cylinder: meshcat's axis (y) must become the URDF's z axis, turned by the origin: Ry(π/2) z = x
    visuals = (geom('<cylinder radius="0.1" length="1"/>', origin='<origin xyz="1 2 3" rpy="0 1.5707963267948966 0"/>')
               + geom('<mesh filename="meshes/ok.stl" scale="2 -3 0.5"/>', material='<material name="blue"/>')
               + geom('<box size="1 2 3"/>') + geom('<sphere radius="0.5"/>'))
    path = arm_with_visual(tmp_path, visuals, '<material name="blue"><color rgba="0 0 1 0.5"/></material>')
    with warnings.catch_warnings():
        warnings.simplefilter("error", GeometryWarning)
        cyl, mesh, box, sphere = load_visuals(path)
    assert_close(cyl.placement[:3, :3] @ [0, 1, 0], [1, 0, 0], 1e-15, "cylinder axis")   # measured 6e-17
    assert_close(cyl.placement[:3, 3], [1, 2, 3], 0, "cylinder origin")
    assert_close(mesh.placement[:3, :3], np.diag([2, -3, 0.5]), 0, "mesh scale")
    assert mesh.rgba == (0.0, 0.0, 1.0, 0.5) and box.rgba == sphere.rgba == viz.geometry.DEFAULT_RGBA


def two_sample(model, span):
    """A trajectory over [0, span] s: two samples, every joint from 0 to 1 rad."""
    return np.array([0.0, span]), np.vstack([np.zeros(model.nv), np.ones(model.nv)])


@pytest.mark.parametrize("span", [1e5, 1e6, 1e7, 1e12])
def test_frame_cap(span):
    model = md.load_urdf(bundled_dir() / "aau_arm.urdf")
    t, Q = two_sample(model, span)
    t0 = time.perf_counter()
    with pytest.warns(viz.PlaybackWarning, match="frame cap"):
        sc = viz.scene_for(model, None, t, Q)
    print(f"\nspan {span:g} s: {len(sc.times)} frames at {sc.fps:.3g} fps in {time.perf_counter() - t0:.2f} s")
    assert len(sc.times) == viz.MAX_FRAMES == vscene.max_frames(model) and sc.notes
    assert_close(sc.times[[0, -1]], [0.0, span], 0, "first and last frame time")
    assert_close(sc.fps, (viz.MAX_FRAMES - 1) / span, 1e-15, "fps")
    for k in (0, 1234, len(sc.times) - 1):            # frames are forward kinematics at their times
        q = np.full(model.nv, sc.times[k] / span)
        for b, body in enumerate(model.body_names):
            R, p = md.frame_placement(model, q, body)
            assert_close(sc.frames[sc.nodes[b]][k][:3, :3], R, 1e-12, "R")     # measured 2e-16
            assert_close(sc.frames[sc.nodes[b]][k][:3, 3], p, 1e-12, "p")


def test_frame_cap_shrinks_with_many_bodies():
    n = 120
    links = {"base": ""} | {f"l{i}": INERTIAL for i in range(n)}
    joints = [(f"j{i}", "revolute", "base" if i == 0 else f"l{i - 1}", f"l{i}", (0, 0, 0.01), (0, 0, 0), (0, 1, 0))
              for i in range(n)]
    model = md.load_urdf_string(urdf(links, joints))
    with pytest.warns(viz.PlaybackWarning):
        sc = viz.scene_for(model, None, *two_sample(model, 1e4))
    assert len(sc.times) == vscene.MAX_KEYS // n and len(sc.times) * model.nv <= vscene.MAX_KEYS


def test_short_motion_keeps_its_fps():
    model = md.load_urdf(bundled_dir() / "aau_arm.urdf")
    with warnings.catch_warnings():
        warnings.simplefilter("error", viz.PlaybackWarning)
        sc = viz.scene_for(model, None, *two_sample(model, 4.0))
    assert len(sc.times) == 121 and sc.fps == 30.0 and not sc.notes


BAD_TRAJ = {  # id: (t, Q rows as a function of nv, fps, message)
    "t-nan": ([0.0, np.nan], None, 30, "non-finite"),
    "t-inf": ([0.0, np.inf], None, 30, "non-finite"),
    "span-overflow": ([-1e308, 1e308], None, 30, "not finite"),
    "t-decreasing": ([1.0, 0.0], None, 30, "increase"),
    "t-repeated": ([0.0, 0.0], None, 30, "increase"),
    "t-2d": ([[0.0, 1.0]], None, 30, "1-D"),
    "t-empty": ([], "empty", 30, "1-D"),
    "q-nan": ([0.0, 1.0], "nan", 30, "non-finite"),
    "q-inf": ([0.0, 1.0], "inf", 30, "non-finite"),
    "q-wrong-width": ([0.0, 1.0], "narrow", 30, "shape"),
    "q-wrong-length": ([0.0, 1.0, 2.0], None, 30, "shape"),
    "fps-zero": ([0.0, 1.0], None, 0, "fps"),
    "fps-negative": ([0.0, 1.0], None, -30, "fps"),
    "fps-nan": ([0.0, 1.0], None, float("nan"), "fps"),
    "fps-inf": ([0.0, 1.0], None, float("inf"), "fps"),
    "fps-huge": ([0.0, 1.0], None, 1e9, "fps"),
    "fps-string": ([0.0, 1.0], None, "30", "fps"),
}


@pytest.mark.parametrize("t,q,fps,msg", list(BAD_TRAJ.values()), ids=list(BAD_TRAJ))
def test_bad_trajectory_raises_input_error(t, q, fps, msg):
    model = md.load_urdf(bundled_dir() / "aau_arm.urdf")
    Q = np.zeros((2, model.nv))
    if q == "nan":
        Q[1, 2] = np.nan
    elif q == "inf":
        Q[0, 0] = np.inf
    elif q == "narrow":
        Q = Q[:, :-1]
    elif q == "empty":
        Q = np.zeros((0, model.nv))
    with pytest.raises(md.InputError, match=msg):
        viz.scene_for(model, None, t, Q, fps=fps)


def test_too_many_samples(monkeypatch, tmp_path):
    model = md.load_urdf(bundled_dir() / "aau_arm.urdf")
    monkeypatch.setattr(vscene, "MAX_SAMPLES", 10)
    with pytest.raises(md.InputError, match="1 to 10 samples"):
        viz.scene_for(model, None, np.arange(11.0), np.zeros((11, model.nv)))
    from manipdyn.io import trajectory
    monkeypatch.setattr(trajectory, "MAX_TRAJECTORY_BYTES", 10)
    (tmp_path / "big.csv").write_text("t,q_x\n" + "0,0\n" * 10)
    with pytest.raises(md.InputError, match="bytes"):
        viz.read_trajectory(tmp_path / "big.csv", model)


def fourbar(ground):
    """A planar four-bar (crank 0.1, coupler 0.35, rocker 0.3) with its pivots ``ground`` m apart."""
    I = (1e-4, 1e-4, 1e-4, 0, 0, 0)
    links = {"base": "", "crank": inertial_xml(0.2, I=I), "coupler": inertial_xml(0.5, I=I),
             "rocker": inertial_xml(0.4, I=I)}
    joints = [("j1", "revolute", "base", "crank", (0, 0, 0), (0, 0, 0), (0, 1, 0)),
              ("j2", "revolute", "crank", "coupler", (0.1, 0, 0), (0, 0, 0), (0, 1, 0)),
              ("j3", "revolute", "base", "rocker", (ground, 0, 0), (0, 0, 0), (0, 1, 0))]
    loop = ('<constraint name="loop" type="revolute"><parent link="coupler"/><parent_origin xyz="0.35 0 0" '
            'rpy="0 0 0"/><parent_axis xyz="0 1 0"/><child link="rocker"/><child_origin xyz="0.3 0 0" rpy="0 0 0"/>'
            '<child_axis xyz="0 1 0"/></constraint><transmission name="t"><joint name="j1"/></transmission>')
    return md.load_urdf_string(urdf(links, joints, name="fourbar").replace("</robot>", loop + "</robot>"))


def test_complete_assembles_from_a_poor_guess():
    # all-zero start is a singular (collinear) pose: complete must still close the loop at every frame
    model = fourbar(0.4)
    Q = np.full((5, model.nv), np.nan)
    Q[:, model.joint_index("j1")] = np.linspace(0.0, 1.0, 5)
    out = viz.complete(model, Q, guess=np.zeros(model.nv))
    from manipdyn.constraints import closure_terms
    assert_close(closure_terms(model, out)[0], np.zeros((5, closure_terms(model, out)[0].shape[1])), 1e-10,
                 "closure residual")                        # assembly tolerance 1e-12
    assert_close(out[:, model.joint_index("j1")], Q[:, model.joint_index("j1")], 0, "crank held")


def test_complete_names_the_frame_it_cannot_assemble():
    model = fourbar(5.0)                                    # pivots 5 m apart: links of 0.75 m cannot close
    Q = np.full((3, model.nv), np.nan)
    Q[:, model.joint_index("j1")] = 0.3
    with pytest.raises(md.ConstraintError, match=r"frame 0 \(j1 = 0\.3\).*starting guesses"):
        viz.complete(model, Q)
