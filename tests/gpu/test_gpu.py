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
from conftest import AAU, ROOT, assert_close

import manipdyn as md
from manipdyn.validation import random_states

pytest.importorskip("numba.cuda", reason="the [gpu] extra (numba-cuda) is not installed")

PROBE = r"""
import json, sys, warnings
import numpy as np
sys.path.insert(0, {tests!r}); sys.path.insert(0, {batch!r})
import manipdyn as md
from manipdyn import _jit, gpu
from numba import cuda
from manipdyn.validation import random_states
from test_lanes import _tree
warnings.simplefilter("ignore")
out = dict(nojit=_jit.NOJIT, sim=cuda.simulator_enabled if hasattr(cuda, "simulator_enabled") else None)
for name, model in (("aau_arm", md.load_urdf({aau!r})), ("tree", md.load_urdf_string(_tree()))):
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
fails("free_flyer", lambda: gpu.rnea(md.load_urdf({aau!r}, root_joint="free_flyer"), np.zeros((2, 12)),
                                     np.zeros((2, 11)), np.zeros((2, 11))))
out["errors"] = errors
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def probe():
    env = {k: x for k, x in os.environ.items() if not k.startswith("MANIPDYN_")}
    env.update(PYTHONPATH=str(ROOT), MANIPDYN_NOJIT="1", NUMBA_ENABLE_CUDASIM="1")
    code = PROBE.format(tests=str(ROOT / "tests"), batch=str(ROOT / "tests" / "batch"), aau=str(AAU))
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
    model = md.load_urdf(AAU) if name == "aau_arm" else md.load_urdf_string(_tree())
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


@pytest.mark.parametrize("key, kind, words", [
    ("nan_q", "InputError", ["rnea on the GPU, row 5", "q[2]", "nan"]),
    ("huge_angle", "InputError", ["q[6, 0]", "300000", "modulo 2π"]),
    ("overflow", "NumericalError", ["aba on the GPU, row 4"]),
    ("shape", "InputError", ["q must be (N, 5)", "(9, 3)"]),
    ("frame_name", "InputError", ["no_such_link"]),
    ("frame_nan", "InputError", ["frame_jacobian on the GPU, row 5", "nan"]),
    ("rows", "InputError", ["v has 4 rows, q has 9"]),
    ("float32", "InputError", ["float64", "float32"]),
    ("free_flyer", "InputError", ["one velocity each", "root_joint"])])
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
