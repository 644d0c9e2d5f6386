"""`manipdyn bench`: speed against error, side by side with Pinocchio, as Markdown + JSON + PNG plots."""
from __future__ import annotations

import json
import time
from pathlib import Path

from ..paths import bundled_dir
from ..validation.zoo import robots_dir
from . import sections
from .timing import machine

ROOT = bundled_dir().parent


def write(data, out_dir):
    """report.json, the plots and report.md from the collected data."""
    out = Path(out_dir)
    (out / "report.json").write_text(json.dumps(data, indent=1))
    plots(data, out)
    (out / "report.md").write_text(markdown(data))


def run(out_dir, quick=False, progress=print) -> dict:
    """Run every section and write report.md, report.json and the plots into out_dir."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ur5 = robots_dir() / "ur_description/urdf/ur5_robot.urdf"
    arms = [ur5] + [p for p in (ROOT / "urdf" / "aau_arm.urdf",) if p.is_file()]
    data = dict(machine=machine(), date=time.strftime("%Y-%m-%d %H:%M"), quick=quick, seed=0)
    steps = [
        ("latency", lambda: sections.latency(arms, quick)),
        ("closed_latency", lambda: sections.closed_latency(ROOT / "urdf" / "spm.urdf", quick)),
        ("throughput", lambda: sections.throughput(arms, (1, 100, 10_000) if quick else (1, 100, 10_000, 100_000), quick)),
        ("scaling", lambda: sections.scaling((2, 4, 8, 16, 32) if quick else (2, 4, 8, 16, 32, 64), quick)),
        ("work_precision", lambda: sections.work_precision(ROOT / "urdf" / "aau_arm.urdf", quick)),
        ("spm_drift", lambda: sections.spm_drift(ROOT / "urdf" / "spm.urdf", quick)),
        ("hard_cases", lambda: hard_cases(quick)),
        ("reduced", lambda: sections.reduced(robots_dir() / "baxter_description/urdf/baxter.urdf",
                                             dict(root="torso", tips=["left_gripper"]), quick)),
    ]
    for name, f in steps:
        t0 = time.perf_counter()
        data[name] = f()
        progress(f"bench: {name} done in {time.perf_counter() - t0:.1f} s")
    data["slopes"] = sections.slopes(data["scaling"])
    data["cost_at_error"] = sections.cost_at_error(data["work_precision"])
    write(data, out)
    return data


def hard_cases(quick):
    """Ill-conditioned chains against the 50-digit reference: q̈ error of each forward-dynamics route."""
    from .hard import ill_conditioned
    rows = []
    for label, kw in (("uniform masses", dict(spread=(1.0, 1.0))),
                      ("1e3 kg root … 1e-6 kg tip", dict(n=8, lengths=(0.001, 0.5))),
                      ("1e-6 kg root … 1e3 kg tip", dict(n=8, light_root=True, lengths=(0.001, 0.5)))):
        for r in ill_conditioned(states=2 if quick else 6, **kw):
            rows.append({"case": label, "cond(M)": f"{r['cond_M']:.1e}", "ABA": f"{r['aba']:.1e}",
                         "Cholesky (M⁻¹)": f"{r['cholesky']:.1e}", "Pinocchio aba": f"{r['pinocchio']:.1e}"})
    return rows


def _table(rows, cols, fmt):
    head = "| " + " | ".join(cols) + " |\n|" + "---|" * len(cols) + "\n"
    cell = lambda r, c: "–" if c not in r else fmt.get(c, "{}").format(r[c])  # noqa: E731
    return head + "".join("| " + " | ".join(cell(r, c) for c in cols) + " |\n" for r in rows)


def markdown(d) -> str:
    """The report text: header (machine, versions), then one table per section."""
    m = d["machine"]
    us, x, e = "{:.2f}", "{:.2f}×", "{:.1e}"
    s = [f"# manipdyn bench report\n\n{d['date']} · {m['cpu']} · {m['cores']} cores · Python {m['python']} · "
         + " · ".join(f"{k} {v}" for k, v in m["versions"].items()) + f" · seed {d['seed']}"
         + (" · **quick run**" if d["quick"] else "") + "\n\nEvery ratio is ours ÷ Pinocchio, both measured in "
         "this run; errors use err = max|x − y| / max(max|y|, 1) against Pinocchio on the same states.\n",
         "## a. Single-state latency (public, input-checked calls)\n",
         _table(d["latency"] + d["closed_latency"], ["robot", "call", "ours_us", "pin_us", "ratio", "err"],
                dict(ours_us=us, pin_us=us, ratio=x, err=e)),
         "\n## b. Batched throughput (µs per state)\n",
         _table(d["throughput"], ["robot", "call", "N", "ours_us", "pin_loop_us", "pin_par1_us", "pin_par_all_us",
                                  "ratio_par1", "ratio_loop"],
                dict(ours_us="{:.3f}", pin_loop_us="{:.3f}", pin_par1_us="{:.3f}", pin_par_all_us="{:.3f}",
                     ratio_par1=x, ratio_loop=x)),
         "\n## c. Scaling on random serial chains\n\n![scaling](scaling.png)\n\n",
         _table(d["scaling"], ["n", "call", "ours_us", "pin_us", "ratio"], dict(ours_us=us, pin_us=us, ratio=x)),
         "\nFitted log-log slopes (time ∝ n^slope):\n\n",
         _table([dict(call=k, **v) for k, v in d["slopes"].items()], ["call", "ours", "pin"],
                dict(ours="{:.2f}", pin="{:.2f}")),
         "\n## Reduced models (baxter, one arm: root torso, tip left_gripper)\n\n",
         _table(d["reduced"], ["model", "nv", "load_ms", "rnea_us", "aba_us", "rnea_batch_us"],
                dict(load_ms="{:.1f}", rnea_us=us, aba_us=us, rnea_batch_us="{:.3f}"))]
    s += ["\n## d. Work–precision of forward simulation (AAU arm)\n\n![work-precision](work_precision.png)\n\n"
          "Time to a final-state error of 1e-8, interpolated on log axes:\n\n",
          _table(d["cost_at_error"], ["gravity", "method", "who", "seconds_at_1e_8"], dict(seconds_at_1e_8="{:.4f}")),
          "\n", _table(d["work_precision"], ["gravity", "method", "dt", "who", "seconds", "error"],
                        dict(seconds="{:.4f}", error="{:.1e}")),
          "\n## e. SPM: cost per step and constraint drift (PD-held actuators, RK4, dt 0.5 ms)\n\n",
          _table(d["spm_drift"], ["stabilization", "horizon_s", "us_per_step", "max_phi", "final_phi"],
                 dict(us_per_step="{:.1f}", max_phi="{:.1e}", final_phi="{:.1e}"))]
    if "hard_cases" in d:
        s.append("\n## Hard cases: q̈ error against a 50-digit reference (mpmath)\n\n"
                 + _table(d["hard_cases"], list(d["hard_cases"][0]), {}))
    if "hard_cases" in d:
        s.append("\nTrust the recursive ABA on ill-conditioned chains: it never forms M, and its error stays"
                 " far below the Cholesky (M⁻¹) route's, which grows like eps · cond(M).\n")
    return "".join(s)


def plots(d, out):
    """scaling.png: time per call against n on log axes, ours solid, Pinocchio dashed."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for call in sorted({r["call"] for r in d["scaling"]}):
        rows = [r for r in d["scaling"] if r["call"] == call]
        n = [r["n"] for r in rows]
        line, = ax.loglog(n, [r["ours_us"] for r in rows], "o-", label=f"{call} (ours)")
        if "lagrange" not in call:
            ax.loglog(n, [r["pin_us"] for r in rows], "x--", color=line.get_color(), label=f"{call} (Pinocchio)")
    _finish(plt, fig, ax, out / "scaling.png", "Scaling on random serial chains", "joints n", "time per call [µs]")
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for key in sorted({(r["gravity"], r["method"], r["who"]) for r in d["work_precision"]}):
        rows = sorted((r for r in d["work_precision"] if (r["gravity"], r["method"], r["who"]) == key),
                      key=lambda r: r["error"])
        ax.loglog([r["error"] for r in rows], [r["seconds"] for r in rows],
                  "o-" if key[2].startswith("manipdyn") else "x--", label=f"{key[1]}, gravity {key[0]}, {key[2]}")
    _finish(plt, fig, ax, out / "work_precision.png", "Work–precision, AAU arm",
            "final-state error vs adaptive reference (rtol 1e-13)", "wall time [s]")


def _finish(plt, fig, ax, path, title, xlabel, ylabel):
    """Labels, legend, grid, and the PNG."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
