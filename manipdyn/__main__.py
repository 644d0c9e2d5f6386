"""`python -m manipdyn ...`: the same as the `manipdyn` command."""
import sys

from .cli import main

sys.exit(main())
