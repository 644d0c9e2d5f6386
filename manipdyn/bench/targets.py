"""The speed-vs-error issue's targets as data, and the check of a bench report against them.

A target is a limit on one figure of the rows of one report section (report.json), e.g. `ratio` (ours ÷
Pinocchio, same run) of the latency rows whose call is listed. A target is met when every matching row is at
or below its limit; a listed call with no row, or a row that refused the call, misses it ("not measured" is
not "met"). Only the cold start is optional: without a measurement it is shown and not counted.

    check(report)    -> [Miss(call, robot, measured, limit, target)], empty when every target is met
    evaluate(report) -> one Result per target (worst figure, where, met), for the tables
A report whose sections are not lists of rows, or whose rows lack the figure, raises InputError.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from dataclasses import field as dc_field
from typing import NamedTuple

from ..errors import InputError

# the single-state calls held to 3× Pinocchio's Python call (the latency table's rows)
SINGLE_CALLS = ("rnea", "aba", "rnea with f_ext", "aba with f_ext", "mass_matrix (crba)", "coriolis_matrix",
                "gravity_torques", "nonlinear_effects", "frame_placement", "frame_jacobian", "frame_jacobian_dot",
                "forward_dynamics (cholesky)", "kinetic_energy", "potential_energy", "rnea_derivatives",
                "aba_derivatives", "joint_torque_regressor")
PLAIN_CHECKED = ("rnea", "aba", "mass_matrix (crba)")   # Pinocchio's figure held to a plain timeit (sections.PLAIN)
CONFIG_CALLS = ("integrate", "difference", "neutral", "normalize")   # bench.sections.CONFIG_CALLS, one state
NJIT_CALL = "rnea, one step of a user's numba.njit loop"               # bench.sections.NJIT_CALL
LAGRANGE = ("mass_matrix (lagrange)",)        # the chapter's O(n³) route, against Pinocchio's crba
LANE_ARMS = ("ur5", "aau_arm")                # the lane kernels' targets: these arms, and the 32-link chain
# our forward-dynamics routes in the hard cases, each against Pinocchio's same algorithm (aba; crba + cholesky.solve)
HARD_ROUTES = ("ABA", "ABA, batched (lanes)", "Cholesky (M⁻¹)")


@dataclass(frozen=True)
class Target:
    """Every row of ``section`` whose ``call_key`` is in ``calls`` (all rows if None) and whose fields match
    ``where`` (a value, or a tuple of the values allowed) must have ``row[field] <= limit``."""
    name: str
    section: str
    field: str
    limit: float
    calls: tuple | None = None
    where: dict = dc_field(default_factory=dict)
    call_key: str = "call"
    robot_key: str = "robot"
    optional: bool = False          # not measured -> shown, not a miss (the cold start)


TARGETS = (
    Target("single-state call ≤ 3× Pinocchio's Python call", "latency", "ratio", 3.0, SINGLE_CALLS),
    Target("single-state mass_matrix (lagrange) ≤ 20× Pinocchio's crba", "latency", "ratio", 20.0, LAGRANGE),
    Target("Pinocchio's single-call figures within 10 % of a plain timeit of its call (rnea, aba, crba)", "latency",
           "pin_deviation", 0.1, PLAIN_CHECKED),
    Target("configuration operations (one state) ≤ 2× Pinocchio's", "one_state", "ratio", 2.0, CONFIG_CALLS),
    Target("one rnea step in a user's njit loop ≤ 0.3× Pinocchio's Python call, on ur5", "one_state", "ratio", 0.3,
           (NJIT_CALL,), where=dict(robot="ur5")),
    Target("SPM constrained_forward_dynamics ≤ 1× Pinocchio's constraintDynamics", "closed_latency", "ratio", 1.0,
           ("constrained_forward_dynamics",)),
    Target("batched call, per state ≤ 1× Pinocchio (InParallel(1) or its loop)", "batched", "ratio", 1.0,
           SINGLE_CALLS),
    Target("batched mass_matrix (lagrange), per state ≤ 20× Pinocchio's crba loop", "batched", "ratio", 20.0,
           LAGRANGE),
    Target("lane kernels, N = 1e4: rnea ≤ 0.1× rneaInParallel(1) on ur5 and the AAU arm", "batched", "ratio", 0.1,
           ("rnea",), dict(N=10_000, robot=LANE_ARMS)),
    Target("lane kernels, N = 1e4: aba ≤ 0.25× abaInParallel(1) on ur5 and the AAU arm", "batched", "ratio", 0.25,
           ("aba",), dict(N=10_000, robot=LANE_ARMS)),
    Target("lane kernels, N = 1e4: mass_matrix ≤ 0.25× a loop of crba on ur5 and the AAU arm", "batched", "ratio",
           0.25, ("mass_matrix (crba)",), dict(N=10_000, robot=LANE_ARMS)),
    Target("lane kernels, N = 1e4: each ≤ 0.5× Pinocchio on the 32-link chain", "batched", "ratio", 0.5,
           ("rnea", "aba", "mass_matrix (crba)"), dict(N=10_000, robot="chain32")),
    Target("floating bases and ball joints, N = 1e4: rnea ≤ 0.15× rneaInParallel(1)", "floating", "ratio", 0.15,
           ("rnea",), dict(N=10_000)),
    Target("floating bases and ball joints, N = 1e4: aba ≤ 0.25× abaInParallel(1)", "floating", "ratio", 0.25,
           ("aba",), dict(N=10_000)),
    Target("floating bases and ball joints, N = 1e4: mass_matrix ≤ 0.3× a loop of crba", "floating", "ratio", 0.3,
           ("mass_matrix (crba)",), dict(N=10_000)),
    Target("every core: a batch of N ≥ 1e4 in ≤ 1/1.8 of one core's time (rnea, aba, mass_matrix)", "throughput",
           "all_over_one", 1 / 1.8, ("rnea", "aba", "mass_matrix"), dict(big=True)),
    Target("hard cases: median q̈ error ≤ 1.5× Pinocchio's same route", "hard_cases", "ratio_median", 1.5, HARD_ROUTES,
           call_key="route", robot_key="case"),
    Target("hard cases: p95 q̈ error ≤ 1.5× Pinocchio's same route", "hard_cases", "ratio_p95", 1.5, HARD_ROUTES,
           call_key="route", robot_key="case"),
    Target("cold start (import + first calls, kernels from the warmed-up cache) ≤ 10 s", "cold_start", "total_s", 10.0, call_key="", robot_key="",
           optional=True),
)


class Miss(NamedTuple):
    """A missed figure: the call and robot (or hard case) of the row, its figure (None: not measured), the limit."""
    call: str
    robot: str
    measured: float | None
    limit: float
    target: str


@dataclass
class Result:
    """One target over a report: the worst figure and where it is, how many rows were read, the misses."""
    target: Target
    rows: int
    worst: float | None
    where: str
    misses: list
    measured: bool = True

    @property
    def met(self) -> bool:
        return not self.misses

    def as_dict(self) -> dict:
        return dict(target=self.target.name, limit=self.target.limit, rows=self.rows, worst=self.worst,
                    where=self.where, measured=self.measured, met=self.met, misses=len(self.misses))


def _rows(report, t):
    """The section's rows (a dict section is one row; a cold start that was not measured, none)."""
    if t.section not in report:
        return None
    sec = report[t.section]
    if isinstance(sec, dict):
        return [sec] if sec.get("measured", True) else None
    if not isinstance(sec, list) or not all(isinstance(r, dict) for r in sec):
        raise InputError(f"bench report: section {t.section!r} is not a list of rows")
    return sec


