"""The issue's targets (manipdyn/bench/targets.py) on synthetic reports: a figure at its limit is met, just
above it is missed, a call without a row is missed, and `manipdyn bench --check --from` exits 0 / 1 / 2.
No timing here: the reports are made up, every figure chosen."""
import copy
import json

import pytest

from manipdyn.bench import targets
from manipdyn.bench.targets import (CONFIG_CALLS, HARD_ROUTES, LAGRANGE, NJIT_CALL, PLAIN_CHECKED, SINGLE_CALLS,
                                     TARGETS)
from manipdyn.cli import main
from manipdyn.errors import InputError


def report(at_limit=True):
    """A report whose every figure sits exactly at its target's limit (at_limit) or well below it."""
    f = (lambda limit: limit) if at_limit else (lambda limit: 0.25 * limit)
    latency = [dict(robot=rob, call=c, ratio=f(3.0)) for rob in ("ur5", "chain32") for c in SINGLE_CALLS]
    for r in latency:                                   # Pinocchio's figure against a plain timeit of its call
        if r["call"] in PLAIN_CHECKED:
            r["pin_deviation"] = f(0.1)
    latency += [dict(robot=rob, call=LAGRANGE[0], ratio=f(20.0)) for rob in ("ur5", "chain32")]
    lane = {"rnea": 0.1, "aba": 0.25, "mass_matrix (crba)": 0.25}     # the lane kernels' targets at N = 10 000
    batched = [dict(robot=rob, call=c, N=10_000, pin_route="loop" if c.startswith("mass") else "InParallel(1)",
                    ratio=f(0.5 if rob == "chain32" else limit)) for rob in ("ur5", "aau_arm", "chain32")
               for c, limit in lane.items()]
    batched += [dict(robot="ur5", call=c, N=1000, pin_route="InParallel(1)", ratio=f(1.0)) for c in ("rnea", "aba")]
    batched += [dict(robot="ur5", call=c, N=1000, pin_route="loop", ratio=f(1.0)) for c in SINGLE_CALLS
                if c not in ("rnea", "aba")]
    batched.append(dict(robot="ur5", call=LAGRANGE[0], N=1000, pin_route="loop", ratio=f(20.0)))
    floating = [dict(robot=rob, call=c, N=10_000, ratio=f(limit)) for rob in ("solo12", "talos_reduced")
                for c, limit in (("rnea", 0.15), ("aba", 0.25), ("mass_matrix (crba)", 0.3))]
    hard = [dict(case=case, route=r, ratio_median=f(1.5), ratio_p95=f(1.5)) for case in ("uniform", "heavy root")
            for r in HARD_ROUTES]
    hard += [dict(case=case, route="Pinocchio aba", median=1e-15, p95=1e-14) for case in ("uniform", "heavy root")]
    throughput = [dict(robot="ur5", call=c, N=N, big=N >= 10_000, all_over_one=f(1 / 1.8) if N >= 10_000 else 1.0)
                  for c in ("rnea", "aba", "mass_matrix") for N in (100, 10_000)]     # (N = 100: not a target row)
    one_state = [dict(robot=rob, call=c, ratio=f(2.0)) for rob in ("ur5", "solo12") for c in CONFIG_CALLS]
    one_state.append(dict(robot="ur5", call=NJIT_CALL, ratio=f(0.3)))
    one_state.append(dict(robot="solo12", call=NJIT_CALL, ratio=5.0))      # (not a target row: ur5 only)
    return dict(machine={}, latency=latency, one_state=one_state, closed_latency=[dict(robot="spm", call="constrained_forward_dynamics",
                                                                  ratio=f(1.0))],
                batched=batched, floating=floating, throughput=throughput, hard_cases=hard, cold_start=dict(measured=True, total_s=f(10.0)))


def rows_of(rep, t):
    """The rows of rep that target t reads."""
    sec = rep[t.section]
    rows = [sec] if isinstance(sec, dict) else sec
    return [r for r in rows if (t.calls is None or r.get(t.call_key) in t.calls)
            and all(targets.matches(r.get(k), v) for k, v in t.where.items())]


def test_every_figure_at_its_limit_is_met():
    assert targets.check(report(at_limit=True)) == []
    assert all(r.met and r.measured and r.rows > 0 for r in targets.evaluate(report()))


@pytest.mark.parametrize("t", TARGETS, ids=[t.name for t in TARGETS])
def test_a_figure_just_above_its_limit_is_missed(t):
    rep = report(at_limit=False)
    row = rows_of(rep, t)[-1]
    row[t.field] = t.limit * (1 + 1e-9)
    misses = targets.check(rep)
    assert [m.target for m in misses] == [t.name]
    m = misses[0]
    assert m.measured == row[t.field] and m.limit == t.limit
    if t.call_key:
        assert m.call.startswith(row[t.call_key]) and m.robot == row[t.robot_key]


