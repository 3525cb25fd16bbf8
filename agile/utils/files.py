"""File-system helpers: checks shared by the caches, and finding a data file shipped with agile."""

from __future__ import annotations

import os
import stat
import warnings
from pathlib import Path


def untrusted_folder_reason(folder: Path) -> str | None:
    """Why files in `folder` could have been put there by someone else (world-writable, or another user's), or
    None when only the current user can write there."""
    info = folder.stat()
    if info.st_mode & stat.S_IWOTH:
        return "it is world-writable"
    if hasattr(os, "getuid") and info.st_uid != os.getuid():
        return f"it belongs to another user (uid {info.st_uid})"
    return None


def warn_if_untrusted_folder(folder: Path, what: str) -> None:
    """Warn before loading `what` from a folder that other users can write to: they could have replaced it."""
    reason = untrusted_folder_reason(folder)
    if reason is not None:
        warnings.warn(f"loading {what} from {folder}, but {reason}: another user could have replaced its files. "
                      f"Point AGILE_CACHE_DIR at a folder of your own.", stacklevel=2)


def resolve_shipped_file(name: str | Path, shipped_dir: Path, suffix: str, kind: str) -> Path:
    """`name` as a path, else, for a bare name (no folder in it), as a file of `shipped_dir` (with or without
    `suffix`, e.g. ".npz"); the error names `kind` (e.g. "motion") and lists the shipped ones. A missing path
    with a folder is an error, not the shipped file of the same name: that would train on another file than
    the one the user named."""
    path = Path(name)
    if path.is_file():
        return path
    shipped = sorted(p.stem for p in shipped_dir.glob(f"*{suffix}"))
    if path.parent != Path("."):
        raise FileNotFoundError(f"{kind} file '{name}' not found. Shipped {kind} files (by name): {shipped}")
    for candidate in (shipped_dir / path.name, shipped_dir / f"{path.name}{suffix}"):
        if candidate.is_file():
            return candidate
    raise FileNotFoundError(f"{kind} file '{name}' not found (neither a path nor a shipped {kind}). "
                            f"Shipped {kind} files: {shipped}")