def _label(row, t):
    call = str(row.get(t.call_key, t.section)) + (f" (N={row['N']})" if "N" in row else "")
    return call, str(row.get(t.robot_key, ""))


def _figure(row, t):
    """row[t.field] as a float; None for a row that refused the call; InputError if the row lacks it."""
    if t.field not in row:
        if "refused" in row:
            return None
        raise InputError(f"bench report: a {t.section!r} row lacks {t.field!r} (a report of another version?)")
    x = row[t.field]
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        raise InputError(f"bench report: {t.section}.{t.field} = {x!r} is not a number")
    return float(x)


def matches(x, v) -> bool:
    """A row's field x against a target's ``where`` value v: equal, or one of v's values if v is a tuple."""
    return x in v if isinstance(v, tuple) else x == v


def evaluate_one(report, t: Target) -> Result:
    """Target t over the report."""
    rows = _rows(report, t)
    if rows is None:
        misses = [] if t.optional else [Miss(t.section, "", None, t.limit, t.name)]
        return Result(t, 0, None, "not measured", misses, measured=False)
    rows = [r for r in rows if (t.calls is None or r.get(t.call_key) in t.calls)
            and all(matches(r.get(k), v) for k, v in t.where.items())]
    misses, worst, where = [], None, ""
    for r in rows:
        x = _figure(r, t)
        call, robot = _label(r, t)
        if x is None or not x <= t.limit:           # NaN misses too
            misses.append(Miss(call, robot, x, t.limit, t.name))
        if x is not None and (worst is None or not x <= worst):
            worst, where = x, f"{call}, {robot}".strip(", ")
    seen = {r.get(t.call_key) for r in rows}
    for c in t.calls or ():
        if c not in seen:                           # a listed call with no row is not measured
            misses.append(Miss(c, "", None, t.limit, t.name))
    if not rows and t.calls is None:
        misses.append(Miss(t.section, "", None, t.limit, t.name))
    return Result(t, len(rows), worst, where, misses, measured=bool(rows))


