"""Every bundled model plays to one HTML file through the CLI, and a closed chain's demo closes its loops."""
import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import ROOT

import manipdyn as md
from manipdyn import viz

MODELS = sorted((ROOT / "urdf").glob("*.urdf"))


@pytest.mark.parametrize("path", MODELS, ids=[p.stem for p in MODELS])
def test_bundled_model_plays_to_html(path, tmp_path):
    out = tmp_path / f"{path.stem}.html"
    r = subprocess.run([sys.executable, "-m", "manipdyn.cli", "play", str(path), "--html", str(out)],
                       env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    assert out.stat().st_size > 100_000 and "frames at" in r.stdout     # meshcat's viewer alone is 850 kB


@pytest.mark.parametrize("path", [p for p in MODELS if md.load_urdf(p).constraints],
                         ids=lambda p: p.stem)
def test_closed_chain_demo_closes_its_loops(path):
    model = md.load_urdf(path)
    t, Q = viz.demo(model, path)
    sc = viz.scene_for(model, path, t, Q)
    gap = max(float(np.max(g)) for g in sc.gaps)
    # fourbar: frames fall on the assembled samples (|Φ| ≤ 1e-12): measured 9.0e-13 m. spm: frames are
    # linear interpolations between assembled samples, O(Δq²): measured 3.4e-7 m
    tol = {"fourbar": 1e-10, "spm": 3e-5}.get(path.stem, 1e-6)
    assert gap < tol, f"{path.stem}: closure gap {gap:.3g} m"
    assert not np.isnan(Q).any()
