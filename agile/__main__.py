"""`python -m agile ...`: the `agile` command line (agile/cli.py)."""

import sys

from agile.cli import main

sys.exit(main())
