"""The plots beside the robot: torques along a trajectory file (finite-difference rates, then rnea or the
constrained inverse dynamics) against torques from exact rates; the SPM demo's marks and series."""
import numpy as np
import pytest
from conftest import ROOT, assert_close

import manipdyn as md
from manipdyn import viz
from manipdyn.viz import plots


def test_traj_file_torques_match_exact_rates(tmp_path):
    # the AAU path written as q only: rates by finite differences, τ by rnea, against rnea on the path's
    # exact rates (the IK's differential kinematics; rnea itself is checked against Pinocchio elsewhere)
    from manipdyn.examples import aau_arm as ex
    model = md.load_urdf(ROOT / "urdf" / "aau_arm.urdf")
    traj = ex.follow(model, *(lambda t: (t, *ex.path(t)))(np.linspace(0.0, 2 * np.pi, 801)),
                     ex.initial_configuration(model))
    csv = tmp_path / "q.csv"
    np.savetxt(csv, np.column_stack([traj.t, traj.q]), delimiter=",", comments="",
               header="t," + ",".join(f"q_{j}" for j in model.joint_names))
    t, Q = viz.read_trajectory(csv, model)
    tau, names = plots.torques(model, t, Q)
    exact = md.rnea(model, traj.q, traj.v, traj.a)
    # second-order differences with h = 7.9 ms: measured 3.1e-6 (the §3 measure over the path)
    assert_close(tau, exact, 3e-4, "τ from finite-difference rates")
    assert names == list(model.joint_names)
    sig = plots.signals(model, t, Q)
    assert [g["key"] for g in sig["groups"]] == ["q", "v", "tau"] and len(sig["t"]) == plots.MAX_POINTS
    k = np.unique(np.linspace(0, len(t) - 1, plots.MAX_POINTS).round().astype(int))
    assert_close(np.array(sig["groups"][2]["series"]).T, tau[k], 5e-5, "plotted τ (5 digits)")   # rounding to 5 digits: ≤ 5e-5; measured 1.8e-5


def test_closed_chain_torques_from_positions_only():
    # the SPM's Fig. 7 motion given as positions only (the completed tree at 240 samples/s): actuator
    # torques by finite differences + closures + constrained inverse dynamics, against the chapter's own
    # formulation (examples/spm.py, Eqs. 33–61) on exact rates, without the external moment
    from manipdyn.examples import spm as chapter
    path = ROOT / "urdf" / "spm.urdf"
    model = md.load_urdf(path)
    m = viz.demo_motion(model, path)
    tau, names = plots.torques(model, m["t"], m["Q"])
    ref = chapter.fig7(m["t"], moment=np.zeros(3)).tau
    # Fig. 7's actuator angles are linear in t (θ̈ = 0), so their differences are exact and the passive
    # rates follow from the closures: what remains is round-off, measured 1.9e-13
    assert names == list(model.actuated)
    assert_close(tau, ref, 2e-11, "actuator torques")


def test_spm_demo_marks_the_leg_singularity():
    path = ROOT / "urdf" / "spm.urdf"
    model = md.load_urdf(path)
    m = viz.demo_motion(model, path)
    sc = viz.scene_for(model, path, m.pop("t"), m.pop("Q"), **m)
    (mark,) = sc.plots["marks"]
    # docs/design.md §6: leg 2's (u₂ × v₂)·w₂ reaches 0 at t ≈ 0.28 s (checked at 1 ms steps)
    assert mark["label"] == "leg 2 singular" and 0.275 < mark["t"] < 0.29
    assert sc.fps == viz.SPM_FPS and len(sc.times) == 61 and sc.times[-1] == pytest.approx(0.25, abs=1e-12)
    assert [g["key"] for g in sc.plots["groups"]] == ["q", "v", "tau", "gap"]
    assert max(max(s) for s in sc.plots["groups"][3]["series"]) < 1e-9      # the loops stay closed


def test_underactuated_chain_plots_without_torques(tmp_path):
    # a four-bar whose crank is not actuated: no torques can produce the motion; the page says why
    text = (ROOT / "urdf" / "fourbar.urdf").read_text()
    cut = text.index("<transmission name")
    path = tmp_path / "fourbar_free.urdf"
    path.write_text(text[:cut] + text[text.index("</transmission>") + len("</transmission>"):])
    model = md.load_urdf(path)
    t = np.linspace(0.0, 1.0, 11)
    base = md.load_urdf(ROOT / "urdf" / "fourbar.urdf")
    Q = viz.demo(base, ROOT / "urdf" / "fourbar.urdf")[1][:11]
    sig = plots.signals(model, t, Q)
    assert [g["key"] for g in sig["groups"]] == ["q", "v", "gap"] and "torques not shown" in sig["notes"][0]
