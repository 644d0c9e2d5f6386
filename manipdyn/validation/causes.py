"""Cause analysis for the engines referee: why an engine's τ, M or q̈ differ from ours, named link by link.

``explain`` diffs an engine's read-back parameters (each adapter's ``links``, ``armature``, ``damping``) against
the file's own numbers (referee_urdf.py), link by link, and against our model's bodies, armature and damping
(docs/design.md §3), and names the quirk (no <inertial>, zero mass with inertia, triangle inequality, rotated
inertial frame, precision, armature, damping); on an MJCF file it compares the engine's bodies with the model's
(no per-link URDF <inertial>). ``precision_causes`` names the links an engine holds to less than double
precision, ``refusal_causes`` what is unusual in the links an engine's refusal names. ``neutralised`` rebuilds
our model with the engine's masses, CoMs and inertias (``dataclasses.replace``), ``applied_damping`` gives our
damping where the engine applies it: the referee compares again with them, and what remains is the engine's
precision.
"""
from __future__ import annotations

import dataclasses
import re

import numpy as np

from ..joints import FREEFLYER
from ..spatial import combine_inertias


def _differs(x, y, floor=1e-12) -> bool:
    """x and y differ beyond round-off: relative 1e-9 of the larger, plus an absolute floor."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    return bool(np.max(np.abs(x - y)) > 1e-9 * max(np.max(np.abs(x)), np.max(np.abs(y))) + floor)


def _same_moments(I, J) -> bool:
    """Same principal moments to 1e-9 (relative to the largest) and close axes (matrices within 1e-5)."""
    scale = max(np.max(np.abs(J)), 1e-300)
    return bool(np.max(np.abs(np.linalg.eigvalsh(I) - np.linalg.eigvalsh(J))) <= 1e-9 * scale
                and np.max(np.abs(I - J)) <= 1e-5 * scale)


def _triangle_broken(I) -> bool:
    lam = np.linalg.eigvalsh(I)
    return bool(lam[0] + lam[1] < lam[2] - 1e-9 * max(np.sum(np.abs(lam)), 1e-300))


def body_params(model, links) -> tuple:
    """(mass (nb,), com (nb, 3), inertia (nb, 3, 3)) of our bodies built from per-link (m, c, I_c) in link
    frames: each link present in ``links`` placed by model.frames and merged into its body."""
    parts = [[] for _ in range(model.njoints)]
    for name, fr in model.frames.items():
        if fr.body >= 0 and name in links:
            m, c, I = links[name]
            parts[fr.body].append((m, fr.p + fr.R @ c, fr.R @ I @ fr.R.T))
    out = [combine_inertias(p) if p else (0.0, np.zeros(3), np.zeros((3, 3))) for p in parts]
    return (np.array([o[0] for o in out], float), np.array([o[1] for o in out], float).reshape(-1, 3),
            np.array([o[2] for o in out], float).reshape(-1, 3, 3))


def explain(model, adapter, inertials) -> list:
    """Named causes [{"link", "kind", "text"}] of every difference between the engine's read-back
    parameters and ours: per link against the file's own numbers, per body against our model, per dof
    for armature and damping. Empty when the engine holds the same parameters."""
    causes, e = [], adapter.name
    em, ec, eI = body_params(model, adapter.links)
    if not adapter.merged:
        for name, fr in model.frames.items():
            if fr.body < 0:
                continue
            f = inertials.get(name)
            if f is None:
                continue
            if name not in adapter.links:
                if f.mass > 0:
                    causes.append(dict(link=name, kind="missing link", text=f"{e} has no link {name!r} "
                                       f"({f.mass:g} kg in the file)"))
                continue
            m, c, I = adapter.links[name]
            causes += _link_causes(e, name, f, m, c, I)
    for i, body in enumerate(model.body_names):       # what the link view cannot see (and merged engines)
        if not (_differs(em[i], model.mass[i]) or _differs(eI[i], model.inertia[i], 1e-15)
                or (model.mass[i] > 0 and _differs(ec[i], model.com[i]))):
            continue
        links = (body,) + tuple(model.merged.get(body, ()))
        if any(c["link"] in links for c in causes):
            continue
        quirks = [q for ln in links if ln in inertials for q in _file_quirks(inertials[ln], ln)]
        causes.append(dict(link=body, kind="body parameters", text=(
            f"{e}: body {body!r} (links {', '.join(links)}) has mass {em[i]:.6g} kg, inertia trace "
            f"{np.trace(eI[i]):.6g}; ours {model.mass[i]:.6g} kg, {np.trace(model.inertia[i]):.6g}"
            + (f" — the file's {'; '.join(quirks)}" if quirks else ""))))
    for j, name in enumerate(model.joint_names):    # ours: model.armature, model.damping (per dof, docs/design.md §3)
        if model.kind[j] == FREEFLYER:                 # a free-flyer root: no armature or damping of its own
            continue
        k = slice(model.idx_v[j], model.idx_v[j] + model.nvs[j])     # a ball: its three dofs
        a, d = adapter.armature[k], adapter.damping[k]
        if _differs(a, model.armature[k]):
            causes.append(dict(link=name, kind="armature", text=f"{e} adds armature {_g(a)} kg m² to joint {name!r} "
                               f"(M's diagonal); ours {_g(model.armature[k])}"))
        if np.any(d) and _differs(d, model.damping[k]):
            causes.append(dict(link=name, kind="damping", text=f"{e} applies joint damping {_g(d)} N m s/rad to "
                               f"joint {name!r} (from <dynamics>); ours {_g(model.damping[k])}"))
    return causes


def _g(x) -> str:
    """A joint's per-dof values: one number when they are one (a 1-dof joint, a ball's three equal entries)."""
    x = np.asarray(x, float)
    return f"{x[0]:g}" if np.all(x == x[0]) else "[" + ", ".join(f"{t:g}" for t in x) + "]"


def applied_damping(model, adapter):
    """Our damping (nv,) where the engine applies damping in its queries (its read-back damping is nonzero), else 0:
    what our side of a comparison adds, as the engine does (τ += d q̇ in ID if ``damping_in_id``, and in FD)."""
    return np.where(adapter.damping != 0, model.damping, 0.0)


def precision_causes(model, adapter, inertials, floor=1e-13, k=3) -> list:
    """The links whose read-back parameters differ from the file's by more than ``floor`` (relative) but
    below the quirk threshold: the engine re-expressed them (e.g. principal axes by an iterative
    diagonalisation) with less than double precision. The k worst, named."""
    worst = []
    for name, fr in model.frames.items():
        f = inertials.get(name)
        if fr.body < 0 or f is None or name not in adapter.links or adapter.merged:
            continue
        m, c, I = adapter.links[name]
        rel = max(abs(m - f.mass) / max(abs(f.mass), 1e-300) if f.mass else abs(m),
                  np.max(np.abs(c - f.com)) / max(np.max(np.abs(f.com)), 1e-3) if f.mass else 0.0,
                  np.max(np.abs(I - f.inertia)) / max(np.max(np.abs(f.inertia)), 1e-300) if np.any(f.inertia)
                  else float(np.max(np.abs(I))))
        if rel > floor:
            worst.append((rel, name))
    return [dict(link=n, kind="precision", text=f"link {n!r}: {adapter.name} holds its mass/CoM/inertia to "
                 f"{rel:.1e} (relative) of the file's: round-off of its own re-expression of the inertia "
                 f"(principal axes), not a modelling difference") for rel, n in sorted(worst, reverse=True)[:k]]


def refusal_causes(reason, inertials) -> list:
    """The links an engine's refusal names (quoted in its message), with what is unusual in their <inertial>."""
    out = []
    for name in dict.fromkeys(re.findall(r"'([^']+)'", reason)):
        f = inertials.get(name)
        if f is None:
            continue
        quirks = _file_quirks(f, name)
        lam = np.linalg.eigvalsh(f.inertia)
        if f.present and lam[0] <= 0:
            quirks.append(f"link {name!r}'s inertia has a principal moment ≤ 0 (eigenvalues {lam.tolist()})")
        if f.present and f.mass == 0 and not np.any(f.inertia):
            quirks.append(f"link {name!r} has zero mass and zero inertia")
        out += [dict(link=name, kind="refused", text=q) for q in quirks]
    return out


