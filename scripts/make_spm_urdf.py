"""Regenerate urdf/spm.urdf from manipdyn/examples/spm_params.py (the chapter's Tables 2 and 3)."""
from pathlib import Path

from manipdyn.examples.spm_urdf import build_urdf

if __name__ == "__main__":
    out = Path(__file__).resolve().parent.parent / "urdf" / "spm.urdf"
    out.write_text(build_urdf())
    print(f"wrote {out}")
