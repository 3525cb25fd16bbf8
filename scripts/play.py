"""`python scripts/play.py ...` runs `agile play ...`: the code lives in agile/run/play.py (kept for torchrun and old
command lines)."""

import sys

from agile.run.play import main

if __name__ == "__main__":
    sys.exit(main())
