"""The fallen-state dataset's disk cache: a file per key, the key a hash of everything the states depend on.

Kept free of the simulator so that it is tested on its own. A file is written whole or not at all (a temporary
file, then renamed); on loading, a file that is truncated, corrupt, not a fallen-state cache, or made for another
key (another robot, terrain or dataset config, or an older format) is reported and not used: the caller
collects again and overwrites it.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import torch

FORMAT_VERSION = 2
"""Bumped whenever what is stored or how it is collected changes: old files are then rebuilt. 2: collected with the
training aids off (a HeightTracking-G1 cache of version 1 holds robots hanging from the lift)."""
MAGIC = "agile-fallen-states"


def default_cache_dir() -> Path:
    """$AGILE_CACHE_DIR/fallen_states, else ~/.cache/agile/fallen_states."""
    root = os.environ.get("AGILE_CACHE_DIR") or os.path.join(os.path.expanduser("~"), ".cache", "agile")
    return Path(root) / "fallen_states"


def cache_key(inputs: dict) -> str:
    """A hex digest of `inputs` (JSON-able: configs as dicts, file contents as their own digests) and the format
    version. Equal inputs give equal keys in any process; any changed value gives another key."""
    text = json.dumps({"format_version": FORMAT_VERSION, **inputs}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def file_digest(path: str | Path) -> str:
    """The SHA-256 of a file's bytes (the robot model: a changed model file changes the key)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def cache_path(cache_dir: str | Path, task_name: str, key: str) -> Path:
    return Path(cache_dir) / f"{task_name}_{key}.pt"


def save_states(path: Path, key: str, states: dict[str, torch.Tensor]) -> None:
    """Write `states` (CPU tensors) under `key`, atomically."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp_path = path.with_name(f"{path.name}.tmp{os.getpid()}")
    torch.save({"magic": MAGIC, "format_version": FORMAT_VERSION, "key": key,
                "states": {name: value.detach().cpu() for name, value in states.items()}}, tmp_path)
    os.replace(tmp_path, path)


def load_states(path: Path, key: str, required: tuple[str, ...]) -> tuple[dict[str, torch.Tensor] | None, str]:
    """(the states, "") from a valid cache file for `key` holding every `required` tensor, else (None, why not)."""
    if not path.is_file():
        return None, "no cache file yet"
    try:
        contents = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:  # a truncated or corrupt file fails in many ways inside torch.load
        return None, f"unreadable ({type(err).__name__}: {err})"
    if not isinstance(contents, dict) or contents.get("magic") != MAGIC:
        return None, "not a fallen-state cache"
    if contents.get("format_version") != FORMAT_VERSION or contents.get("key") != key:
        return None, "made for another robot, terrain, dataset config or format version"
    states = contents.get("states")
    if not isinstance(states, dict) or any(not isinstance(states.get(name), torch.Tensor) for name in required):
        return None, f"incomplete (needs {', '.join(required)})"
    lengths = {states[name].shape[0] for name in required}
    if len(lengths) != 1:
        return None, "incomplete (its tensors hold different numbers of states)"
    return states, ""
