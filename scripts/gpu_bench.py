"""Time manipdyn.gpu on a GPU: states per second at N = 10⁶ for rnea, aba and mass_matrix on ur5 and the AAU arm,
the error against the CPU kernels on a sample of the states, and the device; writes gpu.md and gpu.json.

    python scripts/gpu_bench.py                       # on a machine with an NVIDIA GPU: docs/bench/gpu.md
    python scripts/gpu_bench.py --n 100000 --out /tmp/gpu

Targets (issue 29, float64 on one H100): rnea ≥ 2e8 states/s, aba ≥ 5e7. Each figure is the best of --repeat timed
calls after one untimed call (compilation), device arrays in and out, the clock stopped after
``cuda.synchronize()``. The error is the project's measure (docs/conventions.md) of 1000 states spread through the
batch against the CPU kernels (q̈ divided by cond(M)).
Exit code: 0 written (targets are reported, not enforced: another GPU is not an H100), 2 no GPU (or bad usage).
Under numba's simulator (NUMBA_ENABLE_CUDASIM=1, with MANIPDYN_NOJIT=1) it runs too, on small N, to test itself.
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import sys
import time
import warnings
from importlib import metadata
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
TARGETS = {"rnea": 2e8, "aba": 5e7}             # states/s, float64, one H100


def _err(x, y, scale=1.0):
    return float(np.max(np.abs(x - y)) / max(np.max(np.abs(y)), 1.0) / scale)


def measure(n, repeat, sample=1000):
    import manipdyn as md
    from manipdyn import gpu
    from manipdyn.validation import random_states
    from manipdyn.validation.zoo import robots_dir
    from numba import cuda
    robots = {"ur5": robots_dir() / "ur_description/urdf/ur5_robot.urdf", "aau_arm": ROOT / "urdf" / "aau_arm.urdf"}
    rows = []
    for label, path in robots.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = md.load_urdf(path)
        Q, V, A = random_states(model, n, np.random.default_rng(0))
        dQ, dV, dA = (cuda.to_device(x) for x in (Q, V, A))
        picks = np.unique(np.linspace(0, n - 1, min(sample, n)).astype(int))
        cond = np.linalg.cond(md.mass_matrix(model, Q[picks])).max()
        for call, run, cpu, scale in (
                ("rnea", lambda: gpu.rnea(model, dQ, dV, dA), lambda: md.rnea(model, Q[picks], V[picks], A[picks]),
                 1.0),
                ("aba", lambda: gpu.aba(model, dQ, dV, dA), lambda: md.aba(model, Q[picks], V[picks], A[picks]), cond),
                ("mass_matrix", lambda: gpu.mass_matrix(model, dQ), lambda: md.mass_matrix(model, Q[picks]), 1.0)):
            t0 = time.perf_counter()
            out = run()
            cuda.synchronize()
            first = time.perf_counter() - t0
            best = np.inf
            for _ in range(repeat):
                t0 = time.perf_counter()
                out = run()
                cuda.synchronize()
                best = min(best, time.perf_counter() - t0)
            err = _err(out.copy_to_host()[picks], cpu(), scale)
            rows.append(dict(robot=label, call=call, N=n, seconds=best, states_per_s=n / best, first_call_s=first,
                             err=err, err_note="÷ cond(M)" if call == "aba" else "",
                             target=TARGETS.get(call), met=(n / best >= TARGETS[call]) if call in TARGETS else None))
            print(f"{label:8s} {call:12s} {n / best:10.3g} states/s  err {err:.1e}  (first call {first:.1f} s)")
    return rows


def device():
    import os

    from numba import cuda
    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1":
        return "numba's CUDA simulator (no GPU: the figures are not timings)"
    d = cuda.get_current_device()
    name = d.name.decode() if isinstance(d.name, bytes) else str(d.name)
    return f"{name} (compute capability {d.compute_capability[0]}.{d.compute_capability[1]})"


def markdown(data):
    lines = [f"# GPU bench: manipdyn.gpu\n\nDevice: {data['device']}. Date: {data['date']}. "
             f"Versions: {', '.join(f'{k} {v}' for k, v in data['versions'].items())}.\n",
             "States per second at N = {:,} (the best of {} calls; device arrays in and out), error against the CPU "
             "kernels on {} states spread through the batch (the project's error measure; q̈ ÷ cond(M)). Targets "
             "(float64, one H100): rnea ≥ 2e8, aba ≥ 5e7 states/s. Written by `scripts/gpu_bench.py`.\n"
             .format(data["rows"][0]["N"] if data["rows"] else 0, data["repeat"], data["sample"]),
             "| robot | call | states/s | first call (s) | err | target | met |", "|---|---|---|---|---|---|---|"]
    for r in data["rows"]:
        lines.append(f"| {r['robot']} | {r['call']} | {r['states_per_s']:.3g} | {r['first_call_s']:.1f} | "
                     f"{r['err']:.1e} {r['err_note']} | {'' if r['target'] is None else format(r['target'], '.0e')} | "
                     f"{'' if r['met'] is None else ('met' if r['met'] else 'missed')} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1_000_000, help="states per batch (default 10⁶)")
    ap.add_argument("--repeat", type=int, default=5, help="timed calls per figure (default 5)")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "bench", help="folder for gpu.md and gpu.json")
    args = ap.parse_args(argv)
    if args.n < 1 or args.repeat < 1:
        print("gpu_bench: --n and --repeat must be positive", file=sys.stderr)
        return 2
    try:
        from numba import cuda
    except ImportError:
        print('gpu_bench: numba-cuda is not installed: pip install "manipdyn[gpu]"', file=sys.stderr)
        return 2
    if not cuda.is_available():
        print("gpu_bench: no CUDA GPU here (nothing written)", file=sys.stderr)
        return 2
    data = dict(device=device(), date=_dt.datetime.now().strftime("%Y-%m-%d %H:%M"), repeat=args.repeat,
                sample=min(1000, args.n),
                versions={p: metadata.version(p) for p in ("manipdyn", "numba", "numba-cuda")})
    data["rows"] = measure(args.n, args.repeat)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "gpu.json").write_text(json.dumps(data, indent=1))
    (args.out / "gpu.md").write_text(markdown(data))
    print(f"gpu_bench: wrote {args.out / 'gpu.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
