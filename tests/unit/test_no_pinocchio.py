"""The hand-written modules run with Pinocchio blocked, and `import manipdyn` does not load it."""
import subprocess
import sys

from conftest import AAU, ROOT

SPM = ROOT / "urdf" / "spm.urdf"

CODE = f"""
import sys
sys.modules["pinocchio"] = None          # any import of it now raises ImportError
import numpy as np
import manipdyn
from manipdyn.cli import main
m = manipdyn.load_urdf({str(AAU)!r})
tau = manipdyn.rnea(m, np.zeros(m.nv), np.ones(m.nv), np.ones(m.nv), f_ext={{"tool": ([0, 0, -49.05], [0, 0, 0])}})
terms = manipdyn.rnea_terms(m, np.zeros((3, m.nv)), np.ones((3, m.nv)), np.ones((3, m.nv)))
assert np.all(np.isfinite(tau)) and terms["tau"].shape == (3, m.nv)
assert main(["inspect", {str(AAU)!r}]) == 0
q, v = np.full(m.nv, 0.3), np.full(m.nv, -0.2)
assert np.all(np.isfinite(manipdyn.aba(m, q, v, tau))) and manipdyn.mass_matrix(m, q, method="lagrange").shape == (5, 5)
assert np.all(np.isfinite(manipdyn.coriolis_matrix(m, q, v))) and np.all(np.isfinite(manipdyn.frame_jacobian_dot(m, q, v, "tool")))
assert manipdyn.simulate(m, q, v, (0, 0.01), dt=1e-3).q.shape == (11, 5)
spm = manipdyn.load_urdf({str(SPM)!r})
from manipdyn.examples import spm as chapter
from manipdyn.examples.spm_urdf import tree_guess
f = chapter.fig7(np.array([0.0, 0.1]))
qs, vs, a_s, _ = manipdyn.complete_state(spm, tree_guess(spm, chapter.platform_rotation(f.q[0, 3:]), f.q[0, :3]), f.qd[0, :3], f.qdd[0, :3])
assert np.all(np.isfinite(manipdyn.constrained_forward_dynamics(spm, qs, vs, np.zeros(7))[0]))
print("ok")
"""


def test_core_runs_without_pinocchio():
    out = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().endswith("ok")


def test_import_does_not_load_pinocchio_or_meshcat():
    code = "import sys, manipdyn; print('pinocchio' in sys.modules, 'meshcat' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True).stdout.strip()
    assert out == "False False"
