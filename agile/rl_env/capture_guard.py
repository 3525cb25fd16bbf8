"""On the CPU, find what would break the GPU's captured env step.

On CUDA the env step is recorded once as a CUDA graph and replayed (`ManagerBasedRLEnvCfg.capture_step`): a term
that makes a tensor from host data or reads a device value on the host fails there (or, worse, is frozen into the
graph), and only there. `CaptureGuard` is a torch function mode that raises at the first such operation, naming
it and the line that called it, so that a term written and tested on a laptop is known to be safe for the GPU.
`ManagerBasedRLEnvCfg.check_capture_safety` runs every uncaptured env step after the warm-up under it.
"""

from __future__ import annotations

import os
import traceback

import torch
from torch.overrides import TorchFunctionMode

__all__ = ["CaptureGuard", "CaptureSafetyError"]

HOST_DATA = "makes a tensor from host data (a host-to-device copy): make it once at build time, or with "\
            "torch.zeros_like/full on the device"
HOST_READ = "reads a device value on the host (a synchronisation): keep the decision on the device with "\
            "torch.where or masked math"
DATA_SHAPE = "gives a shape that depends on the data (a host synchronisation): use masked math over all envs"

REFUSED: dict = {
    torch.tensor: HOST_DATA, torch.as_tensor: HOST_DATA, torch.asarray: HOST_DATA, torch.from_numpy: HOST_DATA,
    torch.Tensor.item: HOST_READ, torch.Tensor.tolist: HOST_READ, torch.Tensor.numpy: HOST_READ,
    torch.Tensor.cpu: HOST_READ, torch.Tensor.__bool__: HOST_READ, torch.Tensor.__int__: HOST_READ,
    torch.Tensor.__float__: HOST_READ, torch.Tensor.__index__: HOST_READ,
    torch.nonzero: DATA_SHAPE, torch.Tensor.nonzero: DATA_SHAPE, torch.argwhere: DATA_SHAPE,
    torch.masked_select: DATA_SHAPE, torch.Tensor.masked_select: DATA_SHAPE, torch.unique: DATA_SHAPE,
    torch.Tensor.unique: DATA_SHAPE,
}
"""The operations a CUDA graph capture refuses, with the reason given."""

TORCH_DIR = os.path.dirname(torch.__file__)


class CaptureSafetyError(RuntimeError):
    """An operation in the env step that a CUDA graph capture refuses."""


def _has_bool_index(index) -> bool:
    items = index if isinstance(index, tuple) else (index,)
    return any(isinstance(i, torch.Tensor) and i.dtype == torch.bool for i in items)


def _caller() -> str:
    """file:line (function) of the innermost frame outside torch and this module."""
    for frame in reversed(traceback.extract_stack()):
        if not frame.filename.startswith(TORCH_DIR) and frame.filename != __file__:
            return f"{frame.filename}:{frame.lineno} ({frame.name})"
    return "an unknown caller"


class CaptureGuard(TorchFunctionMode):
    """Raises `CaptureSafetyError` at the first operation of `REFUSED`, or at indexing with a boolean mask (a
    data-dependent shape), made inside the `with` block."""

    def __torch_function__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        reason = REFUSED.get(func)
        if reason == HOST_DATA and args and isinstance(args[0], torch.Tensor):
            reason = None  # from a tensor already on the device: a cast or a device copy, no host data
        if reason is None and func in (torch.Tensor.__getitem__, torch.Tensor.__setitem__) and len(args) > 1 \
                and _has_bool_index(args[1]):
            reason = DATA_SHAPE
        if reason is None and func is torch.where and len(args) + len(kwargs) == 1:
            reason = DATA_SHAPE
        if reason is not None:
            name = getattr(func, "__qualname__", getattr(func, "__name__", str(func)))
            name = name.replace("_VariableFunctionsClass.", "torch.")  # torch's own functions, as users write them
            if func in (torch.Tensor.__getitem__, torch.Tensor.__setitem__):
                name += " with a boolean mask"
            raise CaptureSafetyError(f"{name} at {_caller()} {reason}. The GPU env step is a CUDA graph "
                                     f"(ManagerBasedRLEnvCfg.capture_step), which refuses it.")
        return func(*args, **kwargs)
