"""`manipdyn bench`: speed against error, side by side with Pinocchio, as Markdown + JSON + PNG plots."""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from ..extras import require
from ..paths import bundled_dir
from ..validation.zoo import robots_dir
from . import sections, targets
from .timing import machine

ROOT = bundled_dir().parent
NEEDS = (("pinocchio", "validate"), ("mpmath", "validate"), ("matplotlib", "plots"))   # (module, its extra)


def write(data, out_dir):
    """report.json, the plots and report.md from the collected data."""
    out = Path(out_dir)
    (out / "report.json").write_text(json.dumps(data, indent=1))
    plots(data, out)
    (out / "report.md").write_text(markdown(data))


def run(out_dir, quick=False, progress=print) -> dict:
    """Run every section and write report.md, report.json and the plots into out_dir."""
    for module, extra in NEEDS:           # before any section runs: a missing extra is named at once
        require(module, extra, "manipdyn bench")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ur5 = robots_dir() / "ur_description/urdf/ur5_robot.urdf"
    spm = ROOT / "urdf" / "spm.urdf"
    arms = [ur5] + [p for p in (ROOT / "urdf" / "aau_arm.urdf",) if p.is_file()]
    data = dict(machine=machine(), date=time.strftime("%Y-%m-%d %H:%M"), quick=quick, seed=0, section_seconds={})
    robots = {}

    def sts(*keys):        # the robots, loaded once: ur5 + AAU arm ("arms"), the 32-link chain, the SPM's tree
        if not robots:
            robots.update(arms=sections.setups(arms), chain=sections.setups(chain=32),
                          spm=sections.setups(open_trees=[spm] if spm.is_file() else []),
                          floating=sections.floating_setups([robots_dir() / p for p in FLOATING_URDF],
                                                            [p for p in FLOATING_MJCF if p.is_file()]))
        return [s for k in keys for s in robots[k]]

    steps = [
        ("latency", lambda: sections.latency(sts("arms", "chain", "spm"), quick)),
        ("closed_latency", lambda: sections.closed_latency(spm, quick)),
        ("one_state", lambda: sections.one_state(sts("arms", "floating"), quick)),
        ("batched", lambda: sections.batched(sts("arms", "chain"), quick)),
        ("floating", lambda: sections.floating(sts("floating"), quick)),
        ("floors", lambda: sections.floors(data["batched"], {"ur5": ur5, "aau_arm": ROOT / "urdf" / "aau_arm.urdf",
                                                             "chain32": "chain:32"})),
        ("throughput", lambda: sections.throughput(arms, (1, 100, 10_000) if quick else (1, 100, 10_000, 100_000), quick)),
        ("scaling", lambda: sections.scaling((2, 4, 8, 16, 32) if quick else (2, 4, 8, 16, 32, 64), quick)),
        ("work_precision", lambda: sections.work_precision(ROOT / "urdf" / "aau_arm.urdf", quick)),
        ("spm_drift", lambda: sections.spm_drift(spm, quick)),
        ("hard_cases", lambda: hard_cases(quick)),
        ("reduced", lambda: sections.reduced(robots_dir() / "baxter_description/urdf/baxter.urdf",
                                             dict(root="torso", tips=["left_gripper"]), quick)),
        ("cold_start", lambda: cold_start(quick)),
    ]
    for name, f in steps:
        t0 = time.perf_counter()
        data[name] = f()
        data["section_seconds"][name] = time.perf_counter() - t0
        progress(f"bench: {name} done in {data['section_seconds'][name]:.1f} s")
    data["slopes"] = sections.slopes(data["scaling"])
    data["cost_at_error"] = sections.cost_at_error(data["work_precision"])
    data["targets"] = [r.as_dict() for r in targets.evaluate(data)]
    write(data, out)
    return data


# the floating section's robots: free-flyer roots on example-robot-data's ur5, solo12 and talos_reduced (a humanoid,
# nv = 38), and the bundled ball-jointed MJCF humanoid (tests/data: gymnasium's humanoid, hips and shoulders as balls)
FLOATING_URDF = ("ur_description/urdf/ur5_robot.urdf", "solo_description/robots/solo12.urdf",
                 "talos_data/robots/talos_reduced.urdf")       # in example-robot-data's robots folder
FLOATING_MJCF = (ROOT / "tests" / "data" / "humanoid_ball.xml",)

