"""Reference motions: the motion file format and the converter from retargeted CSVs."""

from agile.motion.motion_file import (FORMAT_VERSION, SHIPPED_MOTIONS_DIR, MotionData, check_names_match,
                                      load_motion, resolve_motion_file, save_motion)

__all__ = ["FORMAT_VERSION", "SHIPPED_MOTIONS_DIR", "MotionData", "check_names_match", "load_motion",
           "resolve_motion_file", "save_motion"]
