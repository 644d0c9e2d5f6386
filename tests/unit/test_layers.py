"""Imports go one way (docs/design.md §2): every import statement in manipdyn/, read from the source with ast —
imports inside functions too, which an import-only test never sees — points to the same layer or one below,
and no chain of imports between manipdyn's modules comes back to where it started.

Layers, bottom up: errors/_jit/paths/extras → spatial → model (model, joints, reduce, quirks, kernel_form) →
io → dynamics → constraints → simulation → the package's public API (manipdyn/__init__.py) → examples →
validation → bench → viz → cli. Closed chains (constraints/) sit on top of tree dynamics (dynamics/); simulation uses
both. A module that is in no layer fails the test until it is placed.
"""
from __future__ import annotations

import ast

import pytest
from conftest import ROOT

PKG = ROOT / "manipdyn"
LAYERS = (("base", ("manipdyn.errors", "manipdyn._jit", "manipdyn.paths", "manipdyn.extras")),
          ("spatial", ("manipdyn.spatial",)),
          ("model", ("manipdyn.model", "manipdyn.joints", "manipdyn.reduce", "manipdyn.quirks",
                     "manipdyn.kernel_form")),
          ("io", ("manipdyn.io",)),
          ("dynamics", ("manipdyn.dynamics", "manipdyn.configuration")),
          ("constraints", ("manipdyn.constraints",)),
          ("simulation", ("manipdyn.simulation",)),
          ("api", ("manipdyn",)),
          ("examples", ("manipdyn.examples",)),
          ("validation", ("manipdyn.validation",)),
          ("bench", ("manipdyn.bench",)),
          ("viz", ("manipdyn.viz",)),
          ("cli", ("manipdyn.cli", "manipdyn.__main__")))    # `python -m manipdyn` runs the CLI


def modules(pkg=PKG):
    """{dotted module name: path} of every .py file under manipdyn/ (a package is its __init__.py)."""
    out = {}
    for path in sorted(pkg.rglob("*.py")):
        parts = path.relative_to(pkg.parent).with_suffix("").parts
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def imports(name, path, known):
    """[(line, imported manipdyn module)] of every import statement in the module, at any depth.

    ``from X import a`` names module X.a when that is a module, else X (a, an attribute of X)."""
    is_pkg = path.name == "__init__.py"
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names if a.name.split(".")[0] == "manipdyn"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")[:len(name.split(".")) - node.level + is_pkg]
                src = ".".join(base + ([node.module] if node.module else []))
            else:
                src = node.module or ""
            if src.split(".")[0] != "manipdyn":
                continue
            out += [(node.lineno, f"{src}.{a.name}" if f"{src}.{a.name}" in known else src) for a in node.names]
    return out


def layer(module):
    """Index of the module's layer (longest matching prefix), or None."""
    best = None
    for i, (_, prefixes) in enumerate(LAYERS):
        for p in prefixes:
            if (module == p or module.startswith(p + ".")) and (best is None or len(p) > best[1]):
                best = (i, len(p))
    return None if best is None else best[0]


def graph(pkg=PKG):
    """{module: [(line, imported module)]} over manipdyn's own modules."""
    known = modules(pkg)
    return {m: imports(m, p, known) for m, p in known.items()}, known


def layer_violations(g):
    """'module:line (layer) imports target (higher layer)' for every import that points upward."""
    bad = []
    for m, edges in g.items():
        for line, target in edges:
            lm, lt = layer(m), layer(target)
            if lt is not None and lm is not None and lt > lm:
                bad.append(f"{m}:{line} ({LAYERS[lm][0]}) imports {target} ({LAYERS[lt][0]}, a higher layer)")
    return bad