# (our route, its key, Pinocchio's same route's key): each of ours is held to Pinocchio's same algorithm
HARD_ROUTES = (("ABA", "aba", "pinocchio"), ("ABA, batched (lanes)", "aba_lanes", "pinocchio"),
               ("Cholesky (M⁻¹)", "cholesky", "pinocchio_cholesky"),
               ("Pinocchio aba", "pinocchio", None), ("Pinocchio crba + Cholesky", "pinocchio_cholesky", None))
EPS = float(np.finfo(float).eps)


def hard_cases(quick):
    """Ill-conditioned chains against the 50-digit reference: per case and route, the median and the 95th
    percentile of the q̈ error over random states, and ours ÷ Pinocchio's same route for both (errors floored
    at machine epsilon, so that an exact result never divides by zero)."""
    from .hard import ill_conditioned
    rows = []
    for label, kw in (("uniform masses", dict(spread=(1.0, 1.0))),
                      ("1e3 kg root … 1e-6 kg tip", dict(n=8, lengths=(0.001, 0.5))),
                      ("1e-6 kg root … 1e3 kg tip", dict(n=8, light_root=True, lengths=(0.001, 0.5)))):
        t0 = time.perf_counter()
        states = ill_conditioned(states=12 if quick else 60, **kw)
        seconds = time.perf_counter() - t0
        cond = np.array([r["cond_M"] for r in states])
        stats = {key: (float(np.median(e)), float(np.percentile(e, 95)))
                 for key, e in ((k, np.array([r[k] for r in states])) for _, k, _ in HARD_ROUTES)}
        for route, key, theirs in HARD_ROUTES:
            med, p95 = stats[key]
            row = dict(case=label, n=states[0]["n"], states=len(states), cond_median=float(np.median(cond)),
                       cond_max=float(cond.max()), route=route, median=med, p95=p95, seconds=seconds)
            if theirs is not None:
                pin_med, pin_p95 = (max(x, EPS) for x in stats[theirs])
                row.update(against=[r for r, k, _ in HARD_ROUTES if k == theirs][0],
                           ratio_median=max(med, EPS) / pin_med, ratio_p95=max(p95, EPS) / pin_p95)
            rows.append(row)
    return rows


def cold_start(quick=False):
    """Cold start (import and first calls in a fresh process, after ``manipdyn warmup`` into an empty cache;
    quick: the first calls only, against the package's own cache), from manipdyn.warmup when it exists."""
    try:
        from ..warmup import cold_start as measure
    except ImportError:
        return dict(measured=False, note="not measured (manipdyn.warmup is not in this build)")
    try:
        r = dict(measure(compile_too=not quick))
    except Exception as exc:     # another module's failure is shown in the report, not fatal to the bench
        return dict(measured=False, note=f"not measured ({type(exc).__name__}: {exc})")
    if "total_s" not in r:
        first = r.get("first_calls_s", 0.0)
        first = sum(first.values()) if isinstance(first, dict) else first
        r["total_s"] = float(r.get("import_s", 0.0)) + float(first)
    r["measured"] = True
    return r


def _table(rows, cols, fmt):
    head = "| " + " | ".join(cols) + " |\n|" + "---|" * len(cols) + "\n"
    cell = lambda r, c: "–" if c not in r else fmt.get(c, "{}").format(r[c])  # noqa: E731
    return head + "".join("| " + " | ".join(cell(r, c) for c in cols) + " |\n" for r in rows)