def test_single_state_and_batched_targets_read_the_right_rows():
    rep = report(at_limit=False)
    for r in rep["latency"]:
        if r["call"] == LAGRANGE[0]:
            r["ratio"] = 19.0                      # 19× crba: over 3× but within the Lagrange route's 20×
    for r in rep["batched"]:
        if r["call"] == "rnea" and r["N"] == 1000:
            r["pin_route"], r["ratio"] = "loop", 0.9   # at N = 1000, rnea is held to 1×, not the lanes' 0.1×
        if r["call"] == "aba" and r["N"] == 10_000:
            r["ratio"] = 0.49 if r["robot"] == "chain32" else 0.24   # aba is not held to rnea's 0.1×
    assert targets.check(rep) == []
    chain = [r for r in rep["batched"] if r["robot"] == "chain32" and r["call"] == "rnea"][0]
    chain["ratio"] = 0.3                            # the chain is held to 0.5×, not the arms' 0.1×
    assert targets.check(rep) == []
    arm = [r for r in rep["batched"] if r["robot"] == "aau_arm" and r["call"] == "mass_matrix (crba)"][0]
    arm["ratio"] = 0.3                              # the AAU arm's mass matrix: 0.25×
    assert [(m.call, m.robot) for m in targets.check(rep)] == [("mass_matrix (crba) (N=10000)", "aau_arm")]


def test_a_listed_call_without_a_row_is_not_measured_and_missed():
    rep = report()
    rep["latency"] = [r for r in rep["latency"] if r["call"] != "frame_jacobian_dot"]
    misses = targets.check(rep)
    assert [(m.call, m.measured) for m in misses] == [("frame_jacobian_dot", None)]
    del rep["closed_latency"]
    assert ("closed_latency", None) in [(m.call, m.measured) for m in targets.check(rep)]


def test_a_refused_batch_and_a_nan_are_missed():
    rep = report()
    rep["batched"][0] = dict(robot="ur5", call=rep["batched"][0]["call"], N=1000, refused="InputError: no batch")
    rep["latency"][0]["ratio"] = float("nan")
    misses = targets.check(rep)
    assert len(misses) == 2 and {m.call for m in misses} == {f"{rep['batched'][0]['call']} (N=1000)",
                                                           rep["latency"][0]["call"]}


def test_cold_start_counts_only_when_measured():
    rep = report()
    rep["cold_start"] = dict(measured=False, note="not measured")
    assert targets.check(rep) == []
    res = [r for r in targets.evaluate(rep) if r.target.section == "cold_start"][0]
    assert not res.measured and "not measured" in targets.text(targets.evaluate(rep))
    rep["cold_start"] = dict(measured=True, total_s=10.5)
    assert [(m.target, m.measured) for m in targets.check(rep)] == [(TARGETS[-1].name, 10.5)]


@pytest.mark.parametrize("breakage", ["section not a list", "figure not a number", "row lacks figure", "list"])
def test_a_malformed_report_raises_input_error(breakage):
    rep = report()
    if breakage == "section not a list":
        rep["latency"] = "rows"
    elif breakage == "figure not a number":
        rep["latency"][0]["ratio"] = "1.0"
    elif breakage == "row lacks figure":
        del rep["hard_cases"][0]["ratio_median"]
    else:
        rep = [rep]
    with pytest.raises(InputError):
        targets.check(rep)


def test_markdown_and_text_name_each_target():
    res = targets.evaluate(report())
    md, txt = targets.markdown(res), targets.text(res)
    assert all(t.name in md and t.name in txt for t in TARGETS)
    assert f"{len(TARGETS)} of {len(TARGETS)} targets met" in txt


def _write(path, data):
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    return str(path)


def test_check_from_exit_codes(tmp_path, capsys):
    assert main(["bench", "--check", "--from", _write(tmp_path / "met.json", report())]) == 0
    assert "targets met" in capsys.readouterr().out
    missed = copy.deepcopy(report())
    missed["batched"][-1]["ratio"] = 21.0
    assert main(["bench", "--from", _write(tmp_path / "missed.json", missed)]) == 1     # --from implies --check
    out = capsys.readouterr().out
    assert "MISSED" in out and "21 > 20" in out
    bad = {"missing": str(tmp_path / "nope.json"), "not JSON": _write(tmp_path / "bad.json", "{not json"),
           "JSON list": _write(tmp_path / "list.json", [1, 2]),
           "row lacks figure": _write(tmp_path / "old.json", dict(report(), latency=[dict(robot="ur5", call="rnea")])),
           "folder": str(tmp_path)}
    for what, path in bad.items():
        assert main(["bench", "--check", "--from", path]) == 2, what
        err = capsys.readouterr().err
        assert err.startswith("manipdyn bench: error:") and err.count("\n") == 1 and "Traceback" not in err, what
    assert main(["bench", "--check", "--from", _write(tmp_path / "m.json", report()), "--out", str(tmp_path)]) == 2
    assert main(["bench", "--check"]) == 2                                   # neither --out nor --from
    assert "--out" in capsys.readouterr().err


def test_the_one_state_targets_name_the_sections_rows():
    from manipdyn.bench import sections
    assert tuple(sections.CONFIG_CALLS) == CONFIG_CALLS and sections.NJIT_CALL == NJIT_CALL
    assert set(sections.PLAIN) == set(PLAIN_CHECKED)
