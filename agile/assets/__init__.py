"""Robot definitions: model file, joint groups, default pose and actuator parameters."""

from agile.assets.files import asset_file

__all__ = ["asset_file"]
