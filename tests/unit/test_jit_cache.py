"""numba's on-disk cache must never hide an edit: changing any kernel source recompiles every compiled
function that depends on it, across modules (kinematics.py and closures.py inline forward_kinematics.fk_pass, which
inlines joints.joint_placement).

The end-to-end case copies the package to a temporary folder, runs it in a fresh interpreter to fill the
cache, flips a sign in a callee in joints.py in the copy, and runs it again in a fresh interpreter:
the numbers must be those of the edited source — checked against the same edited source run uncompiled
(MANIPDYN_NOJIT=1) in a second copy, not merely "different".
"""
import ast
import json
import os
import re
import shutil
import subprocess
import sys

import numpy as np
from conftest import ROOT, assert_close

from manipdyn import _jit

# frame_kernel (dynamics/kinematics.py), closure_kernel (constraints/closures.py) and rnea_derivatives_kernel
# (dynamics/derivatives.py; rnea and rnea_terms drive the lane steps, which place a joint in lanes.py), all inlining
# joints.joint_placement, on one fixed state of the spherical parallel manipulator.
PROBE = f"""
import json, numpy as np, manipdyn as md
from manipdyn.constraints import closure_terms
m = md.load_urdf({str(ROOT / "urdf" / "spm.urdf")!r})
rng = np.random.default_rng(3)
q, v, a = rng.uniform(-3, 3, m.nq), rng.normal(0, 2, m.nv), rng.normal(0, 2, m.nv)
phi, jac, bias = closure_terms(m, q, v)
import os; assert md.__file__.startswith(os.getcwd()), md.__file__    # the copy, not the checkout
print(json.dumps(dict(J=md.frame_jacobian(m, q, "platform").tolist(), phi=phi.tolist(), jac=jac.tolist(),
                      bias=bias.tolist(), dtau_dq=md.rnea_derivatives(m, q, v, a)[0].tolist())))
"""


def _run(pkg_root, **env_extra):
    env = {k: x for k, x in os.environ.items() if not k.startswith(("NUMBA_", "MANIPDYN_"))}
    env.update(PYTHONPATH=str(pkg_root), **env_extra)
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, cwd=pkg_root, capture_output=True, text=True,
                         timeout=900)                          # cwd: `-c` puts it first on sys.path
    assert out.returncode == 0, out.stderr[-3000:]
    return {k: np.array(x) for k, x in json.loads(out.stdout.splitlines()[-1]).items()}


def _copy_package(dst):
    shutil.copytree(ROOT / "manipdyn", dst / "manipdyn", ignore=shutil.ignore_patterns("__pycache__"))
    return dst


def _flip_rotation_sign(pkg_root):
    """Plant a visible edit in a callee: joint_placement turns a revolute joint by −q instead of q."""
    path = pkg_root / "manipdyn" / "joints.py"
    new, n = re.subn(r"rodrigues\(x, y, z, np\.sin\(q0\), np\.cos\(q0\)\)", "rodrigues(x, y, z, -np.sin(q0), np.cos(q0))",
                     path.read_text())
    assert n == 1, "the edit site in joint_placement moved; update this test"
    path.write_text(new)


def _files(folder):
    return {p: p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file()}


def test_callee_edit_reaches_every_compiled_caller(tmp_path):
    pkg, cache = _copy_package(tmp_path / "pkg"), tmp_path / "numba-cache"
    before = _run(pkg, NUMBA_CACHE_DIR=str(cache))              # compiles and fills the cache
    filled = _files(cache)
    assert any(p.suffix == ".nbi" for p in filled)
    assert _run(pkg, NUMBA_CACHE_DIR=str(cache)).keys() == before.keys()
    assert _files(cache) == filled                              # unchanged sources: the cache is reused
    _flip_rotation_sign(pkg)
    after = _run(pkg, NUMBA_CACHE_DIR=str(cache))               # must recompile, not load the stale cache
    fresh = _copy_package(tmp_path / "fresh")                   # the edited source, uncompiled, no cache
    _flip_rotation_sign(fresh)
    truth = _run(fresh, MANIPDYN_NOJIT="1")
    for k in before:
        assert np.max(np.abs(before[k] - truth[k])) > 1e-3, f"the planted edit does not change {k}"
        # compiled vs uncompiled: the same arithmetic (measured 0 on all five; 1e-13 allows operation reordering)
        assert_close(after[k], truth[k], 1e-13, f"{k} after editing a callee (stale compiled cache?)")


