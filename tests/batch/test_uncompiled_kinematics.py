"""The compiled kinematics (dynamics/kinematics.py: frame_kernel, com_jacobians_kernel) and closure rows
(constraints/closures.py: closure_kernel) against the same source run uncompiled (MANIPDYN_NOJIT=1, in a
fresh interpreter): what numba compiles is what the text says. The numbers themselves are held to
Pinocchio elsewhere (tests/crosscheck/test_free_flyer_kinematics.py, test_spatial_loops.py,
tests/batch/test_kernels_vs_readable.py); this catches a difference between the compiled code and its
reading (an aliasing or typing surprise), on a fixed-base spatial loop and a floating one.
"""
import json
import os
import subprocess
import sys

import numpy as np
from conftest import ROOT, assert_close

PROBE = f"""
import json, sys, numpy as np, manipdyn as md
from manipdyn.constraints import closure_terms
from free_flyer import random_floating_states, with_free_flyer
spm = md.load_urdf({str(ROOT / "urdf" / "spm.urdf")!r})
loop = md.load_urdf({str(ROOT / "tests" / "data" / "loops" / "two_loops.urdf")!r})
ff = with_free_flyer(loop, 2.0, np.array([0.1, 0.0, -0.2]), np.diag([0.3, 0.2, 0.1]))
rng = np.random.default_rng(3)
out = {{}}
for name, m in (("spm", spm), ("ff", ff)):
    if m.floating:
        Q, V = random_floating_states(m, 3, rng)
    else:
        Q, V = rng.uniform(-3, 3, (3, m.nq)), rng.normal(0, 2, (3, m.nv))
    frame = m.body_names[-1]
    for ref in ("local_world_aligned", "local"):
        out[name + "J" + ref] = md.frame_jacobian(m, Q, frame, ref)
        out[name + "dJ" + ref] = md.frame_jacobian_dot(m, Q, V, frame, ref)
    out[name + "R"], out[name + "p"] = md.frame_placement(m, Q, frame)
    out[name + "phi"], out[name + "jac"], out[name + "bias"] = closure_terms(m, Q, V)
    out[name + "M"] = md.mass_matrix(m, Q, method="lagrange")
    out[name + "C"], out[name + "g"] = md.coriolis_matrix(m, Q, V), md.gravity_torques(m, Q)
import manipdyn._jit as j
print(json.dumps(dict(nojit=j.NOJIT, **{{k: np.asarray(x).tolist() for k, x in out.items()}})))
"""


def _run(**env_extra):
    env = {k: x for k, x in os.environ.items() if not k.startswith(("NUMBA_", "MANIPDYN_"))}
    env.update(PYTHONPATH=os.pathsep.join([str(ROOT), str(ROOT / "tests")]), **env_extra)
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, cwd=ROOT, capture_output=True, text=True,
                         timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.splitlines()[-1])


def test_compiled_kinematics_equal_uncompiled():
    compiled, plain = _run(), _run(MANIPDYN_NOJIT="1")
    assert not compiled.pop("nojit") and plain.pop("nojit")
    assert compiled.keys() == plain.keys() and len(compiled) == 24
    for k in compiled:
        x, y = np.array(compiled[k]), np.array(plain[k])
        assert x.size and np.all(np.isfinite(x)), k
        assert_close(x, y, 1e-13, k)      # measured 0 on every array (the same operations in the same order)
