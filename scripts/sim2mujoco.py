"""`python scripts/sim2mujoco.py ...` runs `agile sim2mujoco ...`: the code lives in agile/run/sim2mujoco.py (kept for torchrun and old
command lines)."""

import sys

from agile.run.sim2mujoco import main

if __name__ == "__main__":
    sys.exit(main())
