"""Say when a call compiles: the first compile of a manipdyn kernel in a process is announced once, on the
``manipdyn`` logger.

Every kernel is compiled for this machine on its first call and cached on disk (``_jit``): a fresh install's
first calls take seconds to half a minute each, silently unless told. The first time a process compiles one of
manipdyn's kernels (a cache miss; a kernel loaded from the cache says nothing), the ``manipdyn`` logger warns
once, naming the kernel, about how long a compile takes, and ``manipdyn warmup``, which compiles them all ahead
of use:

    manipdyn: compiling the kernel aba_steps_one (manipdyn/dynamics/aba.py) for this machine, once: a kernel's
    first call compiles it (seconds to half a minute each, cached on disk afterwards); `manipdyn warmup` compiles
    every kernel ahead of use

Python's logging convention for libraries: without a handler of the application's, a warning reaches stderr as
that one line; ``logging.getLogger("manipdyn").setLevel(logging.ERROR)`` silences it, and each finished compile
is logged at INFO ("compiled aba_steps_one in 21.8 s"). ``manipdyn warmup``'s workers are silent
(MANIPDYN_COMPILE_NOTICE=0): warmup shows its own progress.
"""
from __future__ import annotations

import logging
import os
import time

from numba.core import event

LOG = logging.getLogger("manipdyn")
PACKAGE = __name__.split(".")[0]


class Notice(event.Listener):
    """numba's compile events for manipdyn's kernels: the first one announced (``said``), each outermost compile
    timed. Compiles run one at a time (numba's compiler lock), so one depth counter serves every thread."""

    def __init__(self):
        self.said, self.depth, self.started = False, 0, 0.0

    @staticmethod
    def _ours(ev):
        func = getattr(ev.data.get("dispatcher"), "py_func", None)
        return func is not None and (getattr(func, "__module__", "") or "").split(".")[0] == PACKAGE, func

    def on_start(self, ev):
        ours, func = self._ours(ev)
        if not ours:
            return
        if self.depth == 0:
            self.started = time.perf_counter()
            if not self.said and os.environ.get("MANIPDYN_COMPILE_NOTICE", "1") != "0":
                self.said = True
                where = func.__module__.replace(".", "/") + ".py"
                LOG.warning(f"manipdyn: compiling the kernel {func.__name__} ({where}) for this machine, once: a "
                            f"kernel's first call compiles it (seconds to half a minute each, cached on disk "
                            f"afterwards); `manipdyn warmup` compiles every kernel ahead of use")
        self.depth += 1

    def on_end(self, ev):
        ours, func = self._ours(ev)
        if not ours:
            return
        self.depth -= 1
        if self.depth == 0:
            LOG.info(f"compiled {func.__name__} in {time.perf_counter() - self.started:.1f} s")


NOTICE = Notice()
event.register("numba:compile", NOTICE)
