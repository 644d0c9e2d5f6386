"""The GPU path (manipdyn.gpu): the lane kernels' steps driven one thread per state, against the CPU kernels,
call by call. Here there is no GPU: the drivers run on numba's CUDA simulator (NUMBA_ENABLE_CUDASIM=1) in a
subprocess where the kernels run as Python (MANIPDYN_NOJIT=1: the simulator hands its arrays to Python code, not
to compiled functions), and the same drivers are compiled to PTX for an H100 (sm_90) where NVVM is installed —
the check that the source the simulator ran compiles for CUDA as it is. scripts/gpu_bench.py times them on a GPU."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import AAU, ROOT, assert_close, err

import manipdyn as md
from manipdyn.validation import random_states

pytest.importorskip("numba.cuda", reason="the [gpu] extra (numba-cuda) is not installed")

PROBE = r"""
import json, sys, warnings
import numpy as np
sys.path.insert(0, {tests!r}); sys.path.insert(0, {batch!r}); sys.path.insert(0, {gpu!r})
import manipdyn as md
from manipdyn import _jit, gpu
from numba import cuda
from manipdyn.validation import random_states
from test_lanes import _tree
warnings.simplefilter("ignore")
from test_gpu import ball_model, floating_model, multi_wrenches, screw_model, tree_model, wrenches
out = dict(nojit=_jit.NOJIT, sim=cuda.simulator_enabled if hasattr(cuda, "simulator_enabled") else None)
for name, model in (("aau_arm", md.load_urdf({aau!r})), ("tree", tree_model(_tree))):
    for N in (1, 7, 40):
        Q, V, A = random_states(model, N, np.random.default_rng(N))
        dq = cuda.to_device(Q)                      # a device array in, as a user's would be
        tip, mid = model.body_names[-1], model.body_names[len(model.body_names) // 2]
        R, p = gpu.frame_placement(model, dq, tip)
        out[f"{{name}}/{{N}}"] = dict(
            frame_R=R.copy_to_host().tolist(), frame_p=p.copy_to_host().tolist(),
            frame_J=gpu.frame_jacobian(model, Q, tip).copy_to_host().tolist(),
            frame_J_local=gpu.frame_jacobian(model, Q, mid, reference="local").copy_to_host().tolist(),
            rnea=gpu.rnea(model, dq, V, A).copy_to_host().tolist(),
            nonlinear_effects=gpu.nonlinear_effects(model, Q, V).copy_to_host().tolist(),
            gravity_torques=gpu.gravity_torques(model, Q).copy_to_host().tolist(),
            mass_matrix=gpu.mass_matrix(model, dq).copy_to_host().tolist(),
            aba=gpu.aba(model, Q, V, A).copy_to_host().tolist())
        fx = wrenches(model, N)
        fx_gpu = {{k: (cuda.to_device(f) if k == tip else f, m) for k, (f, m) in fx.items()}}   # a device force too
        for frame in ("local", "world"):
            out[f"{{name}}/{{N}}"]["rnea_f_ext_" + frame] = gpu.rnea(model, dq, V, A, f_ext=fx_gpu,
                                                                    f_ext_frame=frame).copy_to_host().tolist()
for name in ("screw_chain", "screw_floating", "planar_root", "planar_chain"):
    model = screw_model(name)
    Q = random_states(model, 7, np.random.default_rng(7))[0]
    tip = model.body_names[-1]
    R, p = gpu.frame_placement(model, Q, tip)
    out[name + "_frames"] = dict(frame_R=R.copy_to_host().tolist(), frame_p=p.copy_to_host().tolist(),
                                 frame_J=gpu.frame_jacobian(model, Q, tip).copy_to_host().tolist(),
                                 frame_J_local=gpu.frame_jacobian(model, Q, tip, reference="local").copy_to_host().tolist())
for name, model in (("floating", floating_model()), ("ball", ball_model()), ("screw_chain", screw_model("screw_chain")),
                    ("screw_floating", screw_model("screw_floating")), ("planar_root", screw_model("planar_root")),
                    ("planar_chain", screw_model("planar_chain"))):
    for N in (1, 7):
        Q, V, A = random_states(model, N, np.random.default_rng(N))
        dq = cuda.to_device(Q)
        out[f"{{name}}/{{N}}"] = dict(
            rnea=gpu.rnea(model, dq, V, A).copy_to_host().tolist(),
            rnea_f_ext_world=gpu.rnea(model, dq, V, A, f_ext=multi_wrenches(model, N),
                                      f_ext_frame="world").copy_to_host().tolist(),
            nonlinear_effects=gpu.nonlinear_effects(model, Q, V).copy_to_host().tolist(),
            gravity_torques=gpu.gravity_torques(model, Q).copy_to_host().tolist(),
            mass_matrix=gpu.mass_matrix(model, dq).copy_to_host().tolist(),
            aba=gpu.aba(model, Q, V, A).copy_to_host().tolist())
model = md.load_urdf({aau!r})
Q, V, A = random_states(model, 9, np.random.default_rng(3))
errors = {{}}
def fails(key, f):
    try:
        f()
        errors[key] = None
    except Exception as exc:
        errors[key] = [type(exc).__name__, str(exc)]
bad = Q.copy(); bad[5, 2] = np.nan
fails("nan_q", lambda: gpu.rnea(model, bad, V, A))
big = Q.copy(); big[6, 0] = 3e5
fails("huge_angle", lambda: gpu.mass_matrix(model, big))
hot = V.copy(); hot[4] = 1e200
fails("overflow", lambda: gpu.aba(model, Q, hot, A))
fails("shape", lambda: gpu.rnea(model, Q[:, :3], V, A))
fails("frame_name", lambda: gpu.frame_placement(model, Q, "no_such_link"))
fails("frame_nan", lambda: gpu.frame_jacobian(model, bad, model.body_names[-1]))
fails("rows", lambda: gpu.aba(model, Q, V[:4], A))
fails("float32", lambda: gpu.rnea(model, cuda.to_device(Q.astype(np.float32)), V, A))
fx = wrenches(model, 9)
f = fx[model.body_names[-1]][0].copy(); f[3, 1] = np.nan
fails("f_ext_nan", lambda: gpu.rnea(model, Q, V, A, f_ext={{model.body_names[-1]: (cuda.to_device(f), np.zeros(3))}}))
fails("f_ext_name", lambda: gpu.rnea(model, Q, V, A, f_ext={{"no_such_frame": (np.zeros(3), np.zeros(3))}}))
fails("f_ext_rows", lambda: gpu.rnea(model, Q, V, A, f_ext={{model.body_names[-1]: (cuda.to_device(f[:4]),
                                                                                    np.zeros(3))}}))
out["errors"] = errors
print(json.dumps(out))
"""


def tree_model(_tree):
    """The test tree with a turned, offset tool frame and armature on every joint (so that the GPU's CRBA, RNEA and
    ABA steps read it: M + diag(armature), τ += armature ⊙ q̈, D_i + armature_i)."""
    import dataclasses
    model = md.load_urdf_string(_tree(tool=True))
    return dataclasses.replace(model, armature=np.linspace(0.1, 0.9, model.nv))


def floating_model():
    """The AAU arm on a free-flyer root, armature on every velocity (the free flyer's six too)."""
    import dataclasses
    model = md.load_urdf(AAU, root_joint="free_flyer")
    return dataclasses.replace(model, armature=np.linspace(0.1, 0.9, model.nv))


def ball_model():
    """A random MJCF tree of ball and hinge joints (tests/ball_models.py): balls at the root and mid-chain, armature
    on every velocity."""
    import dataclasses
    import warnings

    from ball_models import random_tree
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = md.load_mjcf_string(random_tree(3, "BHBB"))
    return dataclasses.replace(model, armature=np.linspace(0.05, 0.5, model.nv))


def screw_model(name):
    """A seeded tree of tests/joint_kinds.py with helical joints (and, "screw_floating", a free flyer and a ball)."""
    import warnings

    from joint_kinds import kinds_robot
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return md.load_urdf_string(kinds_robot(name, 0)[0])


def multi_wrenches(model, N):
    """f_ext on the tip and a mid body of a floating or ball-jointed model, seeded rows."""
    rng = np.random.default_rng(200 + N)
    tip, mid = model.body_names[-1], model.body_names[len(model.body_names) // 2]
    return {tip: (rng.normal(0, 10, (N, 3)), rng.normal(0, 2, (N, 3))), mid: (rng.normal(0, 10, (N, 3)),
                                                                             rng.normal(0, 2, (N, 3)))}


def wrenches(model, N):
    """f_ext for the probe: on the tip body, a mid body (a (3,) moment, the same for every state), the "tool" frame
    (offset from its body and turned: R and p × f count) and a frame of the fixed base (dropped: it changes no
    torque); rows from a seeded generator, so the probe and the test agree."""
    rng = np.random.default_rng(100 + N)
    tip, mid = model.body_names[-1], model.body_names[len(model.body_names) // 2]
    assert np.abs(model.frames["tool"].R - np.eye(3)).max() > 0.5 and np.abs(model.frames["tool"].p).max() > 0.05
    return {tip: (rng.normal(0, 10, (N, 3)), rng.normal(0, 2, (N, 3))), mid: (rng.normal(0, 10, (N, 3)),
                                                                             rng.normal(0, 2, 3)),
            "tool": (rng.normal(0, 10, (N, 3)), rng.normal(0, 2, (N, 3))),
            model.root_link: (rng.normal(0, 10, (N, 3)), rng.normal(0, 2, (N, 3)))}


@pytest.fixture(scope="module")
def probe():
    env = {k: x for k, x in os.environ.items() if not k.startswith("MANIPDYN_")}
    env.update(PYTHONPATH=str(ROOT), MANIPDYN_NOJIT="1", NUMBA_ENABLE_CUDASIM="1")
    code = PROBE.format(tests=str(ROOT / "tests"), batch=str(ROOT / "tests" / "batch"),
                        gpu=str(ROOT / "tests" / "gpu"), aau=str(AAU))
    run = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True, text=True,
                         timeout=900, check=False)
    assert run.returncode == 0, run.stderr[-3000:]
    return json.loads(run.stdout.splitlines()[-1])


def test_the_probe_ran_the_simulator_uncompiled(probe):
    assert probe["nojit"] and probe["sim"] in (True, None)


@pytest.mark.parametrize("name", ["aau_arm", "tree"])
@pytest.mark.parametrize("N", [1, 7, 40])
def test_gpu_calls_match_the_cpu_kernels(probe, name, N):
    sys.path.insert(0, str(ROOT / "tests" / "batch"))
    from test_lanes import _tree
    model = md.load_urdf(AAU) if name == "aau_arm" else tree_model(_tree)
    assert name == "aau_arm" or model.armature.all()
    Q, V, A = random_states(model, N, np.random.default_rng(N))
    got = {k: np.array(x) for k, x in probe[f"{name}/{N}"].items()}
    assert_close(got["rnea"], md.rnea(model, Q, V, A), 1e-14, "rnea")                        # measured ≤ 2e-16
    assert_close(got["nonlinear_effects"], md.nonlinear_effects(model, Q, V), 1e-14, "h")
    assert_close(got["gravity_torques"], md.gravity_torques(model, Q), 1e-14, "g")
    assert_close(got["mass_matrix"], md.mass_matrix(model, Q), 1e-14, "M")
    cond = np.linalg.cond(md.mass_matrix(model, Q)).max()
    assert_close(got["aba"], md.aba(model, Q, V, A), 1e-14 * cond, "q̈")
    tip, mid = model.body_names[-1], model.body_names[len(model.body_names) // 2]
    R, p = md.frame_placement(model, Q, tip)
    assert_close(got["frame_R"], R, 1e-14, "R")
    assert_close(got["frame_p"], p, 1e-14, "p")
    assert_close(got["frame_J"], md.frame_jacobian(model, Q, tip), 1e-14, "J")
    assert_close(got["frame_J_local"], md.frame_jacobian(model, Q, mid, reference="local"), 1e-14, "J local")
    for frame in ("local", "world"):
        tau = md.rnea(model, Q, V, A, f_ext=wrenches(model, N), f_ext_frame=frame)
        assert_close(got["rnea_f_ext_" + frame], tau, 1e-14, f"rnea f_ext {frame}")      # measured ≤ 9.4e-16
        assert err(got["rnea_f_ext_" + frame], got["rnea"]) > 1e-3                       # the wrenches count


@pytest.mark.parametrize("name", ["floating", "ball", "screw_chain", "screw_floating", "planar_root", "planar_chain"])
@pytest.mark.parametrize("N", [1, 7])
def test_gpu_takes_free_flyers_ball_helical_and_planar_joints(probe, name, N):
    """The multi-dof lane steps (lanes.quat_placement_lane, rnea.motion_lane_multi and torque_multi_lane, crba's
    columns of a multi-dof joint, aba.articulated_multi, handed_multi, acceleration_multi) and a helical joint's
    (lanes.slide_lane) and a planar joint's (lanes.planar_placement_lane, the masks of lanes.multi_rates, aba.selected)
    driven one thread per state give the CPU's numbers (whose lanes are held to Pinocchio:
    tests/batch/test_lanes_multi_dof.py, tests/crosscheck/test_joint_kinds.py)."""
    model = {"floating": floating_model, "ball": ball_model}.get(name, lambda: screw_model(name))()
    assert (model.kind == md.HELICAL).sum() >= 2 if name.startswith("screw") else (model.kind == md.PLANAR).sum() == 2 \
        if name.startswith("planar") else model.nq > model.nv and model.armature.all()
    Q, V, A = random_states(model, N, np.random.default_rng(N))
    got = {k: np.array(x) for k, x in probe[f"{name}/{N}"].items()}
    assert_close(got["rnea"], md.rnea(model, Q, V, A), 1e-14, "rnea")                        # measured ≤ 4.4e-16
    tau = md.rnea(model, Q, V, A, f_ext=multi_wrenches(model, N), f_ext_frame="world")
    assert_close(got["rnea_f_ext_world"], tau, 1e-14, "rnea f_ext")
    assert err(got["rnea_f_ext_world"], got["rnea"]) > 1e-3
    assert_close(got["nonlinear_effects"], md.nonlinear_effects(model, Q, V), 1e-14, "h")
    assert_close(got["gravity_torques"], md.gravity_torques(model, Q), 1e-14, "g")
    assert_close(got["mass_matrix"], md.mass_matrix(model, Q), 1e-14, "M")
    cond = np.linalg.cond(md.mass_matrix(model, Q)).max()
    assert_close(got["aba"], md.aba(model, Q, V, A), 1e-14 * cond, "q̈")


@pytest.mark.parametrize("name", ["screw_chain", "screw_floating", "planar_root", "planar_chain"])
def test_gpu_frames_take_every_joint_kind(probe, name):
    """The frame drivers (lanes.body_placement_lane: a helical joint's turn and slide, a free flyer's or ball's
    quaternion; a Jacobian column per velocity) give the CPU's placement and Jacobian."""
    model = screw_model(name)
    Q = random_states(model, 7, np.random.default_rng(7))[0]
    got, tip = {k: np.array(x) for k, x in probe[name + "_frames"].items()}, model.body_names[-1]
    R, p = md.frame_placement(model, Q, tip)
    assert_close(got["frame_R"], R, 1e-14, "R")
    assert_close(got["frame_p"], p, 1e-14, "p")
    assert_close(got["frame_J"], md.frame_jacobian(model, Q, tip), 1e-14, "J")
    assert_close(got["frame_J_local"], md.frame_jacobian(model, Q, tip, reference="local"), 1e-14, "J local")


@pytest.mark.parametrize("key, kind, words", [
    ("nan_q", "InputError", ["rnea on the GPU, row 5", "q[2]", "nan"]),
    ("huge_angle", "InputError", ["q[6, 0]", "300000", "modulo 2π"]),
    ("overflow", "NumericalError", ["aba on the GPU, row 4"]),
    ("shape", "InputError", ["q must be (N, 5)", "(9, 3)"]),
    ("frame_name", "InputError", ["no_such_link"]),
    ("frame_nan", "InputError", ["frame_jacobian on the GPU, row 5", "nan"]),
    ("rows", "InputError", ["v has 4 rows, q has 9"]),
    ("float32", "InputError", ["float64", "float32"]),
    ("f_ext_nan", "InputError", ["rnea on the GPU, row 3", "f_ext", "force"]),
    ("f_ext_name", "InputError", ["no_such_frame"]),
    ("f_ext_rows", "InputError", ["force has 4 rows, q has 9"])])
def test_gpu_errors_name_the_row_and_the_entry(probe, key, kind, words):
    got = probe["errors"][key]
    assert got is not None and got[0] == kind, got
    for w in words:
        assert w in got[1], (w, got[1])


def _nvvm():
    try:
        from numba import cuda
        from numba import float64
        cuda.compile_ptx(lambda x: None, (float64[:],), device=False, cc=(9, 0))
        return True
    except Exception:   # noqa: BLE001 - no NVVM (or no CUDA bindings): the PTX check is skipped
        return False


@pytest.mark.skipif(os.environ.get("NUMBA_ENABLE_CUDASIM") == "1" or not _nvvm(),
                    reason="no NVVM here (pip install \"cuda-toolkit[nvvm,nvrtc]\") to compile PTX")
@pytest.mark.parametrize("name", ["rnea", "crba", "aba", "frame"])
def test_the_drivers_compile_for_an_h100(name):
    from manipdyn import gpu
    text = gpu.ptx(name, cc=(9, 0))
    assert ".target sm_90" in text and "fma.rn.f64" in text     # float64 code, fused as on the CPU
