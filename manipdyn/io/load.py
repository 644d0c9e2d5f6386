"""load_model: a robot file read by the reader its content asks for (root element <robot> -> URDF, <mujoco> -> MJCF)."""
from __future__ import annotations

import os

from ..errors import ManipdynError
from .urdf import MAX_BYTES, _parse_xml

__all__ = ["load_model"]


def load_model(path, **kw):
    """Read a URDF or MJCF file into a Model, choosing the reader by the file's root element, not its name:
    ``<robot>`` -> ``load_urdf(path, **kw)``, ``<mujoco>`` -> ``load_mjcf(path, **kw)``. The keywords are the
    chosen reader's. Raises ManipdynError naming the root element found when it is neither (and the readers'
    errors otherwise)."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ManipdynError(f"{path}: no such robot file")
    max_bytes = kw.get("max_bytes", MAX_BYTES)
    with open(path, "rb") as fh:
        data = fh.read(max_bytes + 1)
    if len(data) > max_bytes:
        raise ManipdynError(f"{path}: larger than the size limit of {max_bytes} bytes (pass max_bytes=...)")
    tag = _parse_xml(data, path, None, root_tag=None, error=ManipdynError).tag
    if tag == "robot":
        from .urdf import load_urdf
        return load_urdf(path, **kw)
    if tag == "mujoco":
        from .mjcf_read import load_mjcf
        return load_mjcf(path, **kw)
    raise ManipdynError(f"{path}: root element <{tag}>: neither URDF (<robot>) nor MJCF (<mujoco>)")
