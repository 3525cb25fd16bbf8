"""File-system checks shared by the caches."""

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