def cycle(g):
    """One import cycle [m0, m1, ..., m0] among the modules, or None (depth-first search, iterative)."""
    succ = {m: sorted({t for _, t in e if t in g and t != m}) for m, e in g.items()}
    state = dict.fromkeys(g, 0)                 # 0 unseen, 1 on the current path, 2 done
    for root in sorted(g):
        if state[root]:
            continue
        path, stack = [root], [iter(succ[root])]
        state[root] = 1
        while stack:
            nxt = next(stack[-1], None)
            if nxt is None:
                state[path.pop()] = 2
                stack.pop()
            elif state[nxt] == 1:
                return path[path.index(nxt):] + [nxt]
            elif state[nxt] == 0:
                state[nxt] = 1
                path.append(nxt)
                stack.append(iter(succ[nxt]))
    return None


def test_every_module_is_in_a_layer():
    _, known = graph()
    assert len(known) > 40 and "manipdyn.simulation" in known
    assert [m for m in known if layer(m) is None] == []


def test_imports_point_down_the_layers():
    g, _ = graph()
    assert sum(map(len, g.values())) > 100          # the scan sees the imports (function-level ones too)
    assert any(t == "manipdyn.validation.zoo" for _, t in g["manipdyn.viz.geometry"])   # one inside a function
    assert layer_violations(g) == []


@pytest.mark.parametrize("low, high", [
    ("dynamics", ("constraints", "simulation", "examples", "validation", "bench", "viz", "cli")),
    ("constraints", ("simulation", "examples", "validation", "bench", "viz", "cli")),
    ("model", ("io", "dynamics", "constraints")), ("spatial", ("dynamics", "constraints")),
    ("io", ("dynamics", "constraints"))])
def test_named_layers_stay_below(low, high):
    # the rules of docs/design.md §2 spelled out, so that a change of LAYERS cannot quietly drop one
    names = [n for n, _ in LAYERS]
    assert all(names.index(low) < names.index(h) for h in high)
    g, _ = graph()
    bad = [(m, line, t) for m, e in g.items() if layer(m) == names.index(low)
           for line, t in e if layer(t) in {names.index(h) for h in high}]
    assert bad == []


def test_no_import_cycle():
    # validation/compare ↔ validation/closed once imported each other inside functions; the shared error
    # measure now lives in validation/measure.py, which both import at module level
    found = cycle(graph()[0])
    assert found is None, "import cycle: " + " → ".join(found)


def test_the_checks_catch_an_upward_import_and_a_cycle(tmp_path):
    # a scratch package: a function-level import from dynamics/ up into constraints/, and a ↔ b in validation/
    files = {"manipdyn/__init__.py": "", "manipdyn/dynamics/__init__.py": "", "manipdyn/constraints/__init__.py": "",
             "manipdyn/validation/__init__.py": "",
             "manipdyn/dynamics/integrate.py": "def f():\n    from ..constraints import project\n",
             "manipdyn/constraints/dynamics.py": "from ..dynamics.integrate import f\n",
             "manipdyn/validation/a.py": "from .b import x\n",
             "manipdyn/validation/b.py": "def x():\n    from . import a\n"}
    for rel, text in files.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(text)
    g, _ = graph(tmp_path / "manipdyn")
    assert g["manipdyn.dynamics.integrate"] == [(2, "manipdyn.constraints")]
    assert layer_violations(g) == ["manipdyn.dynamics.integrate:2 (dynamics) imports manipdyn.constraints "
                                   "(constraints, a higher layer)"]
    assert cycle(g) in (["manipdyn.validation.a", "manipdyn.validation.b", "manipdyn.validation.a"],
                        ["manipdyn.validation.b", "manipdyn.validation.a", "manipdyn.validation.b"])


ENGINE_MODULES = ("mujoco", "pybullet", "pybullet_data", "pydrake")
ENGINE_HOSTS = ("manipdyn.validation.adapters", "manipdyn.validation.referee_zoo")