def markdown(d) -> str:
    """The report text: header (machine, versions), targets, what to use when, then one table per section."""
    m = d["machine"]
    us, x, e = "{:.2f}", "{:.2f}×", "{:.1e}"
    results = targets.evaluate(d)
    s = [f"# manipdyn bench report\n\n{d['date']} · {m['cpu']} · {m['cores']} cores · Python {m['python']} · "
         + " · ".join(f"{k} {v}" for k, v in m["versions"].items()) + f" · seed {d['seed']}"
         + (" · **quick run**" if d["quick"] else "") + "\n\nEvery ratio is ours ÷ Pinocchio, both measured in "
         "this run; errors use err = max|x − y| / max(max|y|, 1) against Pinocchio on the same states.\n",
         "\n## Targets\n\nThe issue's targets (manipdyn/bench/targets.py), checked on this report's rows "
         "(`manipdyn bench --check --from report.json`); the worst figure of each, and where it is:\n\n",
         targets.markdown(results),
         f"\n{sum(r.met and r.measured for r in results)} of "
         f"{sum(r.measured or not r.target.optional for r in results)} targets met.\n",
         "\n## What to use when\n\n", advice(d),
         "\n## a. Single-state latency (public, input-checked calls)\n\nPinocchio's cheapest Python route to the "
         "same numbers (pin_route), its conversions (q order, per-joint fext) made outside the timing; err is "
         "the worst over the states (a solve's error is divided by cond(M): note). Both sides are timed as calls "
         "on prepared arrays; for rnea, aba and crba Pinocchio's figure is checked against a plain `timeit` of its "
         "call as a user writes it (`pin.rnea(model, data, q, v, a)`): pin_plain_us, and pin_deviation = "
         "|pin_us ÷ pin_plain_us − 1| (a target: ≤ 0.1).\n\n",
         _table(d["latency"] + d["closed_latency"],
                ["robot", "call", "ours_us", "pin_us", "ratio", "err", "note", "pin_route", "pin_plain_us",
                 "pin_deviation"],
                dict(ours_us=us, pin_us=us, ratio=x, err=e, pin_plain_us=us, pin_deviation="{:.3f}")),
         "\n### Configuration operations, and a step of a user's own compiled loop\n\nEach side a plain `timeit` "
         "of the call as a user writes it (`md.integrate(model, q0, v)` against `pin.integrate(pm, p0, v)`); the "
         "compiled loop's row: one `compiled.rnea` step of a `numba.njit` loop over 10⁴ states (docs/api/compiled.md) "
         "against one `pin.rnea(model, data, q, v, a)` from Python.\n\n",
         _table(d.get("one_state", []), ["robot", "call", "ours_us", "pin_us", "ratio", "err"],
                dict(ours_us=us, pin_us=us, ratio=x, err=e)),
         "\n## b. Batched calls: every public call on (N, nv), µs per state\n\nPinocchio's C++ batch "
         "(`*InParallel`, 1 thread) where it exists, else its Python loop over the same states (pin_route); err "
         "is the worst over 20 states spread through the batch. Both sides write into memory they were given or "
         "keep: Pinocchio's batch into its `out`, its loop into `data`; ours (ours_us) into an `out=` array "
         "(the calls that take one; dynamics/route.py). fresh_us: ours into a new array each call, whose pages "
         "the kernel zeroes at first touch (docs/bench/measurements.md).\n\n",
         _table(d["batched"], ["robot", "call", "N", "ours_us", "fresh_us", "pin_us", "pin_route", "ratio", "err",
                               "note"] + (["refused"] if any("refused" in r for r in d["batched"]) else []),
                dict(ours_us="{:.3f}", fresh_us="{:.3f}", pin_us="{:.3f}", ratio=x, err=e)),
         "\n### Floating bases and ball joints: the lane kernels, N = 10 000, µs per state\n\nFree-flyer roots and "
         "ball joints on the lanes (one thread), against Pinocchio's InParallel(1) (rnea, aba) or its crba loop; "
         "ours_us and fresh_us as in the table above.\n\n",
         _table(d.get("floating", []), ["robot", "call", "N", "ours_us", "fresh_us", "pin_us", "pin_route", "ratio",
                                        "err", "note"],
                dict(ours_us="{:.3f}", fresh_us="{:.3f}", pin_us="{:.3f}", ratio=x, err=e)),
         "\n### Work–precision of the lane kernels\n\nThe batched rows at N = 10 000 of the calls the lane kernels run: "
         "the median and 95th percentile of the error over states spread through the batch (wp_states), against "
         "Pinocchio (err_pin_…) and against the same call on one state, the scalar kernel (err_one_…); q̈ divided by "
         "cond(M) (note). The lane ABA on ill-conditioned chains: the hard cases (section f).\n\n",
         _table([r for r in d["batched"] if "err_one_median" in r], ["robot", "call", "wp_states", "err_pin_median",
                                                                      "err_pin_p95", "err_one_median", "err_one_p95",
                                                                      "note"],
                dict(err_pin_median=e, err_pin_p95=e, err_one_median=e, err_one_p95=e)),
         "\n### The lane kernels against their arithmetic floor\n\nflops: floating-point operations per state, "
         "counted by running the lane kernels on Flop numbers (manipdyn/bench/flops.py); floor_ns = flops ÷ (16 "
         "a cycle × the clock, ghz): every flop a fused multiply-add on two 256-bit units; ours_ns: the batched "
         "row at N = 10 000 above; over_floor = ours_ns ÷ floor_ns.\n\n",
         _table(d.get("floors", []), ["robot", "call", "flops", "ghz", "floor_ns", "ours_ns", "over_floor"],
                dict(flops="{:.0f}", ghz="{:.2f}", floor_ns="{:.1f}", ours_ns="{:.1f}", over_floor="{:.1f}×")),
         "\n### Throughput against N (rnea, aba, mass_matrix), one thread and every core\n\n"
         "ours_us on one thread (`threads=1`), ours_all_us on every core (`threads=None`, the default: "
         f"{d['throughput'][0].get('cores', '?') if d['throughput'] else '?'} here); all_over_one = ours_all_us ÷ "
         "ours_us; Pinocchio's InParallel on 1 thread and on every core (ratio_par1, ratio_par_all: ours ÷ "
         "theirs at the same thread count).\n\n",
         _table(d["throughput"], ["robot", "call", "N", "ours_us", "ours_all_us", "all_over_one", "pin_loop_us",
                                  "pin_par1_us", "pin_par_all_us", "ratio_par1", "ratio_par_all", "ratio_loop"],
                dict(ours_us="{:.3f}", ours_all_us="{:.3f}", all_over_one="{:.2f}", pin_loop_us="{:.3f}",
                     pin_par1_us="{:.3f}", pin_par_all_us="{:.3f}", ratio_par1=x, ratio_par_all=x, ratio_loop=x)),
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
    if d.get("hard_cases"):
        h = d["hard_cases"]
        s.append(f"\n## f. Hard cases: q̈ error against a 50-digit reference (mpmath)\n\nPlanar point-mass chains "
                 f"(bench/hard.py), {h[0]['states']} random states per case; median and 95th percentile of the error "
                 "of each route, and ours ÷ Pinocchio's same algorithm (`against`) for both (errors floored at machine "
                 "epsilon).\n\n"
                 + _table(h, ["case", "n", "states", "cond_median", "cond_max", "route", "median", "p95",
                              "against", "ratio_median", "ratio_p95"],
                          dict(cond_median=e, cond_max=e, median=e, p95=e, ratio_median="{:.2g}×", ratio_p95="{:.2g}×"))
                 + f"\nmpmath reference and the four routes: "
                 f"{sum({r['case']: r['seconds'] for r in h}.values()):.1f} s for the three cases.\n")
    c = d.get("cold_start", {})
    if c.get("measured") and "total_s" in c:
        text = (f"A fresh process: `import manipdyn` {c['import_s']:.2f} s, then the first call of every public "
                f"function ({c.get('calls', '?')} calls, one state and a batch each) {c['first_calls_s']:.2f} s: "
                f"**{c['total_s']:.2f} s** in all, the kernels loaded from the disk cache (slowest: "
                f"{c.get('slowest_call', '?')}).")
        if "warmup_s" in c:
            text += (f" Filling that cache from empty — `manipdyn warmup`, which the README's setup command runs "
                     f"once per install — took {c['warmup_s']:.0f} s on 2 worker processes.")
        else:
            text += " (Quick run: the compile into an empty cache was not measured.)"
    else:
        text = c.get("note", "not measured")
    s.append("\n## g. Cold start\n\n" + text + "\n")
    if d.get("section_seconds"):
        s.append("\nSections ran in " + ", ".join(f"{k} {v:.1f} s" for k, v in d["section_seconds"].items())
                 + ".\n")
    return "".join(s)


def _span(values, fmt="{:.2g}"):
    """'a' or 'a–b' for the smallest and largest of values."""
    lo, hi = min(values), max(values)
    return fmt.format(lo) if fmt.format(lo) == fmt.format(hi) else f"{fmt.format(lo)}–{fmt.format(hi)}"


def advice(d) -> str:
    """'What to use when', written from this report's numbers (no claim that the numbers could contradict)."""
    out = []
    lat = {(r["robot"], r["call"]): r for r in d.get("latency", [])}
    bat = {(r["robot"], r["call"], r["N"]): r for r in d.get("batched", []) if "ours_us" in r}
    one = [(rob, r) for (rob, call, N), r in bat.items() if call == "rnea" and N == 1000 and (rob, "rnea") in lat]
    if one:
        single = [lat[(rob, "rnea")]["ours_us"] for rob, _ in one]
        speedup = [lat[(rob, "rnea")]["ours_us"] / r["ours_us"] for rob, r in one]
        below = [r for r in bat.values() if r["ratio"] <= 1]
        out.append(f"- **One state or many.** One state: call with (nv,) arrays — rnea costs {_span(single)} µs "
                   f"({_span([lat[(rob, 'rnea')]['ratio'] for rob, _ in one])}× Pinocchio's Python call) on "
                   f"{', '.join(rob for rob, _ in one)}. Many states: pass one (N, nv) batch, never a Python loop — "
                   f"at N = 1000 rnea costs {_span([r['ours_us'] for _, r in one])} µs per state, "
                   f"{_span(speedup, '{:.0f}')}× less than one call at a time, and "
                   f"{_span([r['ratio'] for _, r in one])}× Pinocchio's rneaInParallel(1). Of the {len(bat)} batched "
                   f"rows, {len(below)} are at or below Pinocchio's cost per state.")
    pairs = [(lat[(rob, "forward_dynamics (cholesky)")]["ours_us"] / lat[(rob, "aba")]["ours_us"], rob)
             for rob, call in lat if call == "aba" and (rob, "forward_dynamics (cholesky)") in lat]
    hard = {(r["case"], r["route"]): r for r in d.get("hard_cases", [])}
    if pairs or hard:
        text = "- **Forward dynamics: ABA or Cholesky (M⁻¹).**"
        if pairs:
            r = [p for p, _ in pairs]
            word = ("slower on every robot here" if min(r) > 1 else "faster on every robot here" if max(r) < 1
                    else "faster on some robots here, slower on others")
            text += f" One state, the Cholesky route costs {_span(r)}× ABA's time ({word})."
        if hard:
            worst = max({c for c, _ in hard}, key=lambda c: hard[(c, "ABA")]["cond_median"])
            a, ch = hard[(worst, "ABA")], hard[(worst, "Cholesky (M⁻¹)")]
            p, pc = hard.get((worst, "Pinocchio aba")), hard.get((worst, "Pinocchio crba + Cholesky"))
            better = "ABA" if a["p95"] < ch["p95"] else "Cholesky (M⁻¹)"
            other = "Cholesky (M⁻¹)" if better == "ABA" else "ABA"
            text += (f" On the worst-conditioned hard case ({worst}, median cond(M) {a['cond_median']:.0e}) the q̈ "
                     f"error is {a['median']:.0e} median / {a['p95']:.0e} p95 with ABA and {ch['median']:.0e} / "
                     f"{ch['p95']:.0e} with Cholesky"
                     + (f" (Pinocchio's aba: {p['median']:.0e} / {p['p95']:.0e}" if p else "")
                     + (f"; its crba + Cholesky: {pc['median']:.0e} / {pc['p95']:.0e}" if p and pc else "")
                     + (")" if p else "")
                     + f": on ill-conditioned models use {better}"
                     + (", which never forms M." if better == "ABA" else f" ({other} loses accuracy here)."))
        out.append(text)
    crba = [(lat[(rob, "mass_matrix (lagrange)")]["ours_us"] / lat[(rob, "mass_matrix (crba)")]["ours_us"], rob)
            for rob, call in lat if call == "mass_matrix (crba)" and (rob, "mass_matrix (lagrange)") in lat]
    if crba:
        r = [p for p, _ in crba]
        out.append(f"- **Mass matrix.** method=\"lagrange\" (the chapter's Eq. 23) costs {_span(r)}× the default "
                   f"crba on {', '.join(rob for _, rob in crba)}: "
                   + ("use crba for speed, lagrange to read or cross-check." if min(r) > 1 else
                      "on some of these robots it is not slower, so pick either by the err column."))
    return "\n".join(out) + "\n" if out else "Not enough sections in this report to say.\n"


def plots(d, out):
    """scaling.png: time per call against n on log axes, ours solid, Pinocchio dashed."""
    matplotlib = require("matplotlib", "plots", "manipdyn bench (its plots)")
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
