"""What the referee reads from the URDF file itself: each link's <inertial> as written, and the file's text without
<visual> and <collision>.

The referee reads the file again, apart from manipdyn's loader, to see what each engine would read: an engine
holds a link's inertial as the file writes it (its own mass, CoM and rotated inertia, no <inertial> as nothing),
before anything manipdyn does with it (merging fixed links, its policies and quirks). causes.py diffs each
engine's read-back parameters against these numbers, link by link; the adapters load the stripped text, so that
no engine needs meshes or derives inertia from them.
"""
from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np

from ..spatial import rpy_matrix


@dataclasses.dataclass
class LinkInertial:
    """A URDF link's <inertial> as written: mass, CoM and inertia about the CoM in the link frame."""
    present: bool              # False: the link has no <inertial>
    mass: float
    com: np.ndarray            # (3,)
    inertia: np.ndarray        # (3, 3) in the link frame (the inertial origin's rotation applied)
    rotated: bool              # the inertial origin has a non-zero rpy
    raw: np.ndarray            # (3, 3) as written, in the inertial frame


def urdf_inertials(path) -> dict:
    """{link name: LinkInertial} read from the file (lxml without entities or network, as the loader)."""
    from lxml import etree
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, remove_comments=True)
    root = etree.fromstring(Path(path).read_bytes(), parser)
    out = {}
    for link in root.findall("link"):
        e = link.find("inertial")
        if e is None:
            out[link.get("name")] = LinkInertial(False, 0.0, np.zeros(3), np.zeros((3, 3)), False, np.zeros((3, 3)))
            continue
        o, m, i = e.find("origin"), e.find("mass"), e.find("inertia")
        xyz = np.array((o.get("xyz", "0 0 0") if o is not None else "0 0 0").split(), float)
        rpy = np.array((o.get("rpy", "0 0 0") if o is not None else "0 0 0").split(), float)
        k = {a: float(i.get(a, 0.0)) for a in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")} if i is not None else {}
        raw = np.array([[k.get("ixx", 0), k.get("ixy", 0), k.get("ixz", 0)],
                        [k.get("ixy", 0), k.get("iyy", 0), k.get("iyz", 0)],
                        [k.get("ixz", 0), k.get("iyz", 0), k.get("izz", 0)]], float)
        R = rpy_matrix(rpy)
        out[link.get("name")] = LinkInertial(True, float(m.get("value")) if m is not None else 0.0, xyz,
                                             R @ raw @ R.T, bool(np.any(rpy != 0)), raw)
    return out


def stripped_urdf(path) -> str:
    """The file's text without <visual> and <collision> elements (no engine needs meshes for dynamics)."""
    text = Path(path).read_text(encoding="utf-8")
    text = re.sub(r"<(visual|collision)\b[^>]*/>", "", text)
    return re.sub(r"<(visual|collision)\b.*?</\1\s*>", "", text, flags=re.S)
