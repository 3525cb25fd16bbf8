"""`python scripts/train.py ...` runs `agile train ...`: the code lives in agile/run/train.py (kept for torchrun and old
command lines)."""

import sys

from agile.run.train import main

if __name__ == "__main__":
    sys.exit(main())
