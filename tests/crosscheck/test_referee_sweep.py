"""manipdyn validate DIR --against ENGINES --jobs N: a folder's URDFs refereed in worker processes, one summary
table, one JSON file per URDF; the same rows as the in-process sweep, in the same order. --scheduler ADDRESS:
the same sweep on a Dask cluster's workers (a LocalCluster here), the same per-file JSON."""
from __future__ import annotations

import json
import shutil

import pytest

from conftest import AAU, ROOT

from manipdyn.cli import main
from manipdyn.validation.referee_zoo import sweep, urdf_files

BAD = """<robot name="bad"><link name="a"/><joint name="j" type="revolute"><parent link="a"/><child link="b"/>
</joint><link name="b"/></robot>"""


@pytest.fixture
def folder(tmp_path):
    d = tmp_path / "in"
    (d / "sub").mkdir(parents=True)
    shutil.copy(AAU, d / "aau_arm.urdf")
    shutil.copy(ROOT / "urdf" / "fourbar.urdf", d / "sub" / 'four bar "&<x>.urdf')     # a hostile file name
    (d / "bad.urdf").write_text(BAD)
    (d / "notes.txt").write_text("not a URDF")
    return d


def test_folder_sweep_in_two_jobs(folder, tmp_path, capsys):
    out = tmp_path / "json"
    code = main(["validate", str(folder), "--against", "pinocchio", "--jobs", "2", "--states", "2",
                 "--json", str(out)])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "| pinocchio | 2 | 1 |" in text and "manipdyn loads 2 of 3 files." in text
    files = sorted(p.name for p in out.iterdir())
    assert files == ["0000_aau_arm.urdf.json", "0001_bad.urdf.json", "0002_sub_four_bar____x_.urdf.json",
                     "summary.json"]
    rows = json.loads((out / "summary.json").read_text())
    assert [r["file"] for r in rows] == ["aau_arm.urdf", "bad.urdf", 'sub/four bar "&<x>.urdf']
    assert "needs <limit" in rows[1]["manipdyn"] and rows[1]["engines"]["pinocchio"]["status"] == "refused"
    # the worker processes give the rows the in-process sweep gives (same seeds, same order)
    here = sweep(["pinocchio"], n_states=2, seed=0, paths=urdf_files([folder]), root=folder)
    assert json.loads(json.dumps(here, default=float)) == rows
    assert all(r["engines"]["pinocchio"]["worst"] < 1e-13 for r in rows if r["manipdyn"] == "loaded")  # measured 5e-16


def test_folder_sweep_on_a_dask_cluster(folder, tmp_path, capsys):
    distributed = pytest.importorskip("distributed")
    on_cluster, here = tmp_path / "cluster", tmp_path / "here"
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as c:
        code = main(["validate", str(folder), "--against", "pinocchio", "--scheduler", c.scheduler_address,
                     "--states", "2", "--json", str(on_cluster)])
    text = capsys.readouterr().out
    assert code == 0, text
    assert f"the Dask scheduler at {c.scheduler_address}" in text and "manipdyn loads 2 of 3 files." in text
    assert main(["validate", str(folder), "--against", "pinocchio", "--jobs", "1", "--states", "2",
                 "--json", str(here)]) == 0
    names = sorted(p.name for p in here.iterdir())
    assert names == sorted(p.name for p in on_cluster.iterdir()) and len(names) == 4
    for name in names:                                    # the same rows, in the same files
        assert json.loads((on_cluster / name).read_text()) == json.loads((here / name).read_text()), name


def test_an_unreachable_scheduler_is_one_line_exit_2(folder, capsys, monkeypatch):
    pytest.importorskip("distributed")
    from manipdyn.validation import referee_zoo
    monkeypatch.setattr(referee_zoo, "SCHEDULER_TIMEOUT", 1)
    assert main(["validate", str(folder), "--against", "pinocchio", "--scheduler", "tcp://127.0.0.1:9"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("manipdyn validate: error: --scheduler tcp://127.0.0.1:9: no Dask scheduler answered")
    assert "Traceback" not in "\n".join(err)


@pytest.mark.parametrize("argv, fragment", [
    (["validate", "{d}", "--scheduler", "tcp://h:1"], "--scheduler needs --against"),
    (["validate", "{d}", "--against", "pinocchio", "--scheduler", "tcp://h:1", "--jobs", "2"], "and no --jobs"),
    (["validate", "{d}", "--against", "pinocchio", "--scheduler", "tcp://h :1"], "expected a scheduler address"),
    (["validate", "{d}", "--jobs", "2"], "--jobs needs --against"),
    (["validate", "{d}/empty", "--against", "pinocchio"], "holds no *.urdf"),
    (["validate", "{d}", "--against", "pinocchio", "--jobs", "2", "--json", "{d}/aau_arm.urdf"], "is a file"),
    (["validate", "{d}", "--states", "2"], "is a directory"),          # without --against: files only, as before
    (["validate", "{d}", "--against", "pinocchio", "--jobs", "0"], "--jobs"),
])
def test_sweep_bad_input_exit_2(folder, capsys, argv, fragment):
    (folder / "empty").mkdir()
    assert main([a.format(d=folder) for a in argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert fragment in err[-1] and err[-1].startswith("manipdyn validate: error:"), err
