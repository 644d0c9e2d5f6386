"""Quirks: what a loader noticed in a file and reports in ``Model.quirks`` — a difference between engines in how
they read the file (manipdyn reads it as one of them does, and says so), or a flaw in the data.

``QUIRK_KINDS`` names every kind with one sentence on what manipdyn does about it, in the order the loaders
report them; ``Quirk`` is one of them found in a file: its kind, the link, joint or element it concerns, and a
detail sentence.
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["QUIRK_KINDS", "Quirk"]

# What the loader reports about a file (Model.quirks), one kind per engine difference or data flaw:
QUIRK_KINDS = {
    "zero_mass_inertia": "mass 0 but a nonzero rotational inertia (kept or dropped: load_urdf zero_mass_inertia=)",
    "point_mass": "an <inertial> with <mass> but no <inertia>: a point mass at its <origin> (Pinocchio 4.1's reading)",
    "non_psd_inertia": "a body's inertia is not positive semi-definite: loaded as written (load_urdf "
                       "non_psd_inertia=\"keep\"; the default refuses it)",
    "no_inertial": "a link carried by a moving joint has no <inertial> (a massless body unless fixed links add mass)",
    "triangle": "principal moments violate the triangle inequality I1 + I2 >= I3",
    "rotated_root_inertial": "the root link's <inertial><origin rpy> is not zero",
    "free_root": "the root body carries mass and the tree's shape says it is a free body (legs, or a heavy body "
                 "with a hanging appendage, or no joint at all): load with root_joint=\"free_flyer\"",
    "mimic": "a <mimic> joint (honoured with mimic=True, else loaded as an independent joint)",
    "version": "<robot version> that urdfdom 6 (Pinocchio 4.1's reader) refuses; manipdyn loads the file",
    "xml_version": "an XML declaration whose version is not 1.x (<?xml version=\"0.0\"?>): read as XML 1.0, as "
                   "urdfdom (Pinocchio), MuJoCo, PyBullet and Drake ignore it",
    "xml_text": "whitespace before the XML declaration, or NUL bytes (a C string's terminator) after the document: "
                "removed before parsing, as urdfdom (Pinocchio), MuJoCo and PyBullet read such files",
    "inverted_limits": "a joint <limit> with lower > upper: read as no position limit (PyBullet's reading; urdfdom "
                       "keeps the numbers); limits never enter the dynamics (load_urdf strict=True refuses it)",
    "unknown_element": "an element manipdyn does not read (reported, never dropped in silence)",
    "joint_dynamics": "an MJCF joint's stiffness, springref or springdamper is nonzero: read, not applied yet (its "
                      "armature, damping and frictionloss are applied: Model.armature, damping, friction)",
    "free_armature": "an MJCF free joint's armature: applied as Pinocchio applies model.armature, armature ⊙ v̇ with v "
                     "the body-frame twist; MuJoCo adds it to d/dt of its world-frame linear velocity, so its τ differs "
                     "by armature · R (ω × v_lin) on the linear rows (M and the energy are the same)",
    "joint_ref": "an MJCF joint's ref (MuJoCo's qpos0) is nonzero: folded into the joint's placement, so q is MuJoCo's "
                 "qpos and q = 0 is not the pose drawn in the file",
    "passive_force": "an MJCF element that adds passive forces manipdyn does not apply (a body's gravcomp, a tendon's "
                     "stiffness or damping, <option> fluid density, viscosity or wind); MuJoCo's mj_rne leaves them out "
                     "too",
    "equality_softness": "an MJCF equality's solref, solimp or a weld's torquescale: MuJoCo's constraint softness (or "
                         "the scale of its rows), not a model parameter; manipdyn's closures are rigid",
    "inactive_equality": "an MJCF equality with active=\"false\": not read as a closure (MuJoCo starts with it off)",
}


@dataclass(frozen=True)
class Quirk:
    """One thing the loader noticed in a file: kind (a key of QUIRK_KINDS), the link, joint or element it
    concerns, and a detail sentence."""
    kind: str
    name: str
    detail: str

    def as_dict(self) -> dict:
        return {"kind": self.kind, "name": self.name, "detail": self.detail}
