"""`python scripts/export.py ...` runs `agile export ...`: the code lives in agile/run/export.py (kept for torchrun and old
command lines)."""

import sys

from agile.run.export import main

if __name__ == "__main__":
    sys.exit(main())
