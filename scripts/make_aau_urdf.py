"""Regenerate urdf/aau_arm.urdf: the chapter's AAU 5-dof arm (Table 1, standard D-H) via manipdyn.dh_to_urdf.

The chapter gives no numbers for h1, l1, l2, d1, the masses or the inertias. Lengths: h1 = 0.30, l1 = 0.55,
l2 = 0.55, d1 = 0.10 m, a consistent choice that follows the chapter's end-effector path with the tool axis
held vertical (smallest singular value of the 5×5 task Jacobian 0.198 along the path; 0.25/0.5/0.5/0.1 is
feasible but nearly singular). Masses and inertias: a ~9 kg lightweight arm, heavier at the shoulder; each
link a solid cylinder about its own segment (I_axis = m r²/2, I_perp = m(3r² + L²)/12), CoM at the segment's
middle, all given in D-H frame i as the table format asks:
    link 1  shoulder housing, base → joint 2 (along −y1),  3.0 kg, r 0.06
    link 2  upper arm, joint 2 → elbow (along −x2),        2.5 kg, r 0.04
    link 3  elbow housing, first quarter of the forearm,   1.5 kg, r 0.04
    link 4  forearm tube, elbow → wrist (along +y4),       1.2 kg, r 0.03
    link 5  wrist and flange, wrist → tool (along −y5),    0.5 kg, r 0.03
The end-effector point is the link `tool` on a fixed joint at the origin of D-H frame 5 (p_n = [0, 0, 0]).
"""
from pathlib import Path

import numpy as np

from manipdyn.io.dh import dh_to_urdf

H1, L1, L2, D1 = 0.30, 0.55, 0.55, 0.10


def cylinder(m, length, r, axis):
    """Inertia (3, 3) of a solid cylinder about its centre, its axis along unit vector ``axis``."""
    k = np.asarray(axis, float)
    perp = m * (3 * r**2 + length**2) / 12
    return perp * np.eye(3) + (m * r**2 / 2 - perp) * np.outer(k, k)


TABLE = [   # Table 1: α_i, a_i, d_i, θ_i (standard D-H)
    dict(alpha=np.pi / 2, a=0.0, d=H1, theta=0.0, mass=3.0, com=[0, -H1 / 2, 0],
         inertia=cylinder(3.0, H1, 0.06, [0, 1, 0])),
    dict(alpha=0.0, a=L1, d=0.0, theta=0.0, mass=2.5, com=[-L1 / 2, 0, 0],
         inertia=cylinder(2.5, L1, 0.04, [1, 0, 0])),
    dict(alpha=np.pi / 2, a=0.0, d=0.0, theta=0.0, mass=1.5, com=[0, 0, L2 / 8],
         inertia=cylinder(1.5, L2 / 4, 0.04, [0, 0, 1])),
    dict(alpha=-np.pi / 2, a=0.0, d=L2, theta=0.0, mass=1.2, com=[0, L2 / 2, 0],
         inertia=cylinder(1.2, L2, 0.03, [0, 1, 0])),
    dict(alpha=np.pi / 2, a=0.0, d=D1, theta=0.0, mass=0.5, com=[0, -D1 / 2, 0],
         inertia=cylinder(0.5, D1, 0.03, [0, 1, 0])),
]


def build() -> str:
    return dh_to_urdf(TABLE, convention="standard", name="aau_arm", tool={"name": "tool"},
                      comment="AAU 5-dof lightweight arm, the chapter's Example I." + __doc__.split("\n", 1)[1]
                      .replace("--", "-"))


if __name__ == "__main__":
    out = Path(__file__).resolve().parent.parent / "urdf" / "aau_arm.urdf"
    out.write_text(build())
    print(f"wrote {out}")
