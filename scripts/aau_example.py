"""Regenerate the chapter's Figs. 3 and 4 (AAU arm) and their CSV into docs/examples/."""
import sys
from pathlib import Path

from manipdyn.cli import main

if __name__ == "__main__":
    sys.exit(main(["example", "aau", "--out", str(Path(__file__).resolve().parent.parent / "docs" / "examples")]))
