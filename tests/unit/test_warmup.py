"""`manipdyn warmup` compiles what a user's first calls need: every kernel a public function reaches."""
import importlib

import numba
import pytest

from manipdyn import _jit, warmup
from manipdyn.cli import main

# kernels no public dynamics call reaches: the validation layer's and playback's helpers (they compile on
# their own first use, which is not a public function's first call)
NOT_PUBLIC = {"com_jacobians_kernel", "fk_kernel", "joint_placements_kernel"}
# kernels only other kernels call: their machine code is part of their callers', loaded from the cache with them
# (their own dispatcher then lists no signature)
CALLED_BY_KERNELS = {"closure_rows", "frame_one", "cholesky_states", "outward_lanes", "external_lanes",
                     "inward_lanes", "merge_lanes", "aba_steps_one", "slide_lanes",
                     "column_lanes", "velocity_lanes", "articulated_lanes", "inertia_up_lanes", "acceleration_lanes",
                     "articulated_multi_lanes", "acceleration_multi_lanes",
                     "outward_multi_lanes", "inward_multi_lanes", "velocity_multi_lanes",
                     "column_multi_lanes", "quat_composite_lanes",
                     "frame_kernel", "world_lanes", "world_multi_lanes", "jacobian_lanes", "local_lanes",
                     "rnea_steps_one", "crba_steps_one"}   # the one-state drivers of the lane steps


def kernels():
    """{name: dispatcher} of every compiled function defined in the kernel sources (inlined helpers aside:
    they have no machine code of their own)."""
    out = {}
    for rel in _jit.KERNEL_SOURCES:
        if rel == "_jit.py":
            continue
        mod = importlib.import_module("manipdyn." + rel[:-3].replace("/", "."))
        for name, obj in vars(mod).items():
            if isinstance(obj, numba.core.registry.CPUDispatcher) and obj.__module__ == mod.__name__ \
                    and obj.targetoptions.get("inline", "never") == "never":
                out[name] = obj
    return out


@pytest.mark.skipif(_jit.NOJIT, reason="the kernels run uncompiled")
def test_first_calls_compile_every_public_kernel():
    calls = warmup.first_calls()
    assert len(calls) >= 40 and all(t >= 0 for t in calls.values())
    missed = sorted(n for n, d in kernels().items() if not d.signatures and n not in NOT_PUBLIC | CALLED_BY_KERNELS)
    assert missed == []          # a kernel added without a warmup call fails here


def test_groups_cover_every_call_once():
    arm, closed = warmup._models()
    keys = [k for g in warmup.GROUPS for k in g]
    assert sorted(keys) == sorted(warmup._calls(arm, closed)) and len(keys) == len(set(keys))


@pytest.mark.parametrize("argv", [["warmup", "--jobs", "0"], ["warmup", "--jobs", "x"], ["warmup", "extra"]])
def test_cli_refuses_bad_jobs(argv, capsys):
    assert main(argv) == 2
    assert "Traceback" not in capsys.readouterr().err


def test_workers_report_each_call_and_a_stuck_one_is_killed():
    seen = []
    out = warmup._run_python("print('call 3', flush=True); print('call 3'); print('{\"x\": 1}')", on_line=seen.append)
    assert out == {"x": 1} and seen == [3, 3]
    with pytest.raises(RuntimeError, match="a fresh Python process failed: killed after 1 s"):
        warmup._run_python("import time; time.sleep(30)", timeout=1)


class _Bar:
    total, n, refreshed = None, 0, 0

    def update(self, k=1):
        self.n += k

    def refresh(self):
        self.refreshed += 1


def test_warmup_moves_a_bar_whose_total_comes_from_the_workers():
    from manipdyn.cli import _NoBar, _warmup_progress
    bar = _Bar()
    progress = _warmup_progress(bar)
    progress(1, 0, 0.5)                                  # one worker has reported: no total yet
    assert (bar.n, bar.total) == (1, None)
    for done in range(2, 9):
        progress(done, 8, done * 10.0)
    assert (bar.n, bar.total, bar.refreshed) == (8, 8, 1)
    _warmup_progress(_NoBar())(3, 8, 1.0)                # without tqdm: no bar, no error
