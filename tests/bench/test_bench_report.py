"""The bench is not a test: this only checks that `manipdyn bench --quick` runs and writes a valid report."""
import json

from manipdyn.bench import targets
from manipdyn.cli import main


def test_bench_quick_writes_a_valid_report(tmp_path, monkeypatch):
    from manipdyn.bench import sections
    monkeypatch.setattr(sections, "per_call", lambda f, repeat=1, min_time=0: (f(), 1e-6)[1])  # no timing loops
    monkeypatch.setattr(sections, "per_call_pair", lambda f, g, repeat=1, min_time=0: (f(), g(), 1e-6, 1e-6)[2:])
    assert main(["bench", "--quick", "--out", str(tmp_path)]) == 0
    data = json.loads((tmp_path / "report.json").read_text())
    for key in ("machine", "latency", "closed_latency", "batched", "floating", "floors", "throughput", "scaling", "slopes", "reduced",
                "work_precision", "spm_drift", "hard_cases", "cold_start", "targets"):
        assert data[key], key
    assert all(r["err"] <= 1e-12 for r in data["latency"])      # errors are measured, not assumed
    # every public call on a batch, on the three robots, none refused; errors measured 4.9e-13 at worst (aau aba)
    assert {(r["robot"], r["call"]) for r in data["batched"]} == {
        (rob, c) for rob in ("ur5", "aau_arm", "chain32") for c in targets.SINGLE_CALLS + targets.LAGRANGE}
    assert all("refused" not in r and r["err"] <= 1e-12 for r in data["batched"])
    # the floating bases: the lane calls at N = 10 000 on free flyers and the ball-jointed humanoid, none refused;
    # errors measured ≤ 2.7e-12 (q̈ of talos_reduced's aba, divided by nothing: the batched err column's measure)
    assert {(r["robot"], r["call"]) for r in data["floating"]} == {
        (rob, c) for rob in ("ur5 (free flyer)", "solo12", "talos_reduced", "humanoid_ball (MJCF)")
        for c in ("rnea", "aba", "mass_matrix (crba)")}
    assert all("refused" not in r and r["N"] == 10_000 and r["err"] <= 1e-11 for r in data["floating"])
    assert {r["robot"] for r in data["latency"]} == {"ur5", "aau_arm", "chain32", "spm (open tree)"}
    # the lane kernels' work–precision rows: against the one-state kernel within the batch-vs-single bound (1e-14;
    # measured p95 ≤ 5.4e-15, the chain's q̈), against Pinocchio within the batched err column's 1e-12 (≤ 3.5e-13)
    wp = [r for r in data["batched"] if "err_one_median" in r]
    assert {(r["robot"], r["call"]) for r in wp} == {
        (rob, c) for rob in ("ur5", "aau_arm", "chain32") for c in ("rnea", "aba", "mass_matrix (crba)")}
    assert all(r["err_one_p95"] <= 1e-14 and r["err_pin_p95"] <= 1e-12 and r["wp_states"] == 20 for r in wp)
    # the lane kernels' flop counts, beside their batched rows at N = 10 000 (the timings here are stand-ins)
    assert {(r["robot"], r["call"]) for r in data["floors"] if "over_floor" in r} == {
        (rob, c) for rob in ("ur5", "aau_arm", "chain32") for c in ("rnea", "aba", "mass_matrix (crba)")}
    # the targets find their rows and figures in a real report: each counted target reads rows, none is
    # "not measured"; the hard cases are distributions over 12 states (quick)
    results = targets.evaluate(data)
    assert all(r.rows > 0 for r in results if not r.target.optional)
    assert not [m for m in targets.check(data) if m.measured is None]
    assert {r["states"] for r in data["hard_cases"]} == {12}
    assert main(["bench", "--check", "--from", str(tmp_path / "report.json")]) in (0, 1)
    assert data["closed_latency"][0]["err"] <= 1e-10
    assert data["cold_start"]["measured"], data["cold_start"]      # quick: the first calls from the package's cache
    text = (tmp_path / "report.md").read_text()
    assert "ratio" in text and "pin" in data["machine"]["versions"]
    assert "## Targets" in text and "## What to use when" in text and "**One state or many.**" in text
    assert (tmp_path / "scaling.png").stat().st_size > 1000
    assert (tmp_path / "work_precision.png").stat().st_size > 1000
    assert all(r["max_phi"] < 1e-6 for r in data["spm_drift"])
