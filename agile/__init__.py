"""agile: manager-based RL tasks for humanoid robots on NVIDIA Newton."""

__version__ = "0.1.0"
