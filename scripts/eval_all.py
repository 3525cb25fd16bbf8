"""`python scripts/eval_all.py ...` runs `agile eval_all ...`: the code lives in agile/run/eval_all.py (kept for torchrun and old
command lines)."""

import sys

from agile.run.eval_all import main

if __name__ == "__main__":
    sys.exit(main())
