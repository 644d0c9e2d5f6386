"""Regenerate the bench report (docs/bench/): `python scripts/bench.py [--quick]`."""
import sys
from pathlib import Path

from manipdyn.cli import main

if __name__ == "__main__":
    out = Path(__file__).resolve().parent.parent / "docs" / "bench"
    sys.exit(main(["bench", "--out", str(out)] + sys.argv[1:]))
