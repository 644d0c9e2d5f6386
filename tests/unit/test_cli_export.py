"""manipdyn export URDF --mjcf FILE: the document written (read back with ElementTree, no MuJoCo needed) and
the exit codes / one-line errors of docs/design.md §9."""
from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from conftest import ROOT

import manipdyn as md
from manipdyn.cli import main
from manipdyn.errors import ModelError
from manipdyn.io.mjcf import to_mjcf
from manipdyn.io.urdf import load_urdf_string


def test_export_writes_bodies_joints_and_closures(tmp_path, capsys):
    out = tmp_path / "spm.xml"
    assert main(["export", str(ROOT / "urdf" / "spm.urdf"), "--mjcf", str(out)]) == 0
    assert "2 closure(s)" in capsys.readouterr().out
    doc = ET.parse(out).getroot()
    model = md.load_urdf(ROOT / "urdf" / "spm.urdf")
    assert [b.get("name") for b in doc.iter("body")] == list(model.body_names)
    assert [j.get("name") for j in doc.iter("joint") if j.get("type")] == list(model.joint_names)
    assert doc.find("compiler").attrib == dict(angle="radian", autolimits="true", inertiafromgeom="false",
                                               balanceinertia="false")
    # two connects per revolute closure (point + axis), on sites of the closure bodies
    assert [c.get("name") for c in doc.find("equality")] == ["leg2_top", "leg2_top:axis", "leg3_top", "leg3_top:axis"]
    masses = [float(i.get("mass")) for i in doc.iter("inertial")]
    assert np.array_equal(masses, model.mass)                  # repr round-trips the float exactly


@pytest.mark.parametrize("argv, fragment", [
    (["export", "{urdf}", "--mjcf", "{d}/nowhere/o.xml"], "does not exist"),
    (["export", "{urdf}", "--mjcf", "{d}"], "is a directory"),
    (["export", "{d}/missing.urdf", "--mjcf", "{d}/o.xml"], "no such URDF"),
    (["export", "{urdf}"], "required: --mjcf"),
])
def test_export_bad_paths_exit_2_one_line(tmp_path, capsys, argv, fragment):
    argv = [a.format(d=tmp_path, urdf=ROOT / "urdf" / "fourbar.urdf") for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert fragment in err[-1] and err[-1].startswith("manipdyn export: error:")


COUPLED = (ROOT / "tests" / "data" / "loops" / "gear_pair.urdf.in").read_text()


def test_coupling_becomes_a_joint_equality_or_is_refused():
    eq = ET.fromstring(to_mjcf(load_urdf_string(COUPLED.replace("{child}", "b")))).find("equality/joint")
    assert (eq.get("joint1"), eq.get("joint2"), eq.get("polycoef")) == ("jb", "ja", "0 -2.5 0 0 0")
    with pytest.raises(ModelError, match="coupling 'gear'.*2 joints"):   # jb + jc: MuJoCo relates 2 joints only
        to_mjcf(load_urdf_string(COUPLED.replace("{child}", "c")))
