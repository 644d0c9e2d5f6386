"""Write tests/data/humanoid_ball.xml: gymnasium's MuJoCo humanoid (gymnasium/envs/mujoco/assets/humanoid.xml,
gymnasium 1.4.0; MIT License, Copyright (c) 2022 Farama Foundation) with ball joints at the hips and shoulders.

What changes (text replacements on the file; the script checks each is made exactly once):
- each hip's hinge triplet (hip_x, hip_z, hip_y, about one anchor) becomes one ``type="ball"`` joint
  (``right_hip``, ``left_hip``) at that anchor, armature 0.01 and damping 5 (the triplet's; MuJoCo's ball has one
  armature for its three dofs), its range a cone of 90 degrees (a limit of MuJoCo's solver, not of the dynamics);
- each shoulder's hinge pair (shoulder1, shoulder2) becomes one ball joint (``right_shoulder``, ``left_shoulder``),
  armature 0.006 (between the pair's 0.0068 and 0.0051), damping 1 (the file's default), the same cone;
- the balls carry no stiffness (the hinges' springs have no one-number equivalent on a quaternion);
- the two fixed tendons (hip_y + knee) and the motors of the removed hinges go, as their joints do.
Everything else is the file as published: the free root joint, the abdomen's two joints in one body, the knees and
elbows with their armature, damping and stiffness, the geoms the masses come from, ``<compiler angle="degree"
inertiafromgeom="true">``.

Run from the repository root: ``PYTHONPATH=. python scripts/make_humanoid_ball.py`` (needs gymnasium).
"""
from __future__ import annotations

import os
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "tests" / "data" / "humanoid_ball.xml"

HEADER = """<!-- tests/data/humanoid_ball.xml, written by scripts/make_humanoid_ball.py (do not edit by hand).
     From gymnasium 1.4.0's envs/mujoco/assets/humanoid.xml (MIT License, Copyright (c) 2022 Farama Foundation),
     changed: the hips' hinge triplets and the shoulders' hinge pairs are ball joints (armature 0.01 and 0.006,
     damping 5 and 1, no stiffness); the tendons and motors of the removed hinges are removed. -->
"""


def ball(side, part, armature, damping):
    return (f'<joint armature="{armature}" damping="{damping}" name="{side}_{part}" pos="0 0 0" range="0 90" '
            f'type="ball"/>')


def convert(text: str) -> str:
    """The ball-joint humanoid of gymnasium's humanoid.xml text."""
    def once(pattern, repl, s):
        out, n = re.subn(pattern, repl, s, flags=re.S)
        if n != 1:
            raise ValueError(f"{pattern!r}: {n} matches (expected 1): not the gymnasium humanoid this script knows")
        return out

    for side in ("right", "left"):
        text = once(rf'<joint [^>]*name="{side}_hip_x"[^>]*/>\s*<joint [^>]*name="{side}_hip_z"[^>]*/>\s*'
                    rf'<joint [^>]*name="{side}_hip_y"[^>]*/>', ball(side, "hip", 0.01, 5), text)
        text = once(rf'<joint [^>]*name="{side}_shoulder1"[^>]*/>\s*<joint [^>]*name="{side}_shoulder2"[^>]*/>',
                    ball(side, "shoulder", 0.006, 1), text)
        text = once(rf'\s*<fixed name="{side}_hipknee">.*?</fixed>', "", text)
        for j in ("hip_x", "hip_z", "hip_y", "shoulder1", "shoulder2"):
            text = once(rf'\s*<motor [^>]*joint="{side}_{j}"[^>]*/>', "", text)
    text = once(r"\s*<tendon>\s*</tendon>", "", text)
    return HEADER + text


def source() -> Path:
    import gymnasium
    return Path(os.path.dirname(gymnasium.__file__)) / "envs" / "mujoco" / "assets" / "humanoid.xml"


if __name__ == "__main__":
    OUT.write_text(convert(source().read_text()))
    print(f"wrote {OUT}")
