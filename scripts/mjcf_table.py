"""Write docs/mjcf.md's table: each third-party MJCF file (gymnasium's MuJoCo assets, pybullet_data/mjcf) loaded by
manipdyn.load_mjcf and compared with MuJoCo and Pinocchio (tests/crosscheck/test_mjcf_third_party.py holds the table
to the files). Run from the repository root:
``PYTHONPATH=. python scripts/mjcf_table.py``."""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "tests" / "crosscheck")]

import importlib.metadata  # noqa: E402
import manipdyn as md  # noqa: E402
import mujoco  # noqa: E402
from test_mjcf_third_party import ASSETS, SETS, outcome  # noqa: E402
from test_mjcf_import import pin_errors  # noqa: E402

START, END = "<!-- table: scripts/mjcf_table.py -->", "<!-- end of table -->"


def pinocchio(model, path) -> str:
    """Pinocchio 4.1's buildModelFromMJCF of the file against ours: the error, or why there is none."""
    import pinocchio as pin
    try:
        pm = pin.buildModelFromMJCF(str(path))
    except Exception as exc:  # noqa: BLE001 - any failure of the third-party reader is reported as such
        return f"does not load ({type(exc).__name__})"
    if (pm.nq, pm.nv) != (model.nq, model.nv):
        return f"nq, nv = {pm.nq}, {pm.nv}"
    return f"{pin_errors(model, path):.1e}"


def table() -> str:
    rows = ["| file | MuJoCo loads? | loads? | nq, nv | max error vs MuJoCo (M, τ) | vs Pinocchio | quirks, or the reason "
            "refused |", "|---|---|---|---|---|---|---|"]
    for name, path in ASSETS:
        mj, (kind, value) = outcome(path)
        first = f"| {name}/{path.name} | {'no' if mj else 'yes'} |"
        if kind == "loads":
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                model = md.load_mjcf(path)
            kinds = ", ".join(sorted({q.kind for q in model.quirks})) or "—"
            if mj:
                rows.append(f"{first} yes | {model.nq}, {model.nv} | | | {kinds}; MuJoCo 4 refuses it: "
                            f"{mj.replace('|', '/')} |")
            else:
                rows.append(f"{first} yes | {model.nq}, {model.nv} | {value:.1e} | {pinocchio(model, path)} | {kinds} |")
        else:
            why = value.replace("|", "/") + (f" (MuJoCo 4 refuses it too: {mj.replace('|', '/')})" if mj else "")
            rows.append(f"{first} no | | | | {why} |")
    versions = ", ".join(f"{n} {importlib.metadata.version(n if n != 'pybullet_data' else 'pybullet')}"
                         for n, paths in SETS.items() if paths)
    return f"{versions}, MuJoCo {mujoco.__version__}, 5 random states per file:\n\n" + "\n".join(rows)


if __name__ == "__main__":
    doc = ROOT / "docs" / "mjcf.md"
    text = doc.read_text()
    head, rest = text.split(START)
    tail = rest.split(END)[1]
    doc.write_text(f"{head}{START}\n{table()}\n{END}{tail}")
    print(f"wrote {doc}")
