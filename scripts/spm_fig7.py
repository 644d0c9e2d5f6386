"""Regenerate the chapter's Fig. 7 (SPM actuator torques, three routes) into docs/examples/."""
import sys
from pathlib import Path

from manipdyn.cli import main

if __name__ == "__main__":
    sys.exit(main(["example", "spm", "--out", str(Path(__file__).resolve().parent.parent / "docs" / "examples")]))
