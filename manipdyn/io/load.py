"""load_model: a robot file read by the reader its content asks for (root element <robot> -> URDF, <mujoco> -> MJCF)."""
from __future__ import annotations

import os

from ..errors import ManipdynError
from .safe_xml import MAX_BYTES, parse_xml

__all__ = ["load_model", "robot_format"]


def robot_format(path, max_bytes=MAX_BYTES) -> str:
    """"urdf" (root element ``<robot>``) or "mjcf" (``<mujoco>``) of a robot file, by its content; ManipdynError
    naming the root element found when it is neither."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ManipdynError(f"{path}: no such robot file")
    with open(path, "rb") as fh:
        data = fh.read(max_bytes + 1)
    if len(data) > max_bytes:
        raise ManipdynError(f"{path}: larger than the size limit of {max_bytes} bytes (pass max_bytes=...)")
    tag = parse_xml(data, path, None, root_tag=None, error=ManipdynError).tag
    if tag not in ("robot", "mujoco"):
        raise ManipdynError(f"{path}: root element <{tag}>: neither URDF (<robot>) nor MJCF (<mujoco>)")
    return "urdf" if tag == "robot" else "mjcf"


def load_model(path, **kw):
    """Read a URDF or MJCF file into a Model, choosing the reader by the file's root element, not its name:
    ``<robot>`` -> ``load_urdf(path, **kw)``, ``<mujoco>`` -> ``load_mjcf(path, **kw)``. The keywords are the
    chosen reader's. Raises ManipdynError naming the root element found when it is neither (and the readers'
    errors otherwise)."""
    if robot_format(path, kw.get("max_bytes", MAX_BYTES)) == "urdf":
        from .urdf import load_urdf
        return load_urdf(path, **kw)
    from .mjcf_read import load_mjcf
    return load_mjcf(path, **kw)
