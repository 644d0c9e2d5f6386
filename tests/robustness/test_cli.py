"""The CLI's exit-code contract: 0 success, 1 a validated term failed, 2 bad input or usage.

A refusal is one line on stderr, ``manipdyn <command>: error: ...`` (after argparse's usage for a usage
error), never a traceback unless --debug; bad arguments and output paths are refused before any work
(no report on stdout). Subprocess cases run the real entry point; the rest call ``main`` in-process.
"""
import os
import subprocess
import sys
from pathlib import Path

import pytest

from manipdyn import cli
from manipdyn.cli import MAX_SAMPLES, MAX_SEED, MAX_STATES, main

ROOT = Path(__file__).resolve().parents[2]
AAU = ROOT / "urdf" / "aau_arm.urdf"
FOURBAR = ROOT / "urdf" / "fourbar.urdf"


def run_cli(*args, cwd=None):
    """The CLI as a user runs it, on the code under test."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "manipdyn.cli", *map(str, args)], capture_output=True,
                          text=True, env=env, cwd=cwd, timeout=600)


def assert_refused(code, err, command, fragment, usage=False):
    """Exit 2 with one error line naming the fault; argparse's usage lines before it, nothing else."""
    assert code == 2, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    prefix = f"manipdyn {command}: error: " if command else "manipdyn: error: "
    assert lines and lines[-1].startswith(prefix), err
    assert fragment in lines[-1], err
    if usage:
        assert lines[0].startswith("usage: manipdyn"), err
    else:
        assert len(lines) == 1, err


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Bad inputs and output targets, in one folder."""
    d = tmp_path_factory.mktemp("cli")
    (d / "folder").mkdir()
    (d / "file.txt").write_text("a file\n")
    (d / "empty.urdf").write_bytes(b"")
    (d / "binary.urdf").write_bytes(bytes(range(256)) * 8)
    (d / "bad.csv").write_text("t,q_joint1\n0,abc\n")
    (d / "model.xml").write_text('<mujoco><worldbody><body name="b"><joint name="j" axis="0 1 0"/><geom type="sphere" '
                                 'size="0.1"/></body></worldbody></mujoco>')
    text = AAU.read_text()                        # the AAU arm with link2's mass 20 % heavier
    i = text.index("<mass value=", text.index('<link name="link2"'))
    j = text.index('"', i + len('<mass value="'))
    old = float(text[i + len('<mass value="'):j])
    (d / "perturbed.urdf").write_text(text[:i] + f'<mass value="{old * 1.2!r}' + text[j:])
    return d


# ---- subprocess: the real entry point ---------------------------------------------------------------------

SUBPROCESS = [   # id, argv (with {d} = the files folder), command, fragment of the error line, usage error?
    ("validate-states-0", ["validate", AAU, "--states", "0"], "validate", "--states", True),
    ("validate-states-huge", ["validate", AAU, "--states", "1000000000"], "validate", f"1..{MAX_STATES}", True),
    ("validate-seed-negative", ["validate", AAU, "--seed", "-1"], "validate", "--seed", True),
    ("validate-unknown-option", ["validate", AAU, "--nope"], "validate", "unrecognized", True),
    ("no-subcommand", [], "", "required", True),
    ("validate-json-missing-folder", ["validate", AAU, "--states", "2", "--json", "{d}/nowhere/r.json"],
     "validate", "does not exist", False),
    ("validate-json-directory", ["validate", AAU, "--states", "2", "--json", "{d}/folder"], "validate",
     "is a directory", False),
    ("validate-missing-urdf", ["validate", "{d}/missing.urdf", "--states", "2"], "validate", "no such URDF",
     False),
    ("validate-second-urdf-is-folder", ["validate", AAU, "{d}/folder", "--states", "2"], "validate",
     "is a directory", False),
    ("validate-reference-not-urdf", ["validate", AAU, "--reference", "{d}/file.txt", "--states", "2"],
     "validate", "malformed XML", False),
    ("validate-reference-other-robot", ["validate", AAU, "--reference", FOURBAR, "--states", "2"],
     "validate", "joint order differs", False),
    ("validate-lock-not-a-number", ["validate", AAU, "--states", "2", "--lock", "joint1=abc"], "validate",
     "JOINT=VALUE", False),
    ("inspect-directory", ["inspect", "{d}/folder"], "inspect", "is a directory", False),
    ("inspect-missing", ["inspect", "{d}/missing.urdf"], "inspect", "no such URDF", False),
    ("inspect-not-urdf", ["inspect", "{d}/file.txt"], "inspect", "malformed XML", False),
    ("inspect-binary", ["inspect", "{d}/binary.urdf"], "inspect", "binary.urdf", False),
    ("inspect-tips-unknown", ["inspect", AAU, "--tips", "nolink"], "inspect", "nolink", False),
    ("inspect-asset-root-on-urdf", ["inspect", AAU, "--asset-root", "{d}/folder"], "inspect", "--asset-root grants",
     False),
    ("inspect-asset-root-missing", ["inspect", "{d}/model.xml", "--asset-root", "{d}/nowhere"], "inspect",
     "no such folder", False),
    ("example-samples-0", ["example", "aau", "--samples", "0", "--out", "{d}/ex"], "example", "--samples",
     True),
    ("example-out-is-file", ["example", "aau", "--out", "{d}/file.txt"], "example", "is a file", False),
    ("bench-out-is-file", ["bench", "--quick", "--out", "{d}/file.txt"], "bench", "is a file", False),
    ("play-missing-urdf", ["play", "{d}/missing.urdf", "--html", "{d}/o.html"], "play", "no such URDF", False),
    ("play-traj-bad-cell", ["play", AAU, "--traj", "{d}/bad.csv", "--html", "{d}/o.html"], "play",
     "line 2, column 'q_joint1'", False),
]


@pytest.mark.parametrize("argv,command,fragment,usage", [c[1:] for c in SUBPROCESS],
                         ids=[c[0] for c in SUBPROCESS])
def test_subprocess_refusal(files, argv, command, fragment, usage):
    r = run_cli(*[str(a).format(d=files) for a in argv], cwd=files)
    assert_refused(r.returncode, r.stderr, command, fragment, usage)
    if not usage:
        assert r.stdout == "", "refused before any work: no report"


def test_bad_json_path_fails_before_validation(files):
    """A --json path that cannot be written stops the run before the first model is even loaded."""
    r = run_cli("validate", AAU, "--states", "2", "--quiet", "--json", files / "nowhere" / "r.json")
    assert_refused(r.returncode, r.stderr, "validate", "--json")
    assert r.stdout == ""               # no header line, no report table
    assert not (files / "nowhere").exists()


def test_failing_term_exits_1(files):
    """The only exit 1: a term fails (a perturbed link mass against the bundled file's Pinocchio model)."""
    out = files / "report.json"
    r = run_cli("validate", files / "perturbed.urdf", "--reference", AAU, "--states", "3", "--quiet",
                "--json", out)
    assert r.returncode == 1, r.stderr
    assert "Traceback" not in r.stderr and "FAILED" in r.stdout
    assert "first divergence: link 'link2'" in r.stdout
    assert out.is_file()


def test_passing_run_exits_0(files):
    r = run_cli("validate", AAU, "--states", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    assert "1/1 models pass every term" in r.stdout


@pytest.mark.parametrize("where", ["global", "after-subcommand"])
def test_debug_shows_the_traceback(files, where):
    argv = ["inspect", files / "folder"]
    argv = ["--debug", *argv] if where == "global" else [*argv, "--debug"]
    r = run_cli(*argv)
    assert r.returncode == 2
    assert "Traceback" in r.stderr and r.stderr.strip().splitlines()[-1].startswith("manipdyn inspect: error:")


def test_help_documents_exit_codes_and_debug():
    r = run_cli("--help")
    assert r.returncode == 0 and r.stderr == ""
    assert "--debug" in r.stdout and "exit codes:" in r.stdout
    assert "1  a validated term failed" in r.stdout and f"--states 1..{MAX_STATES}" in r.stdout


# ---- in-process: main(argv) returns the code --------------------------------------------------------------

USAGE = [   # id, argv, fragment: argparse refuses these before anything is loaded
    ("states-negative", ["validate", str(AAU), "--states", "-3"], "--states"),
    ("states-over-max", ["validate", str(AAU), "--states", str(MAX_STATES + 1)], f"1..{MAX_STATES}"),
    ("states-float", ["validate", str(AAU), "--states", "2.5"], "'2.5'"),
    ("tol-zero", ["validate", str(AAU), "--tol", "0"], "--tol"),
    ("tol-negative", ["validate", str(AAU), "--tol", "-1e-12"], "--tol"),
    ("tol-inf", ["validate", str(AAU), "--tol", "inf"], "--tol"),
    ("tol-text", ["validate", str(AAU), "--tol", "tight"], "'tight'"),
    ("seed-over-max", ["validate", str(AAU), "--seed", str(MAX_SEED + 1)], "--seed"),
    ("seed-text", ["validate", str(AAU), "--seed", "x"], "--seed"),
    ("samples-negative", ["example", "aau", "--samples", "-5"], "--samples"),
    ("samples-one", ["example", "aau", "--samples", "1"], "--samples"),
    ("samples-over-max", ["example", "aau", "--samples", str(MAX_SAMPLES + 1)], f"2..{MAX_SAMPLES}"),
    ("example-unknown-name", ["example", "nope"], "invalid choice"),
    ("bench-without-out", ["bench"], "--out"),
    ("bench-check-without-out", ["bench", "--check"], "--out"),
    ("bench-from-with-out", ["bench", "--from", "report.json", "--out", "somewhere"], "--out and --quick"),
    ("bench-from-with-quick", ["bench", "--from", "report.json", "--quick"], "--out and --quick"),
    ("inspect-without-urdf", ["inspect"], "urdf"),
    ("tips-without-links", ["inspect", str(AAU), "--tips"], "--tips"),
    ("tol-nan", ["validate", str(AAU), "--tol", "nan"], "--tol"),
    ("unknown-option", ["validate", str(AAU), "--states", "2", "--nope"], "unrecognized arguments: --nope"),
    ("unknown-option-inspect", ["inspect", str(AAU), "--nope"], "unrecognized arguments: --nope"),
]


@pytest.mark.parametrize("argv,fragment", [c[1:] for c in USAGE], ids=[c[0] for c in USAGE])
def test_usage_error(argv, fragment, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    assert_refused(code, err, argv[0], fragment, usage=True)
    assert out == ""


INPUT = [   # id, argv (with {d} = the files folder), fragment of the error line
    ("json-into-file-as-folder", ["validate", str(AAU), "--json", "{d}/file.txt/r.json"], "does not exist"),
    ("json-unwritable", ["validate", str(AAU), "--json", "/proc/manipdyn-report.json"], "cannot write it"),
    ("json-onto-proc-file", ["validate", str(AAU), "--json", "/proc/version"], "cannot write it"),
    ("example-out-below-a-file", ["example", "aau", "--out", "{d}/file.txt/sub"], "file.txt"),
    ("bench-out-below-a-file", ["bench", "--out", "{d}/file.txt/sub"], "file.txt"),
    ("bench-from-missing", ["bench", "--from", "{d}/missing.json"], "no such bench report"),
    ("bench-from-folder", ["bench", "--check", "--from", "{d}/folder"], "is a directory"),
    ("validate-empty-urdf", ["validate", "{d}/empty.urdf", "--states", "2"], "empty.urdf"),
    ("inspect-empty-urdf", ["inspect", "{d}/empty.urdf"], "empty.urdf"),
    ("inspect-dev-null", ["inspect", "/dev/null"], "not a regular file"),
    ("lock-without-equals", ["inspect", str(AAU), "--lock", "joint1"], "expected JOINT=VALUE"),
    ("lock-empty-name", ["inspect", str(AAU), "--lock", "=0.5"], "expected JOINT=VALUE"),
    ("lock-twice", ["inspect", str(AAU), "--lock", "joint1=0", "--lock", "joint1=1"], "locked twice"),
    ("lock-nan", ["inspect", str(AAU), "--lock", "joint1=nan"], "must be finite"),
    ("lock-unknown-joint-validate", ["validate", str(AAU), "--lock", "nojoint=0", "--states", "2"], "nojoint"),
    ("tips-unknown-validate", ["validate", str(AAU), "--tips", "nolink", "--states", "2"], "nolink"),
    ("play-urdf-folder", ["play", "{d}/folder", "--html", "{d}/o.html"], "is a directory"),
    ("play-html-missing-folder", ["play", str(AAU), "--html", "{d}/nowhere/o.html"], "does not exist"),
    ("play-html-directory", ["play", str(AAU), "--html", "{d}/folder"], "is a directory"),
    ("reference-missing", ["validate", str(AAU), "--reference", "{d}/missing.urdf"], "no such --reference"),
    ("root-unknown", ["inspect", str(AAU), "--root", "nolink"], "nolink"),
    ("lock-unknown-joint", ["inspect", str(AAU), "--lock", "nojoint=0"], "nojoint"),
]


@pytest.mark.parametrize("argv,fragment", [c[1:] for c in INPUT], ids=[c[0] for c in INPUT])
def test_input_refused(files, argv, fragment, capsys):
    if "/proc/" in " ".join(argv) and not Path("/proc/version").is_file():
        pytest.skip("needs Linux /proc")
    code = main([a.format(d=files) for a in argv])
    out, err = capsys.readouterr()
    assert_refused(code, err, argv[0], fragment)
    assert out == ""


def _raise(exc):
    def command(args):
        raise exc
    return command


@pytest.mark.parametrize("exc,fragment", [
    (KeyboardInterrupt(), "error: interrupted"),
    (ZeroDivisionError("float division by zero"), "internal error: ZeroDivisionError: float division by zero "
                                                  "(run with --debug for the traceback)"),
    (ValueError("two\nlines"), "internal error: ValueError: two | lines"),
    (PermissionError(13, "Permission denied", "/some/file"), "error: /some/file: Permission denied"),
], ids=["ctrl-c", "internal-error", "multi-line-message", "os-error"])
def test_unexpected_exceptions_exit_2_on_one_line(exc, fragment, monkeypatch, capsys):
    """A bug, Ctrl-C or an OSError deep inside a subcommand: exit 2, one line, no traceback."""
    monkeypatch.setattr(cli, "_inspect", _raise(exc))
    code = main(["inspect", str(AAU)])
    assert_refused(code, capsys.readouterr().err, "inspect", fragment)


def test_debug_keeps_the_exit_code(monkeypatch, capsys):
    """--debug adds the traceback; the code stays 2."""
    monkeypatch.setattr(cli, "_inspect", _raise(ZeroDivisionError("x")))
    assert main(["--debug", "inspect", str(AAU)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" in err and "ZeroDivisionError" in err


def test_help_exits_0(capsys):
    assert main(["validate", "--help"]) == 0
    assert "exit codes:" in capsys.readouterr().out


def test_output_check_leaves_no_file(files, capsys):
    """Checking that --json can be written creates nothing when the run is then refused."""
    target = files / "never.json"
    assert main(["validate", str(AAU), "--json", str(target), "--lock", "nojoint=0"]) == 2
    assert not target.exists()
    capsys.readouterr()


# ---- inspect --json, the quirks, --mimic -------------------------------------------------------------------

def _zoo(rel):
    from manipdyn.validation.zoo import robots_dir
    return robots_dir() / rel


PANDA, PR2, ROMEO = (_zoo(r) for r in ("panda_description/urdf/panda.urdf", "pr2_description/urdf/pr2.urdf",
                                       "romeo_description/urdf/romeo.urdf"))


def test_inspect_json_carries_the_quirks_and_the_summary():
    import json
    import warnings

    from manipdyn import load_urdf
    r = run_cli("inspect", PANDA, "--mimic", "--json")
    assert r.returncode == 0 and r.stderr == "", r.stderr
    d = json.loads(r.stdout)                     # stdout is the JSON document and nothing else
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mm = load_urdf(PANDA, mimic=True)
    assert d["quirks"] == [q.as_dict() for q in mm.quirks] and d["quirks"][0]["kind"] == "mimic"
    assert list(d["quirk_kinds"]) == ["mimic"] and "<mimic>" in d["quirk_kinds"]["mimic"]
    assert d["summary"] == mm.summary() and d["nq"] == d["nv"] == 8 and d["mimic_honoured"]
    assert d["mimic"] == [dict(joint="panda_finger_joint2", target="panda_finger_joint1", multiplier=1.0, offset=0.0)]
    assert len(d["full_joints"]) == 9 and d["warnings"]


def test_inspect_json_to_a_file_and_closures(files, capsys):
    import json
    out = files / "fourbar.json"
    assert main(["inspect", str(FOURBAR), "--json", str(out)]) == 0
    assert capsys.readouterr().out == ""
    d = json.loads(out.read_text())
    assert d["constraints"] == [dict(name="loop", type="revolute", rows=5, source="constraint", parent_link="coupler",
                                     child_link="rocker")] and d["actuated"] == ["j1_crank"] and d["quirks"] == []
    assert_refused(main(["inspect", str(FOURBAR), "--json", str(files / "nowhere" / "x.json")]),
                   capsys.readouterr().err, "inspect", "does not exist")


def test_inspect_text_lists_quirks_per_kind_naming_links(capsys):
    assert main(["inspect", str(PR2)]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    k = lines.index("quirks (Model.quirks: what the loader noticed), per kind:")
    kinds = [ln.split()[0] for ln in lines[k + 1:] if ln.startswith("  ") and not ln.startswith("    ")]
    assert kinds == ["triangle", "mimic"], kinds                  # QUIRK_KINDS order
    assert "    sensor_mount_link: principal moments" in out and "    double_stereo_link: principal moments" in out
    assert "    l_gripper_r_finger_joint: = 1 * l_gripper_l_finger_joint + 0" in out


def test_validate_mimic_exit_codes(files, capsys):
    assert main(["validate", str(PANDA), "--mimic", "--states", "2", "--quiet"]) == 0
    assert "1/1 models pass every term" in capsys.readouterr().out
    text = PANDA.read_text()                      # the finger mimic with multiplier 0.5 against the file's 1
    bad = files / "panda_half.urdf"
    bad.write_text(text.replace('<mimic joint="panda_finger_joint1"', '<mimic multiplier="0.5" joint="panda_finger_joint1"'))
    assert 'multiplier="0.5"' in bad.read_text()
    assert main(["validate", str(bad), "--reference", str(PANDA), "--mimic", "--states", "2", "--quiet"]) == 1
    assert "FAIL" in capsys.readouterr().out
    code = main(["validate", str(ROMEO), "--mimic", "--states", "2", "--quiet"])   # Pinocchio refuses the file
    assert_refused(code, capsys.readouterr().err, "validate", "Pinocchio cannot build a reference model")
    code = main(["inspect", str(PANDA), "--mimic", "--lock", "panda_joint1=0"])
    assert_refused(code, capsys.readouterr().err, "inspect", "cannot yet be combined with mimic=True")


def test_asset_root_lets_inspect_read_a_suites_shared_include(tmp_path):
    """inspect on an MJCF file that includes ../common/defaults.xml: refused by default, naming --asset-root; read
    with --asset-root on the suite's folder (exit 0)."""
    (tmp_path / "robots").mkdir()
    (tmp_path / "common").mkdir()
    (tmp_path / "common" / "defaults.xml").write_text('<mujoco><compiler angle="radian"/></mujoco>')
    main = tmp_path / "robots" / "arm.xml"
    main.write_text('<mujoco><include file="../common/defaults.xml"/><worldbody><body name="b"><joint name="j" '
                    'axis="0 1 0"/><geom type="sphere" size="0.1"/></body></worldbody></mujoco>')
    r = run_cli("inspect", main, cwd=tmp_path)
    assert r.returncode == 2 and "--asset-root" in r.stderr and "Traceback" not in r.stderr, r.stderr
    r = run_cli("inspect", main, "--asset-root", tmp_path, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
