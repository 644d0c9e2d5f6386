"""Timing helpers and random models for the bench: every timing is paired with Pinocchio's, same run."""
from __future__ import annotations

import os
import platform
import timeit
from importlib import metadata

import numpy as np

from ..extras import require
from ..io.urdf import load_urdf_string


def per_call(f, repeat=5, min_time=0.05) -> float:
    """Seconds per call of f(): best of ``repeat`` runs of about ``min_time`` seconds each, the loop count
    calibrated on runs of 1, 10, 100 … calls up to 2 ms (``min_time`` ≤ 0: one call per run, for calls that
    are long already, such as a whole batch)."""
    timer = timeit.Timer(f)
    number = 1
    if min_time > 0:
        while (t := timer.timeit(number)) < 0.002:
            number *= 10
        number = max(1, int(number * min_time / t))
    return min(timer.repeat(repeat=repeat, number=number)) / number


def per_call_pair(f, g, repeat=5, min_time=0.05) -> tuple:
    """Seconds per call of f() and of g(), timed in alternation: ``repeat`` rounds, each one run of f then one
    of g (loop counts calibrated as ``per_call``'s), the best run of each. A ratio of the two then compares
    runs minutes apart no more than seconds apart (a CPU clock that drifts, a neighbour process, moves both)."""
    timers, numbers = [], []
    for h in (f, g):
        timer, number = timeit.Timer(h), 1
        if min_time > 0:
            while (t := timer.timeit(number)) < 0.002:
                number *= 10
            number = max(1, int(number * min_time / t))
        timers.append(timer)
        numbers.append(number)
    best = [float("inf"), float("inf")]
    for _ in range(repeat):
        for k in (0, 1):
            best[k] = min(best[k], timers[k].timeit(numbers[k]) / numbers[k])
    return best[0], best[1]


def machine() -> dict:
    """What the numbers were measured on."""
    cpu = "unknown"
    try:
        with open("/proc/cpuinfo") as fh:
            cpu = next((line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")), cpu)
    except OSError:
        pass
    versions = {}
    for pkg in ("manipdyn", "numpy", "scipy", "numba", "pin", "example-robot-data"):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = "not installed"
    return dict(cpu=cpu, cores=os.cpu_count(), python=platform.python_version(), system=platform.platform(),
                versions=versions)


def random_chain_urdf(n, seed=0) -> str:
    """A serial chain of n joints, revolute and prismatic mixed, random axes/origins/inertias (physical)."""
    rng = np.random.default_rng(seed)
    out = ['<?xml version="1.0"?><robot name="chain%d"><link name="l0"/>' % n]
    for k in range(1, n + 1):
        d = rng.uniform(0.01, 0.1, 3)
        m = rng.uniform(0.5, 2.0)
        I = m * np.array([d[1] + d[2], d[0] + d[2], d[0] + d[1]])
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        kind = "prismatic" if rng.random() < 0.3 else "revolute"
        xyz, rpy, c = rng.uniform(-0.2, 0.2, 3), rng.uniform(-1, 1, 3), rng.uniform(-0.1, 0.1, 3)
        out.append(f'<link name="l{k}"><inertial><origin xyz="{c[0]} {c[1]} {c[2]}" rpy="0 0 0"/>'
                   f'<mass value="{m}"/><inertia ixx="{I[0]}" iyy="{I[1]}" izz="{I[2]}" ixy="0" ixz="0" '
                   f'iyz="0"/></inertial></link>')
        out.append(f'<joint name="j{k:03d}" type="{kind}"><parent link="l{k - 1}"/><child link="l{k}"/>'
                   f'<origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/>'
                   f'<axis xyz="{axis[0]} {axis[1]} {axis[2]}"/>'
                   f'<limit lower="-0.5" upper="0.5" effort="10" velocity="10"/></joint>')
    out.append("</robot>")
    return "".join(out)


def random_chain(n, seed=0):
    """(our Model, Pinocchio model) of random_chain_urdf(n)."""
    pin = require("pinocchio", "validate", "manipdyn bench")
    text = random_chain_urdf(n, seed)
    return load_urdf_string(text, source=f"chain{n}"), pin.buildModelFromXML(text)
