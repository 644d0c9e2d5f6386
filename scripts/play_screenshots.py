"""Regenerate docs/play_aau.png, docs/play_spm.png, docs/play_fourbar.png: each bundled model's demo page
(as `manipdyn play urdf/<model>.urdf --html`) opened paused at a moment of its motion in headless Chromium,
driven through chromedriver (tests/browser.py), as the tests see it.

    python scripts/play_screenshots.py
"""
from __future__ import annotations

import sys
import tempfile
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
SHOTS = {"aau_arm": ("play_aau.png", 0.3), "spm": ("play_spm.png", 0.5), "fourbar": ("play_fourbar.png", 0.25)}
WINDOW = (1100, 720)

def main():
    from browser import Browser
    from PIL import Image

    import manipdyn as md
    from manipdyn import viz
    with tempfile.TemporaryDirectory() as tmp, Browser(*WINDOW) as b:
        for name, (png, frac) in SHOTS.items():
            path = ROOT / "urdf" / f"{name}.urdf"
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", viz.GeometryWarning)
                model = md.load_urdf(path)
                m = viz.demo_motion(model, path)
                page = Path(tmp) / f"{name}.html"
                sc = viz.export_html(model, path, m.pop("t"), m.pop("Q"), page, **m)
            b.open(f"file://{page}#t={sc.t0 + frac * sc.times[-1]:.4f}")
            b.frames(5)
            shot = Path(tmp) / png
            b.shot(shot)
            img = Image.open(shot).convert("RGB")
            img.save(ROOT / "docs" / png, optimize=True)
            print(f"wrote docs/{png} ({(ROOT / 'docs' / png).stat().st_size // 1024} kB)")


if __name__ == "__main__":
    main()
