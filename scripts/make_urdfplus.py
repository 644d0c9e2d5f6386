"""Write the bundled closed chains (urdf/fourbar.urdf, urdf/spm.urdf) in URDF+ form into tests/data/loops/.

URDF+ (Chignoli et al., arXiv 2411.19753; the models of generalized_rbda) closes loops with
<loop name type><predecessor link><origin/></predecessor><successor link><origin/></successor><axis/></loop>
(one axis, in the loop frame, which each side's <origin rpy> turns into its link) and marks the actuated
joints with independent="true"|"false" instead of <transmission>. Each <constraint> becomes one <loop>:
  revolute   loop axis z; each side's rpy turns z onto that side's axis (the <constraint> rpy is unused
             by a revolute closure), so both sides carry a non-zero rotation when the axis is not z;
  fixed      each side's rpy copied (the closure frames), the axis left out;
  spherical  origins copied.
Moving joints named in a <transmission> get independent="true", the others "false"; transmissions are
dropped. Everything else is kept byte for byte. tests/crosscheck/test_urdfplus_forms.py checks the files are
what this script makes now, and that both forms give the same closures and dynamics.

Run from the repository root:  python scripts/make_urdfplus.py   (scripts/make_spm_urdf.py runs it too)
"""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from manipdyn.spatial import matrix_rpy, rotation_between

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "tests" / "data" / "loops"
SOURCES = {"fourbar.urdf": "fourbar_urdfplus.urdf", "spm.urdf": "spm_urdfplus.urdf"}


def _f(x):
    return " ".join(repr(float(v)) if v != 0 else "0" for v in x)


def _floats(e, key, default):
    return np.array([float(t) for t in e.get(key).split()]) if e is not None and e.get(key) else np.array(default, float)


def _loop(c) -> str:
    """One <constraint> element -> the <loop> text."""
    kind = c.get("type")
    sides = []
    for role, tag in (("parent", "predecessor"), ("child", "successor")):
        org = c.find(f"{role}_origin")
        xyz, rpy = _floats(org, "xyz", (0, 0, 0)), _floats(org, "rpy", (0, 0, 0))
        if kind == "revolute":
            axis = _floats(c.find(f"{role}_axis"), "xyz", (0, 0, 1))
            rpy = matrix_rpy(rotation_between(np.array([0.0, 0.0, 1.0]), axis / np.linalg.norm(axis)))
        sides.append(f'    <{tag} link="{c.find(role).get("link")}"><origin xyz="{_f(xyz)}" rpy="{_f(rpy)}"/></{tag}>')
    axis = '\n    <axis xyz="0 0 1"/>' if kind == "revolute" else ""
    return f'<loop name="{c.get("name")}" type="{kind}">\n' + "\n".join(sides) + axis + "\n  </loop>"


def urdfplus(text: str, source: str = "") -> str:
    """The URDF+ form of a URDF with <constraint> closures and <transmission>s (module docstring)."""
    robot = ET.fromstring(text.encode())
    actuated = {j.get("name") for t in robot.findall("transmission") for j in t.findall("joint")}
    text = re.sub(r"<constraint .*?</constraint>", lambda m: _loop(ET.fromstring(m.group(0))), text, flags=re.S)
    text = re.sub(r"\n *<transmission .*?</transmission>", "", text, flags=re.S)

    def mark(m):
        name, kind = m.group(1), m.group(2)
        if kind == "fixed":
            return m.group(0)
        return m.group(0)[:-1] + f' independent="{"true" if name in actuated else "false"}">'
    text = re.sub(r'<joint name="([^"]+)" type="([^"]+)">', mark, text)
    note = (f"<!-- URDF+ form of {source} (<loop> for <constraint>, independent= for <transmission>), written by "
            f"scripts/make_urdfplus.py; do not edit. -->\n")
    head, sep, rest = text.partition("<robot ")
    return head + note + sep + rest


def main():
    for src, dst in SOURCES.items():
        out = OUT / dst
        out.write_text(urdfplus((ROOT / "urdf" / src).read_text(), f"urdf/{src}"))
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
