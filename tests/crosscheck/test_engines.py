"""Other engines as referees (manipdyn.validation.referee): what each engine does with one URDF quirk, the cause
the referee names for it (link and kind), and agreement once the engine's own parameters are fed back.

The quirk files are tests/data/quirks/*.urdf: two revolute joints, the quirk on ``link1`` (or on the joints).
Every expectation below was measured from the engine itself (its read-back parameters and its τ, M, q̈), on
MuJoCo 4.0, PyBullet 3.2.7, Drake 1.51 and Pinocchio 4.1; an engine that is not installed skips its cases.
Tolerances: the worst neutralised error measured over these files and arms is 4e-15 (τ, M, q̈/cond M) for
every engine; NEUTRAL = 1e-13 is within 100x of it. PyBullet's own round-off reaches 2.4e-13 un-neutralised
(its principal-axes diagonalisation holds inertias to ~3e-9 relative): RAW_PB = 1e-11.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import AAU, ROOT

from manipdyn.io.urdf import load_urdf
from manipdyn.validation import adapters as A
from manipdyn.validation import referee as R
from manipdyn.validation.causes import neutralised
from manipdyn.validation.referee_urdf import urdf_inertials

QUIRKS = ROOT / "tests" / "data" / "quirks"
NEUTRAL = 1e-13          # measured ≤ 4e-15 after neutralising, every engine, every file here
RAW = 1e-13              # engines in double precision without a quirk: measured ≤ 4.2e-15
RAW_PB = 1e-11           # PyBullet without a quirk: measured ≤ 2.4e-13
N = 10                   # random states per file


def need(engine):
    pytest.importorskip(A.MODULES[engine])


def run(path, engine, n=N):
    with _nowarn():
        model = load_urdf(path)
    rep = R.referee(model, path, [engine], n_states=n, seed=3)
    return model, rep.engines[0]


class _nowarn:
    def __enter__(self):
        import warnings
        self.c = warnings.catch_warnings()
        self.c.__enter__()
        warnings.simplefilter("ignore")

    def __exit__(self, *a):
        return self.c.__exit__(*a)


def adapter(path, engine):
    with _nowarn():
        model = load_urdf(path)
    with R._quiet():
        return model, A.load_engine(engine, model, path)


def kinds(res, link):
    return {c["kind"] for c in res.causes if c["link"] == link}


# ---- the quirks, engine by engine -------------------------------------------------------------------------------

@pytest.mark.parametrize("engine", ["pinocchio", "drake"])
def test_no_inertial_is_zero_mass_in_pinocchio_and_drake(engine):
    need(engine)
    _, res = run(QUIRKS / "no_inertial.urdf", engine)
    assert res.status == "ok" and res.causes == []
    assert res.worst <= RAW                       # measured 1.8e-15


def test_no_inertial_pybullet_gives_one_kilogram_and_unit_inertia():
    need("pybullet")
    _, ad = adapter(QUIRKS / "no_inertial.urdf", "pybullet")
    m, c, I = ad.links["link1"]
    assert m == 1.0 and np.array_equal(I, np.eye(3)) and np.array_equal(c, np.zeros(3))   # its documented default
    _, res = run(QUIRKS / "no_inertial.urdf", "pybullet")
    assert res.worst > 0.1                        # measured τ 6.8: a whole kilogram more
    assert kinds(res, "link1") == {"no <inertial>"}
    assert res.explained and res.worst_neutral <= NEUTRAL    # measured 9.7e-16


@pytest.mark.parametrize("quirk, message", [("no_inertial", "mjMINVAL"), ("zero_mass_inertia", "mjMINVAL"),
                                            ("triangle", "A + B >= C")])
def test_mujoco_refuses_massless_moving_bodies_and_triangle_violations(quirk, message):
    # with balanceinertia off (as the referee sets it) MuJoCo refuses rather than altering the inertia
    need("mujoco")
    _, res = run(QUIRKS / f"{quirk}.urdf", "mujoco")
    assert res.status == "refused" and message in res.reason and "link1" in res.reason


def test_zero_mass_with_inertia_drake_substitutes_a_unit_mass():
    need("drake")
    _, ad = adapter(QUIRKS / "zero_mass_inertia.urdf", "drake")
    m, _, I = ad.links["link1"]
    # measured: 1 kg (to 2e-16) and an isotropic inertia, after Drake's own warning
    assert abs(m - 1.0) < 1e-12 and np.allclose(I, I[0, 0] * np.eye(3), rtol=0, atol=1e-15)
    assert any("mass > 0" in n for n in ad.notes)
    _, res = run(QUIRKS / "zero_mass_inertia.urdf", "drake")
    assert res.worst > 1e-3                       # measured 6.0e-2
    assert kinds(res, "link1") == {"zero mass with inertia"}
    assert res.explained and res.worst_neutral <= NEUTRAL     # measured 1.2e-15


@pytest.mark.parametrize("engine", ["pinocchio", "pybullet"])
def test_zero_mass_with_inertia_kept_by_pinocchio_and_pybullet(engine):
    need(engine)
    _, ad = adapter(QUIRKS / "zero_mass_inertia.urdf", engine)
    _, res = run(QUIRKS / "zero_mass_inertia.urdf", engine)
    assert res.causes == [] and res.worst <= (RAW_PB if engine == "pybullet" else RAW)   # 2.5e-14, 1.1e-15


def test_triangle_violation_pybullet_zeroes_drake_replaces():
    need("pybullet")
    need("drake")
    path = QUIRKS / "triangle.urdf"
    _, pb = adapter(path, "pybullet")
    _, dk = adapter(path, "drake")
    assert pb.links["link1"][0] == 2.0 and np.array_equal(pb.links["link1"][2], np.zeros((3, 3)))
    I = dk.links["link1"][2]            # mass read back as 2 - 9e-16 (Drake stores a unit inertia times m)
    assert any("triangle inequality" in n for n in dk.notes)
    assert abs(dk.links["link1"][0] - 2.0) < 1e-12 and np.allclose(I, I[0, 0] * np.eye(3), rtol=0, atol=1e-15)
    assert not np.allclose(I, np.diag([0.002, 0.003, 0.02]))
    for engine in ("pybullet", "drake"):
        _, res = run(path, engine)
        assert res.worst > 1e-3                   # measured 1.4e-1 (pybullet), 1.0e-1 (drake)
        assert kinds(res, "link1") == {"triangle inequality"}
        assert res.explained and res.worst_neutral <= NEUTRAL      # measured 3.6e-15, 1.2e-15


def test_triangle_violation_pinocchio_keeps_it():
    need("pinocchio")
    _, res = run(QUIRKS / "triangle.urdf", "pinocchio")
    assert res.causes == [] and res.worst <= RAW


@pytest.mark.parametrize("engine", A.ENGINES)
@pytest.mark.parametrize("quirk, link", [("rotated_inertial", "link1"), ("fixed_child", "tool")])
def test_rotated_inertial_frame_every_engine_rotates_it(engine, quirk, link):
    # fixed_child: a massive tool on a rotated fixed joint with a rotated inertial frame, which we merge into
    # link2's body and the engines keep as a link of its own (MuJoCo with fusestatic off)
    need(engine)
    path = QUIRKS / f"{quirk}.urdf"
    _, ad = adapter(path, engine)
    _, res = run(path, engine)
    assert [c for c in res.causes if c["kind"] != "precision"] == []
    assert res.worst <= (RAW_PB if engine == "pybullet" else RAW)     # measured 2.1e-14 / 2.5e-15
    assert res.worst_neutral <= NEUTRAL                                # measured 2.4e-15
    if engine != "pinocchio":            # the link's inertia in its frame is the file's R I Rᵀ, not the raw I
        f = urdf_inertials(path)[link]
        assert np.max(np.abs(ad.links[link][2] - f.inertia)) < 1e-10 < np.max(np.abs(f.raw - f.inertia))


@pytest.mark.parametrize("engine", ["mujoco", "drake"])
def test_damping_from_dynamics_agrees_with_mujoco_and_drake(engine):
    """<dynamics damping> is ours too (model.damping): the comparison includes it where the engine applies it, and
    agrees; a model without it (joint_dynamics= zero) differs in τ and q̈, and the cause is named."""
    need(engine)
    _, ad = adapter(QUIRKS / "damping.urdf", engine)
    assert ad.damping.tolist() == [0.3, 0.3]
    model, res = run(QUIRKS / "damping.urdf", engine)
    assert model.damping.tolist() == [0.3, 0.3]
    assert res.causes == [] and res.worst <= RAW               # measured ≤ 2.0e-15
    with _nowarn():
        bare = load_urdf(QUIRKS / "damping.urdf", joint_dynamics={j: dict(damping=0.0) for j in ("j1", "j2")})
    res = R.referee(bare, QUIRKS / "damping.urdf", [engine], n_states=N, seed=3).engines[0]
    assert res.err["tau"] > 1e-2 and res.err["M"] <= RAW      # damping: τ and q̈ differ, M does not
    assert kinds(res, "j1") == kinds(res, "j2") == {"damping"}
    assert res.explained and res.worst_neutral <= NEUTRAL     # measured 2.0e-15


def test_damping_is_not_in_pybullets_queries():
    need("pybullet")
    _, res = run(QUIRKS / "damping.urdf", "pybullet")
    assert res.causes == [] and res.worst <= RAW_PB           # measured 1.8e-14
    assert any("acts only when stepping" in n for n in res.notes)


def test_armature_drake_reflected_rotor_inertia():
    # <drake:rotor_inertia> 0.002 with <drake:gear_ratio> 10 on j1's transmission: Drake adds ρ = I_r n² = 0.2
    # to M's diagonal; the other engines ignore the drake: tags (no engine adds armature by default)
    need("drake")
    path = QUIRKS / "armature.urdf"
    _, ad = adapter(path, "drake")
    assert np.allclose(ad.armature, [0.2, 0.0], rtol=0, atol=1e-15)
    _, res = run(path, "drake")
    assert res.err["M"] > 0.1                     # measured 0.2: the armature itself
    assert [(c["kind"], c["link"]) for c in res.causes] == [("armature", "j1")]
    assert res.explained and res.worst_neutral <= NEUTRAL     # measured 4.7e-16
    with _nowarn():                                 # the same armature ours (model.armature): agreement as it is
        model = load_urdf(path, joint_dynamics={"j1": dict(armature=0.2)})
    res = R.referee(model, path, ["drake"], n_states=N, seed=3).engines[0]
    assert res.causes == [] and res.worst <= RAW               # measured ≤ 1e-15


@pytest.mark.parametrize("engine", ["pinocchio", "mujoco", "pybullet"])
def test_armature_tags_of_drake_ignored_by_the_others(engine):
    need(engine)
    _, res = run(QUIRKS / "armature.urdf", engine)
    assert res.causes == [] and res.worst <= (RAW_PB if engine == "pybullet" else RAW)   # measured ≤ 1.8e-14


def test_pybullet_precision_named_on_products_of_inertia():
    need("pybullet")
    _, ad = adapter(QUIRKS / "products_of_inertia.urdf", "pybullet")
    f = urdf_inertials(QUIRKS / "products_of_inertia.urdf")["link1"]
    rel = np.max(np.abs(ad.links["link1"][2] - f.inertia)) / np.max(np.abs(f.inertia))
    assert 1e-10 < rel < 1e-7                     # measured 3.3e-9: its diagonalisation's tolerance
    _, res = run(QUIRKS / "products_of_inertia.urdf", "pybullet")
    assert kinds(res, "link1") == {"precision"}
    assert res.worst <= RAW_PB and res.worst_neutral <= NEUTRAL   # measured 2.4e-13, 1.5e-15


def test_neutralising_is_not_a_tautology():
    # the neutralised model really carries the engine's numbers: rebuilt from PyBullet's read-back on the
    # no-inertial file, link1's body gains PyBullet's 1 kg; from Pinocchio's, it keeps the file's 0 kg
    need("pybullet")
    model, pb = adapter(QUIRKS / "no_inertial.urdf", "pybullet")
    i = model.body_names.index("link1")
    assert model.mass[i] == 0.0 and neutralised(model, pb).mass[i] == 1.0


# ---- real robots ----------------------------------------------------------------------------------------------

def zoo(rel):
    from manipdyn.validation.zoo import robots_dir
    return robots_dir() / rel


@pytest.mark.parametrize("engine", A.ENGINES)
def test_aau_arm(engine):
    need(engine)
    _, res = run(AAU, engine)
    if engine == "pybullet":             # the tool link has no <inertial>
        assert kinds(res, "tool") == {"no <inertial>"} and res.worst > 0.1
        assert res.worst_neutral <= NEUTRAL                    # measured 1.1e-15
    else:
        assert res.causes == [] and res.worst <= RAW          # measured ≤ 2.3e-15


@pytest.mark.parametrize("engine", A.ENGINES)
def test_ur5_every_engine_agrees(engine):
    need(engine)
    _, res = run(zoo("ur_description/urdf/ur5_robot.urdf"), engine)
    assert res.causes == [] and res.worst <= RAW               # measured ≤ 4.2e-15


@pytest.mark.parametrize("engine", ["mujoco", "pybullet", "drake"])
def test_xarm7_causes(engine):
    need(engine)
    _, res = run(zoo("xarm_description/urdf/xarm7.urdf"), engine)
    if engine == "pybullet":
        assert res.worst > 1.0 and res.explained and res.worst_neutral <= NEUTRAL   # measured 4.3; ≤ 1.8e-15
        assert kinds(res, "link_eef") == {"no <inertial>"}
    else:                                   # its <dynamics damping> on 7 joints: ours as theirs (it was 5.5 off)
        assert res.causes == [] and res.worst <= RAW                                # measured ≤ 4e-15


@pytest.mark.parametrize("engine", ["mujoco", "drake"])
def test_double_pendulum_damping(engine):
    need(engine)
    _, res = run(zoo("double_pendulum_description/urdf/double_pendulum.urdf"), engine)
    assert res.causes == [] and res.worst <= RAW              # its damping is ours too: measured ≤ 4.2e-16


# ---- the command line -----------------------------------------------------------------------------------------

def test_cli_against_table_and_json(tmp_path, capsys):
    need("pybullet")
    from manipdyn.cli import main
    out = tmp_path / "r.json"
    code = main(["validate", str(QUIRKS / "no_inertial.urdf"), "--against", "pinocchio,pybullet", "--states", "5",
                 "--json", str(out)])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "pybullet" in text and "no <inertial>: link 'link1'" in text
    rep = json.loads(out.read_text())[0]
    pb = {e["engine"]: e for e in rep["engines"]}["pybullet"]
    assert pb["explained"] and pb["causes"][0]["link"] == "link1" and pb["err"]["tau"] > 0.1


def test_cli_unknown_engine_is_one_line_exit_2(capsys):
    from manipdyn.cli import main
    assert main(["validate", str(AAU), "--against", "pinocchio,bullet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown engine 'bullet'" in err[0] and err[0].startswith("manipdyn validate: error:")


def test_cli_missing_engine_is_skipped_with_a_note(monkeypatch, capsys):
    from manipdyn.cli import main
    real = A.available
    monkeypatch.setattr(A, "available", lambda name: False if name == "drake" else real(name))
    assert main(["validate", str(AAU), "--against", "pinocchio,drake", "--states", "3"]) == 0
    out = capsys.readouterr().out
    assert "drake      missing  drake is not installed (pip install drake" in out


def test_engines_are_not_imported_by_the_referee_module():
    # importing the referee loads no engine; the adapters import them on use
    import subprocess
    import sys
    code = ("import sys, manipdyn.validation.referee, manipdyn.validation.referee_zoo; "
            "print(sorted(m for m in ('mujoco', 'pybullet', 'pydrake') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                         env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "[]", out.stderr
