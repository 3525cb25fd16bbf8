"""`python scripts/benchmark.py ...` runs `agile benchmark ...`: the code lives in agile/run/benchmark.py (kept for torchrun and old
command lines)."""

import sys

from agile.run.benchmark import main

if __name__ == "__main__":
    sys.exit(main())
