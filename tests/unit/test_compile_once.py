"""Every kernel is compiled once: one list of argument types per kernel, whichever public call reaches it
(docs/design.md §2: one compiled body per kernel). A second signature would be a second compile of the same
code — the first compile's cost paid twice, in ``manipdyn warmup`` and in a user's first calls."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

from manipdyn import _jit

PROBE = """
import json, sys
sys.path.insert(0, {here!r})
from test_warmup import kernels          # every compiled kernel of the kernel sources
from manipdyn.warmup import first_calls
first_calls()
print(json.dumps({{name: [str(s) for s in d.signatures] for name, d in kernels().items()}}))
"""


@pytest.mark.skipif(_jit.NOJIT, reason="the kernels run uncompiled")
def test_every_public_call_reaches_kernels_compiled_for_one_signature():
    probe = PROBE.format(here=str(Path(__file__).parent))
    r = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=1800)
    assert r.returncode == 0, r.stderr[-2000:]
    sigs = json.loads(r.stdout.strip().splitlines()[-1])
    assert len(sigs) >= 30                                   # the probe saw the kernels
    assert sum(bool(v) for v in sigs.values()) >= 20         # and the calls compiled (or loaded) them
    twice = {k: v for k, v in sigs.items() if len(v) > 1}
    assert twice == {}, f"kernels compiled for more than one list of argument types: {twice}"
