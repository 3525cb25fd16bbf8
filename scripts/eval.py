"""`python scripts/eval.py ...` runs `agile eval ...`: the code lives in agile/run/eval.py (kept for torchrun and old
command lines)."""

import sys

from agile.run.eval import main

if __name__ == "__main__":
    sys.exit(main())
