"""Identify the AAU arm's base dynamic parameters from noisy torques and test them on a second trajectory
(manipdyn/examples/identify.py). Options: --samples, --sigma (N·m), --seed, --csv FILE."""
import sys

from manipdyn.examples.identify import main

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
