"""Optional packages, imported on first use: a missing one names the feature and the extra that brings it.

``import manipdyn`` and every algorithm need only numpy, scipy, numba and yourdfpy. The rest comes with the
extras of pyproject.toml: validate (Pinocchio, example-robot-data, mpmath, tqdm), viz (meshcat), plots
(matplotlib), engines (MuJoCo, PyBullet, Drake), dask (Dask arrays of states), gpu (numba-cuda: manipdyn.gpu).
Each import of one of them goes through ``require``::

    pin = require("pinocchio", "validate", "manipdyn validate")
    # not installed: MissingExtraError('manipdyn validate needs Pinocchio: pip install "manipdyn[validate]"')
"""
from __future__ import annotations

import importlib

from .errors import MissingExtraError

# top-level module -> the name a user knows it by
LABELS = {"pinocchio": "Pinocchio", "example_robot_data": "example-robot-data", "meshcat": "meshcat",
          "umsgpack": "u-msgpack-python (meshcat's)", "matplotlib": "matplotlib", "mpmath": "mpmath",
          "tqdm": "tqdm", "mujoco": "MuJoCo", "pybullet": "PyBullet", "pybullet_data": "PyBullet",
          "pydrake": "Drake", "dask": "Dask", "distributed": "Dask distributed", "numba_cuda": "numba-cuda",
          "cupy": "CuPy"}


def install_command(extra) -> str:
    """The pip command of one manipdyn extra: pip install "manipdyn[extra]"."""
    return f'pip install "manipdyn[{extra}]"'


def missing(module, extra, feature, cause=None) -> MissingExtraError:
    """The MissingExtraError for ``module`` (needed by ``feature``, installed by ``extra``); ``cause``: why an
    installed package failed to import, added in parentheses."""
    top = str(module).split(".")[0]
    why = f" ({cause})" if cause else ""
    err = MissingExtraError(f"{feature} needs {LABELS.get(top, top)}{why}: {install_command(extra)}", name=top)
    err.module, err.extra, err.feature = module, extra, feature
    return err


def require(module, extra, feature):
    """``importlib.import_module(module)``, or MissingExtraError naming ``feature`` and the pip command of
    ``extra`` when the module (or a package it needs) cannot be imported."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        absent = isinstance(exc, ModuleNotFoundError) and (exc.name or "").split(".")[0] == module.split(".")[0]
        cause = None if absent else " ".join(f"import {module} failed: {exc}".split())
        raise missing(module, extra, feature, cause) from exc
