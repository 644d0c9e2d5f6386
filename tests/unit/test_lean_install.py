"""A lean install: without the extras of pyproject.toml, `import manipdyn` and the algorithms work, and each
optional feature raises MissingExtraError with the pip command of its extra.

The check runs in a fresh virtual environment (tmp_path) whose site-packages holds only the core
distributions — pyproject.toml's ``dependencies`` and their requirements, recursively, found with
importlib.metadata and linked from this environment — plus the repository itself (a .pth file)."""
from __future__ import annotations

import importlib.metadata as md
import json
import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parents[2]
CORE = ("numpy", "scipy", "numba", "yourdfpy")          # pyproject.toml's dependencies, nothing else
OPTIONAL_MODULES = ("pinocchio", "meshcat", "matplotlib", "mujoco", "pybullet", "pydrake", "example_robot_data",
                    "dask", "distributed", "mpmath", "tqdm")
OPTIONAL_DISTS = ("pin", "meshcat", "matplotlib", "mujoco", "pybullet", "drake", "example-robot-data", "dask",
                  "distributed", "mpmath", "tqdm")
TIMEOUT = 120


def core_requirements() -> list[str]:
    """pyproject.toml's [project] dependencies (tomllib from Python 3.11; CORE before)."""
    try:
        import tomllib
    except ModuleNotFoundError:
        return list(CORE)
    with open(ROOT / "pyproject.toml", "rb") as fh:
        return tomllib.load(fh)["project"]["dependencies"]


def closure(requirements) -> tuple[dict, list]:
    """({canonical name: Distribution} of the requirements and of theirs, recursively, extras and markers
    honoured, as installed in this environment; [names that are required but not installed here])."""
    found, absent, seen = {}, [], set()
    todo = [(req, extra) for req in map(Requirement, requirements) for extra in ("", *req.extras)]
    while todo:
        req, extra = todo.pop()
        key = canonicalize_name(req.name)
        if (key, extra) in seen:
            continue
        seen.add((key, extra))
        try:
            dist = found.get(key) or md.distribution(req.name)
        except md.PackageNotFoundError:
            absent.append(req.name)
            continue
        found[key] = dist
        for text in dist.requires or []:
            sub = Requirement(text)
            if sub.marker is None and extra == "" or sub.marker is not None and sub.marker.evaluate({"extra": extra}):
                todo += [(sub, e) for e in ("", *sub.extras)]
    return found, absent


def link_distribution(dist, site: Path):
    """Symlink the distribution's top-level packages, modules and .dist-info folder into ``site``."""
    base = Path(dist.locate_file("")).resolve()
    for top in sorted({Path(str(f)).parts[0] for f in dist.files or []}):
        if top in ("..", "__pycache__") or (site / top).exists():
            continue
        src = base / top
        if src.exists():
            (site / top).symlink_to(src, target_is_directory=src.is_dir())


@pytest.fixture(scope="module")
def lean(tmp_path_factory):
    """The python of a virtual environment with the core distributions and the repository only."""
    requirements = core_requirements()
    assert sorted(canonicalize_name(Requirement(r).name) for r in requirements) == sorted(CORE), \
        f"pyproject.toml's dependencies are no longer the lean core {CORE}: {requirements}"
    dists, absent = closure(requirements)
    lost = [n for n in CORE if canonicalize_name(n) not in dists]
    if lost:
        pytest.skip(f"core distribution(s) {lost} not installed in this environment: nothing to link")
    if [d for d in dists.values() if not d.files]:
        pytest.skip(f"no file list (RECORD) for {[d.metadata['Name'] for d in dists.values() if not d.files]}")
    assert not {canonicalize_name(n) for n in OPTIONAL_DISTS} & set(dists), \
        f"a core distribution requires an optional one: {sorted(set(dists) & set(OPTIONAL_DISTS))}"
    env = tmp_path_factory.mktemp("lean") / "venv"
    base = getattr(sys, "_base_executable", None) or sys.executable
    subprocess.run([base, "-m", "venv", "--without-pip", str(env)], check=True, timeout=TIMEOUT)
    python = env / ("Scripts" if os.name == "nt" else "bin") / ("python.exe" if os.name == "nt" else "python")
    site = Path(subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               capture_output=True, text=True, check=True, timeout=TIMEOUT).stdout.strip())
    assert site.is_dir() and site != Path(sysconfig.get_paths()["purelib"])
    for dist in dists.values():
        link_distribution(dist, site)
    (site / "manipdyn_repo.pth").write_text(str(ROOT) + "\n")
    return python


def run(python, args, cwd):
    """Run the lean python (kernels uncompiled, no user site, no PYTHON* variables of this process)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env.update(MANIPDYN_NOJIT="1", PYTHONNOUSERSITE="1", PYTHONDONTWRITEBYTECODE="1")
    return subprocess.run([str(python), *args], capture_output=True, text=True, cwd=cwd, env=env, timeout=TIMEOUT)


CHECKS = r"""
import json, sys, tempfile
from pathlib import Path
OPTIONAL = __OPTIONAL__
out = {}
import manipdyn
out["after_import"] = sorted(m for m in OPTIONAL if m in sys.modules)
import numpy as np
model = manipdyn.load_urdf(__AAU__)
q, v, a = np.full(model.nv, 0.3), np.full(model.nv, -0.2), np.full(model.nv, 0.5)
tau = manipdyn.rnea(model, q, v, a)
out["finite"] = bool(np.all(np.isfinite(tau)) and np.all(np.isfinite(manipdyn.aba(model, q, v, tau)))
                     and np.all(np.isfinite(manipdyn.mass_matrix(model, q))))
