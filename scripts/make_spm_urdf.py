"""Regenerate urdf/spm.urdf from manipdyn/examples/spm_params.py (the chapter's Tables 2 and 3), and its URDF+
form tests/data/loops/spm_urdfplus.urdf (scripts/make_urdfplus.py)."""
from pathlib import Path

from make_urdfplus import OUT, urdfplus

from manipdyn.examples.spm_urdf import build_urdf

if __name__ == "__main__":
    out = Path(__file__).resolve().parent.parent / "urdf" / "spm.urdf"
    out.write_text(build_urdf())
    print(f"wrote {out}")
    plus = OUT / "spm_urdfplus.urdf"
    plus.write_text(urdfplus(out.read_text(), "urdf/spm.urdf"))
    print(f"wrote {plus}")