def test_cache_folder_is_keyed_by_every_kernel_source(tmp_path):
    pkg = _copy_package(tmp_path / "pkg") / "manipdyn"
    first = _jit.cache_dir(pkg, user_base=str(tmp_path / "user"))
    assert first.parent == tmp_path / "user" and first.is_dir()          # a user's NUMBA_CACHE_DIR is the base
    in_tree = _jit.cache_dir(pkg, user_base="")
    assert in_tree.parent == pkg / "__pycache__" and in_tree.name == first.name
    for name in _jit.KERNEL_SOURCES:
        path = pkg / name
        text = path.read_text()
        path.write_text(text + "\n# edited\n")
        assert _jit.cache_dir(pkg, user_base="").name != first.name, f"an edit of {name} keeps the cache"
        path.write_text(text)
    assert _jit.cache_dir(pkg, user_base="").name == first.name
    path.write_text(text + "\n# edited\n")
    _jit.cache_dir(pkg, user_base="")
    assert in_tree.exists()                                   # choosing a folder removes nothing (no side effect)
    gone = _jit.prune_stale(pkg)                              # warmup prunes the stale folders, keeps the current
    assert in_tree in gone and not in_tree.exists() and _jit.cache_dir(pkg, user_base="").exists()
    assert len(list((pkg / "__pycache__").glob("numba-*"))) == 1


def _jitted_functions(tree):
    """Names of the module's functions decorated with njit."""
    def is_njit(d):
        d = d.func if isinstance(d, ast.Call) else d
        return isinstance(d, ast.Name) and d.id == "njit" or isinstance(d, ast.Attribute) and d.attr == "njit"
    return [f for f in ast.walk(tree) if isinstance(f, ast.FunctionDef) and any(map(is_njit, f.decorator_list))]


# compiled as a user's own code is (numba.njit, no disk cache, so no cache key to keep fresh): the bench's row of a
# step of a user's njit loop (manipdyn.compiled)
USER_CODE = {"bench/sections.py"}


def test_kernel_sources_cover_every_compiled_dependency():
    """Every module with a compiled function, and every package module a compiled function takes a
    name from, is hashed into the cache key."""
    pkg = ROOT / "manipdyn"
    listed = set(_jit.KERNEL_SOURCES)
    for path in pkg.rglob("*.py"):
        rel = path.relative_to(pkg).as_posix()
        tree = ast.parse(path.read_text())
        jitted = _jitted_functions(tree)
        if rel in USER_CODE:                       # its compiled functions: numba.njit as a user writes it
            assert jitted and all("cache" not in ast.unparse(d) for f in jitted for d in f.decorator_list), rel
            continue
        if not jitted:
            continue
        assert rel in listed, f"{rel} defines compiled functions but is not in _jit.KERNEL_SOURCES"
        assert "from numba import njit" not in path.read_text(), f"{rel}: use manipdyn._jit.njit"
        imported = {}                          # name -> source file of `from .x import name` (package only)
        for node in tree.body:
            if isinstance(node, ast.ImportFrom) and node.level > 0:
                base = path.parent
                for _ in range(node.level - 1):
                    base = base.parent
                src = (base / (node.module or "").replace(".", "/")).with_suffix(".py").relative_to(pkg)
                for a in node.names:
                    imported[a.asname or a.name] = src.as_posix()
        for f in jitted:
            used = {n.id for n in ast.walk(f) if isinstance(n, ast.Name)}
            for name in used & imported.keys():
                assert imported[name] in listed, \
                    f"{rel}:{f.name} compiles {name} from {imported[name]}, which is not in _jit.KERNEL_SOURCES"
