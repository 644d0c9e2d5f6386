"""A call that compiles says so once: the first compile (a disk-cache miss) of a manipdyn kernel in a process
warns on the "manipdyn" logger, naming the kernel and ``manipdyn warmup``; a kernel loaded from the cache says
nothing; the logger's level silences it; each compile is logged at INFO with its time (compile_notice.py)."""
import os
import re
import subprocess
import sys

import pytest

from conftest import AAU

from manipdyn import _jit

CODE = """
import logging
import numpy as np
{setup}
import manipdyn as md
m = md.load_urdf({aau!r})
q = md.neutral(m)
md.difference(m, q, q)                        # two kernels compile (difference_one, integrate_one: the one-state
                                              # forms, each compiling its batch kernel within)
md.integrate(m, q, np.zeros(m.nv))
"""
NOTICE = ("manipdyn: compiling the kernel difference_one (manipdyn/joints.py) for this machine, once: a kernel's "
          "first call compiles it (seconds to half a minute each, cached on disk afterwards); `manipdyn warmup` "
          "compiles every kernel ahead of use")
pytestmark = pytest.mark.skipif(_jit.NOJIT, reason="the kernels run uncompiled: nothing compiles")


def stderr_lines(cache, setup=""):
    """A fresh process's stderr lines after two kernels' first calls, with its disk cache in ``cache``."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    env.pop("MANIPDYN_COMPILE_NOTICE", None)
    r = subprocess.run([sys.executable, "-c", CODE.format(setup=setup, aau=str(AAU))], env=env, capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    return r.stderr.strip().splitlines()


def test_a_first_compile_says_so_once_and_a_cached_kernel_is_silent(tmp_path):
    assert stderr_lines(tmp_path) == [NOTICE]            # two kernels compile, one line
    assert stderr_lines(tmp_path) == []                  # both loaded from the cache


def test_the_notice_follows_the_logger(tmp_path):
    assert stderr_lines(tmp_path / "a", 'logging.getLogger("manipdyn").setLevel(logging.ERROR)') == []
    lines = stderr_lines(tmp_path / "b", 'logging.basicConfig(level=logging.INFO, format="%(message)s")')
    assert lines[0] == NOTICE and len(lines) == 3
    assert [re.fullmatch(r"compiled (\w+) in \d+\.\d s", x).group(1) for x in lines[1:]] == \
        ["difference_one", "integrate_one"]
