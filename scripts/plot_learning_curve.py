"""`python scripts/plot_learning_curve.py ...` runs `agile plot_learning_curve ...`: the code lives in agile/run/plot_learning_curve.py (kept for torchrun and old
command lines)."""

import sys

from agile.run.plot_learning_curve import main

if __name__ == "__main__":
    sys.exit(main())
