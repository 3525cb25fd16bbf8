"""Loading checkpoints without running their code.

`torch.load(weights_only=False)` unpickles arbitrary objects, so a checkpoint from a paper's page or a
colleague can run code on the machine that plays, evaluates, exports or resumes it. Our checkpoints (RSL-RL's:
state dicts, the optimizer's state, the iteration, `infos`) hold only tensors and plain containers, which
`weights_only=True` loads. A file that needs more is refused, naming the type, unless the user trusts it
(`--trust_checkpoint`).
"""

from __future__ import annotations

import os
import pickle
import re

import torch

TRUST_FLAG = "--trust_checkpoint"


class UntrustedCheckpointError(RuntimeError):
    """A checkpoint holds objects that only a full (code-running) unpickling can load."""


class UnreadableCheckpointError(RuntimeError):
    """A checkpoint file that torch cannot read at all: cut short (a crash while writing, a copy broken off),
    empty, or not a checkpoint."""


def load_checkpoint(path: str, map_location: str | torch.device = "cpu", trust: bool = False) -> dict:
    """The checkpoint's contents. Without `trust`, only tensors and plain containers are unpickled; a file that
    holds anything else raises UntrustedCheckpointError naming the type (and nothing of it runs). A file torch
    cannot read raises UnreadableCheckpointError naming it and torch's reason."""
    try:
        if trust:
            return torch.load(path, map_location=map_location, weights_only=False)
        return torch.load(path, map_location=map_location, weights_only=True)
    except pickle.UnpicklingError as err:
        if trust or "GLOBAL" not in str(err) and "Weights only load failed" not in str(err):
            raise UnreadableCheckpointError(_unreadable(path, err)) from None
        found = re.search(r"GLOBAL ([\w.]+)", str(err))
        what = f"an object of type '{found.group(1)}'" if found else "objects other than tensors and containers"
        raise UntrustedCheckpointError(
            f"checkpoint '{path}' holds {what}, which loading would have to run code for; refused. If you trust "
            f"where the file comes from, load it with {TRUST_FLAG}.") from None
    except (RuntimeError, EOFError, ValueError, OSError) as err:  # a zip archive cut short fails in many ways
        if isinstance(err, FileNotFoundError):
            raise
        raise UnreadableCheckpointError(_unreadable(path, err)) from None


def _unreadable(path: str, err: Exception) -> str:
    # torch's first sentence (it goes on with advice for its own users)
    reason = str(err).strip().splitlines()[0].split(". ")[0] if str(err).strip() else type(err).__name__
    size = os.path.getsize(path) if os.path.exists(path) else 0
    return (f"checkpoint '{path}' cannot be read ({size:,} bytes; {reason}): it was cut short (a crash while "
            f"writing, a copy broken off) or is not a checkpoint")


def restore_runner(runner, checkpoint: dict, load_cfg: dict | None = None, strict: bool = True) -> None:
    """What rsl-rl's `OnPolicyRunner.load(path)` does, from contents loaded by `load_checkpoint` (its own
    `load` unpickles with weights_only=False); the runner continues at the iteration after the checkpoint's
    (rsl-rl's own `load` would repeat it)."""
    if runner.alg.load(checkpoint, load_cfg, strict):
        runner.current_learning_iteration = checkpoint["iter"] + 1