def engine_imports(path):
    """[(line, module, at_top_level)] of every import of another engine (MuJoCo, PyBullet, Drake)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    top = {id(n) for n in tree.body}
    out = []
    for node in ast.walk(tree):
        names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
            [node.module or ""] if isinstance(node, ast.ImportFrom) else []
        out += [(node.lineno, n, id(node) in top) for n in names if n.split(".")[0] in ENGINE_MODULES]
    return out


def test_other_engines_are_imported_only_by_the_referee_and_lazily():
    # MuJoCo, PyBullet and Drake are optional (manipdyn[engines]): only validation/adapters.py and
    # validation/referee_zoo.py import them, inside functions (importlib.import_module counts as lazy)
    _, known = graph()
    found = {m: engine_imports(p) for m, p in known.items()}
    assert any(found[m] for m in ENGINE_HOSTS)                 # the scan sees them
    assert {m for m, e in found.items() if e} <= set(ENGINE_HOSTS)
    assert [(m, line, n) for m, e in found.items() for line, n, top in e if top] == []


# -- one kernel toolkit: algebra lives in spatial.py, algorithms borrow only algorithms ----------------------

ALGORITHMS = ("rnea", "crba", "aba", "lagrange", "coriolis", "kinematics", "energy", "derivatives", "regressor")
# What one algorithm module may take from another: an algorithm built on another one (the M⁻¹ route runs the
# CRBA and the Newton–Euler kernel, one state through their one-lane drivers; the derivatives differentiate the
# ABA, the regressor reads the RNEA's records, the Lagrange M sums the frame Jacobians) — never a helper of the
# algebra, which lives in spatial.py.
BORROWED = {"rnea": {"NT", "RECORD", "rnea", "rnea_lanes", "rnea_one", "rnea_steps_one", "steps_scratch",
                     "outward_one"},
            "crba": {"crba", "crba_lanes", "crba_steps_one", "mass_matrix"},
            "aba": {"ABA", "aba_steps_one"},
            "lagrange": {"lagrange_mass_matrix"},
            "kinematics": {"body_point", "point_jacobian", "point_jacobian_dot", "point_velocity", "com_jacobians",
                           "supports"}}


def toolkit():
    """Names of the compiled functions spatial.py defines (the kernel toolkit)."""
    tree = ast.parse((PKG / "spatial.py").read_text(encoding="utf-8"))
    return {f.name for f in tree.body if isinstance(f, ast.FunctionDef) and f.decorator_list}


def borrowed_helpers(pkg=PKG):
    """'file:line imports NAME from ALGORITHM' for every name taken from an algorithm module that is not in
    BORROWED, and 'file:line defines NAME' for every toolkit name defined outside spatial.py."""
    tools, out = toolkit(), []
    for path in sorted(pkg.rglob("*.py")):
        if path.name in ("spatial.py", "__init__.py"):       # the toolkit itself; re-exports
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        rel = path.relative_to(pkg.parent)
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef) and node.name in tools:
                out.append(f"{rel}:{node.lineno} defines {node.name} (spatial.py's)")
            if isinstance(node, ast.ImportFrom) and node.module:
                src = node.module.split(".")[-1]
                in_dynamics = node.module.startswith(("dynamics.", "manipdyn.dynamics.")) or \
                    (node.level == 1 and path.parent.name == "dynamics")
                if src in ALGORITHMS and in_dynamics:
                    out += [f"{rel}:{node.lineno} imports {a.name} from {src}" for a in node.names
                            if a.name not in BORROWED.get(src, set()) and path.parent.name in ("dynamics", "constraints")
                            and path.stem != src]
    return out


def test_algebra_is_written_once_and_no_algorithm_borrows_helpers():
    assert {"cross", "rot_t", "motion_cross", "force_cross", "dot6", "rigid_inertia", "first_nonfinite"} <= toolkit()
    assert borrowed_helpers() == []


def test_the_toolkit_check_bites(tmp_path):
    pkg = tmp_path / "manipdyn"
    (pkg / "dynamics").mkdir(parents=True)
    (pkg / "spatial.py").write_text((PKG / "spatial.py").read_text(encoding="utf-8"))
    (pkg / "dynamics" / "coriolis.py").write_text("from .aba import cholesky_kernel\n\n\ndef dot6(a, b):\n    pass\n")
    assert borrowed_helpers(pkg) == ["manipdyn/dynamics/coriolis.py:1 imports cholesky_kernel from aba",
                                     "manipdyn/dynamics/coriolis.py:4 defines dot6 (spatial.py's)"]