def _file_quirks(f, name) -> list:
    """What is unusual in a link's <inertial> (short phrases)."""
    out = []
    if not f.present:
        out.append(f"link {name!r} has no <inertial>")
    elif f.mass == 0 and np.any(f.inertia):
        out.append(f"link {name!r} has zero mass but a non-zero inertia")
    elif f.present and np.any(f.inertia) and _triangle_broken(f.inertia):
        out.append(f"link {name!r}'s inertia violates the triangle inequality")
    if f.rotated:
        out.append(f"link {name!r}'s inertial frame is rotated (rpy ≠ 0)")
    return out


def _link_causes(e, name, f, m, c, I) -> list:
    """The engine's (m, c, I) of one link against the file's LinkInertial f: named quirks."""
    out = []
    dm, dc, dI = _differs(m, f.mass), f.mass > 0 and _differs(c, f.com), _differs(I, f.inertia, 1e-15)
    if not (dm or dc or dI):
        return out
    said = f"{e} holds {m:.6g} kg, inertia diag {np.round(np.diag(I), 9).tolist()}"
    if not f.present:
        out.append(dict(link=name, kind="no <inertial>", text=f"link {name!r} has no <inertial>: {said} "
                        f"(ours and the file: 0 kg)"))
    elif f.mass == 0 and np.any(f.inertia):
        how = "drops the inertia" if not np.any(np.abs(I) > 1e-300) else "changes it"
        out.append(dict(link=name, kind="zero mass with inertia", text=f"link {name!r} has zero mass and a "
                        f"non-zero inertia: {e} {how} ({said}; ours keeps the file's inertia)"))
    elif dI and _triangle_broken(f.inertia):
        out.append(dict(link=name, kind="triangle inequality", text=f"link {name!r}'s inertia violates the "
                        f"triangle inequality: {e} alters it ({said})"))
    elif dI and f.rotated and not _differs(I, f.raw, 1e-15):
        out.append(dict(link=name, kind="rotated inertial frame", text=f"link {name!r}'s inertial frame is "
                        f"rotated: {e} ignores the rotation (holds the inertia as written, unrotated)"))
    elif dI and not (dm or dc) and _same_moments(I, f.inertia):
        rel = np.max(np.abs(I - f.inertia)) / np.max(np.abs(f.inertia))
        out.append(dict(link=name, kind="precision", text=f"link {name!r}: {e} holds the inertia to {rel:.1e} "
                        f"(relative) of the file's, its principal moments to round-off: the principal axes of "
                        f"its re-expression (an iterative diagonalisation that stops at a tolerance) are off, "
                        f"not a modelling difference"))
    else:
        what = [w for w, d in (("mass", dm), ("CoM", dc), ("inertia", dI)) if d]
        out.append(dict(link=name, kind=" and ".join(what), text=f"link {name!r}: {e}'s {' and '.join(what)} "
                        f"differ(s) from the file ({said}; file {f.mass:.6g} kg)"))
    return out


def neutralised(model, adapter):
    """Our model rebuilt with the engine's masses, CoMs and inertias (dataclasses.replace)."""
    m, c, I = body_params(model, adapter.links)
    return dataclasses.replace(model, mass=m, com=c, inertia=I, notes=model.notes + (
        f"parameters read back from {adapter.name}",))
