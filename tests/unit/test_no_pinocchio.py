"""The hand-written modules run with Pinocchio blocked, and `import manipdyn` does not load it."""
import subprocess
import sys

from conftest import AAU

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
print("ok")
"""


def test_core_runs_without_pinocchio():
    out = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().endswith("ok")


def test_import_does_not_load_pinocchio():
    code = "import sys, manipdyn; print('pinocchio' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True).stdout.strip() == "False"
