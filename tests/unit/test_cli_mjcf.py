"""The command line on an MJCF file: inspect, play and export choose the reader by the file's root element (as
validate --against does), an MJCF file takes no --root-joint or --mimic (its free joints and equalities are in the
file: exit 2, one line), and what it reads is the model load_mjcf builds (the humanoid with ball joints)."""
from __future__ import annotations

import json
import warnings

import pytest

from conftest import ROOT

import manipdyn as md
from manipdyn.cli import main

HUMANOID = ROOT / "tests" / "data" / "humanoid_ball.xml"


def model():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return md.load_mjcf(HUMANOID)


def test_inspect_reads_an_mjcf_file(tmp_path, capsys):
    out = tmp_path / "inspect.json"
    assert main(["inspect", str(HUMANOID), "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    m = model()
    text = json.dumps(data)
    assert all(name in text for name in m.joint_names) and str(m.nq) in text
    assert main(["inspect", str(HUMANOID)]) == 0
    text = capsys.readouterr().out
    assert "right_hip" in text and " ball " in text and f"nq = {m.nq}, nv = {m.nv}" in text


def test_export_of_an_mjcf_file_reads_back_the_same_model(tmp_path):
    out = tmp_path / "again.xml"
    assert main(["export", str(HUMANOID), "--mjcf", str(out)]) == 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        again = md.load_mjcf(out)
    m = model()
    assert again.joint_names == m.joint_names and (again.nq, again.nv) == (m.nq, m.nv)
    assert abs(sum(again.mass) - sum(m.mass)) <= 1e-12 * sum(m.mass)


def test_play_writes_a_page_of_an_mjcf_file(tmp_path, capsys):
    pytest.importorskip("meshcat")
    out = tmp_path / "h.html"
    assert main(["play", str(HUMANOID), "--html", str(out)]) == 0
    err = capsys.readouterr().err
    assert "drawn as capsules" in err and "Traceback" not in err
    assert out.stat().st_size > 10_000


@pytest.mark.parametrize("flag", [["--root-joint", "free_flyer"], ["--mimic"]])
def test_urdf_only_options_are_refused_for_an_mjcf_file(flag, capsys):
    assert main(["inspect", str(HUMANOID), *flag]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "an MJCF file" in err[0]


def test_term_by_term_validation_names_the_engine_route_for_an_mjcf_file(capsys):
    assert main(["validate", str(HUMANOID), "--states", "2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--against mujoco" in err[0]