out["aba_inverts_rnea"] = float(np.max(np.abs(manipdyn.aba(model, q, v, tau) - a)))

import manipdyn.cli, manipdyn.validation, manipdyn.validation.referee, manipdyn.validation.fig7
import manipdyn.validation.referee_zoo, manipdyn.bench, manipdyn.bench.hard, manipdyn.viz, manipdyn.examples.aau_arm
out["after_feature_modules"] = sorted(m for m in OPTIONAL if m in sys.modules)

from manipdyn.errors import ManipdynError, MissingExtraError
tmp = Path(tempfile.mkdtemp())
t = np.linspace(0.0, 1.0, 3)
Q = np.tile(q, (3, 1))
from manipdyn.validation.reference import Reference
from manipdyn.validation.adapters import _import, load_engine
class FakeDask:                   # what a Dask array looks like to the route (dask itself is not installed)
    __module__ = "dask.array.core"
    def map_blocks(self):
        pass
entries = {
    "validate: Reference": lambda: Reference(model, __AAU__),
    "validate: validation.robots_dir": lambda: manipdyn.validation.robots_dir(),
    "validate: bench.run": lambda: manipdyn.bench.run(tmp / "bench", quick=True),
    "validate: bench.hard.mp_forward": lambda: manipdyn.bench.hard.mp_forward([1.0], [1.0], [0.0], [0.0], [0.0]),
    "validate: load_engine pinocchio": lambda: load_engine("pinocchio", model, __AAU__),
    "viz: viz.LiveViewer": lambda: manipdyn.viz.LiveViewer(),
    "viz: viz.export_html": lambda: manipdyn.viz.export_html(model, __AAU__, t, Q, tmp / "play.html"),
    "plots: examples.aau_arm.plot": lambda: manipdyn.examples.aau_arm.plot(tmp, model, None, None),
    "plots: bench.report.plots": lambda: manipdyn.bench.report.plots({}, tmp),
    "engines: mujoco": lambda: _import("mujoco"),
    "engines: pybullet": lambda: _import("pybullet"),
    "engines: pydrake": lambda: _import("pydrake"),
    "dask: rnea on a Dask array": lambda: manipdyn.rnea(model, FakeDask(), FakeDask(), FakeDask()),
}
out["entries"] = {}
for name, call in entries.items():
    try:
        call()
        out["entries"][name] = ["no error", ""]
    except Exception as exc:
        kinds = [k for k, c in (("MissingExtraError", MissingExtraError), ("ManipdynError", ManipdynError),
                                ("ImportError", ImportError)) if isinstance(exc, c)]
        out["entries"][name] = [" ".join(kinds) or type(exc).__name__, str(exc)]
out["no_bar"] = manipdyn.cli._progress_bar() is manipdyn.cli._NoBar
out["files_written"] = sorted(p.name for p in tmp.rglob("*"))
print(json.dumps(out))
"""


def test_the_lean_environment_lacks_the_extras(lean):
    out = run(lean, ["-c", "import sys; print(sys.prefix != sys.base_prefix); import pinocchio"], ROOT)
    assert out.stdout.strip() == "True", out.stderr
    assert out.returncode == 1 and "ModuleNotFoundError: No module named 'pinocchio'" in out.stderr


def test_core_works_and_each_extra_is_named(lean):
    code = CHECKS.replace("__OPTIONAL__", repr(OPTIONAL_MODULES))
    code = code.replace("__AAU__", repr(str(ROOT / "urdf" / "aau_arm.urdf")))
    out = run(lean, ["-c", code], lean.parent)
    assert out.returncode == 0, out.stderr[-3000:]
    r = json.loads(out.stdout.strip().splitlines()[-1])
    assert r["after_import"] == [] and r["after_feature_modules"] == []       # every optional import is lazy
    assert r["finite"] and r["aba_inverts_rnea"] < 1e-9                         # the algorithms, uncompiled
    assert r["no_bar"]                                                           # validate's bar falls back
    assert r["files_written"] == []                                              # refused before any work
    for name, (kind, message) in r["entries"].items():
        extra = name.split(":")[0]
        assert kind == "MissingExtraError ManipdynError ImportError", (name, kind, message)
        assert f'pip install "manipdyn[{extra}]"' in message, (name, message)
        assert "\n" not in message, (name, message)
    assert r["entries"]["validate: Reference"][1] == \
        'manipdyn validate needs Pinocchio: pip install "manipdyn[validate]"'


def test_cli_names_the_extra_in_one_line(lean):
    out = run(lean, ["-m", "manipdyn", "validate", "urdf/aau_arm.urdf"], ROOT)
    assert out.returncode == 2, (out.stdout, out.stderr)
    assert out.stdout == ""
    lines = out.stderr.strip().splitlines()
    assert lines == ['manipdyn validate: error: manipdyn validate needs Pinocchio: pip install "manipdyn[validate]"']
    assert "Traceback" not in out.stderr