def evaluate(report, targets=TARGETS) -> list:
    """Every target over the report (a dict as written to report.json)."""
    if not isinstance(report, dict):
        raise InputError("bench report: not a JSON object")
    return [evaluate_one(report, t) for t in targets]


def check(report, targets=TARGETS) -> list:
    """The missed figures of the report, [Miss(call, robot, measured, limit, target)]; empty if all are met."""
    return [m for r in evaluate(report, targets) for m in r.misses]


def _fig(x) -> str:
    return "not measured" if x is None else "nan" if isinstance(x, float) and math.isnan(x) else f"{x:.3g}"


def _status(r: Result) -> str:
    if not r.measured and r.target.optional:
        return "not measured"
    return "met" if r.met else f"MISSED ({len(r.misses)})"


def text(results) -> str:
    """The targets table for the terminal, then each missed figure."""
    w = max(len(r.target.name) for r in results)
    out = [f"{'target':<{w}}  {'limit':>6}  {'worst':>12}  status        where"]
    for r in results:
        out.append(f"{r.target.name:<{w}}  {r.target.limit:>6g}  {_fig(r.worst):>12}  {_status(r):<12}  {r.where}")
    misses = [m for r in results for m in r.misses]
    if misses:
        out.append("\nmissed:")
        out += [f"  {m.call} on {m.robot or '–'}: {_fig(m.measured)} > {m.limit:g}  ({m.target})" for m in misses]
    met = sum(r.met and r.measured for r in results)
    counted = sum(r.measured or not r.target.optional for r in results)
    out.append(f"\n{met} of {counted} targets met")
    return "\n".join(out)


def markdown(results) -> str:
    """The report's Targets table: each target, its limit, the worst figure, where, met or missed."""
    s = "| target | limit | rows | worst figure | where | status |\n|---|---|---|---|---|---|\n"
    for r in results:
        s += (f"| {r.target.name} | {r.target.limit:g} | {r.rows} | {_fig(r.worst)} | {r.where or '–'} | "
              f"{_status(r)} |\n")
    return s
