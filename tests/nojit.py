"""One harness for the crosschecks' "the source run uncompiled gives the compiled numbers" tests.

A probe is a script template (``{tests}``, ``{here}``, ``{names}`` filled in) that prints one JSON object
whose "nojit" entry is ``manipdyn._jit.NOJIT`` and whose other entries, one per case name, are lists of
results. It runs in two fresh interpreters, with and without MANIPDYN_NOJIT=1 (numba decides at import).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from conftest import ROOT, err


def run_probe(template, here, names, nojit, timeout=1800):
    """The probe's JSON output, run compiled (nojit False) or as plain Python (nojit True)."""
    env = {k: x for k, x in os.environ.items() if not k.startswith("MANIPDYN_")}
    env.update(PYTHONPATH=str(ROOT), **({"MANIPDYN_NOJIT": "1"} if nojit else {}))
    code = template.format(tests=str(ROOT / "tests"), here=str(Path(here).parent), names=names)
    run = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True, text=True,
                         timeout=timeout, check=False)
    assert run.returncode == 0, run.stderr[-3000:]
    return json.loads(run.stdout.splitlines()[-1])


def assert_uncompiled_equals_compiled(template, here, names, tol=1e-14):
    """Every result of every case agrees between the two runs to ``tol`` in the §3 error measure (a number, or one
    per result of a case)."""
    plain, compiled = run_probe(template, here, names, True), run_probe(template, here, names, False)
    assert plain["nojit"] and not compiled["nojit"]            # the switch really took effect in each run
    for name in names:
        assert len(plain[name]) == len(compiled[name]), name
        for k, (x, y) in enumerate(zip(plain[name], compiled[name])):
            assert err(np.array(x), np.array(y)) <= (tol[k] if isinstance(tol, (list, tuple)) else tol), (name, k)
