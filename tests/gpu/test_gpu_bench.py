"""scripts/gpu_bench.py runs end to end (on numba's CUDA simulator, tiny N: not a timing) and refuses without a GPU."""
import os
import subprocess
import sys

import pytest
from conftest import ROOT

pytest.importorskip("numba.cuda", reason="the [gpu] extra (numba-cuda) is not installed")
SCRIPT = ROOT / "scripts" / "gpu_bench.py"


def _run(args, **env):
    e = {k: x for k, x in os.environ.items() if not k.startswith(("MANIPDYN_", "NUMBA_ENABLE_CUDASIM"))}
    e.update(PYTHONPATH=str(ROOT), **env)
    return subprocess.run([sys.executable, str(SCRIPT), *args], env=e, cwd=ROOT, capture_output=True, text=True,
                          timeout=900, check=False)


def test_gpu_bench_writes_its_table_on_the_simulator(tmp_path):
    r = _run(["--n", "16", "--repeat", "1", "--out", str(tmp_path)], MANIPDYN_NOJIT="1", NUMBA_ENABLE_CUDASIM="1")
    assert r.returncode == 0, r.stderr[-2000:]
    text = (tmp_path / "gpu.md").read_text()
    assert "simulator" in text and text.count("| ur5 |") == 3 and text.count("| aau_arm |") == 3


def test_gpu_bench_refuses_bad_usage_and_no_gpu(tmp_path):
    assert _run(["--n", "0", "--out", str(tmp_path)]).returncode == 2
    from numba import cuda
    if not cuda.is_available():
        r = _run(["--n", "8", "--out", str(tmp_path)])
        assert r.returncode == 2 and "no CUDA GPU" in r.stderr and not (tmp_path / "gpu.md").exists()
