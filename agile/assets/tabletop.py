"""A table in front of the robot and a cube on it: the props of pick-and-place (AGILE: a table USD and a DexCube
or YCB soup can). Positions are in the env frame (the robot's root starts above the origin, facing +x)."""

from __future__ import annotations

from agile.sim.scene_cfg import BoxShapeCfg, RigidObjectCfg

TABLE_TOP_HEIGHT_M = 0.75
TABLE_SIZE_M = (0.5, 1.0, TABLE_TOP_HEIGHT_M)
"""Depth (x), width (y), height (z): a solid block from the ground to the top."""
TABLE_FRONT_EDGE_X_M = 0.28
"""The table's near edge, clear of the robot's knees and hands at its default pose: the index fingertips hang at
x 0.27 m from the spawned root, 0.24 m once the robot stands (0.22 put them 3-5 cm into the table's front, so the
held-still left hand pushed on it all episode and the right hand had to rise through the table top)."""
CUBE_EDGE_M = 0.06
"""AGILE's DexCube."""
CUBE_MASS_KG = 0.1
CUBE_START_POS_M = (0.33, -0.12, TABLE_TOP_HEIGHT_M + CUBE_EDGE_M / 2)
"""Where every shipped trajectory picks the cube up: in front of the right hand, resting on the table."""
TABLE_COLOR_RGB = (0.55, 0.42, 0.30)
CUBE_COLOR_RGB = (0.85, 0.15, 0.10)
"""A red cube on a wooden table: apart in a camera image, whatever the light."""
TABLE_PALETTE_RGB = ((0.55, 0.42, 0.30), (0.70, 0.55, 0.38), (0.36, 0.25, 0.17), (0.82, 0.80, 0.76),
                     (0.45, 0.46, 0.48), (0.18, 0.18, 0.20), (0.62, 0.50, 0.44))
"""Table tops a recording draws from, one per episode: light, mid and dark wood, white, grey and black laminate."""
CUBE_PALETTE_RGB = ((0.85, 0.15, 0.10), (0.12, 0.55, 0.20), (0.12, 0.30, 0.80), (0.95, 0.80, 0.10),
                    (0.95, 0.45, 0.05), (0.55, 0.20, 0.65))
"""Cube colours a recording draws from, one per episode: red, green, blue, yellow, orange, purple."""


def table_cfg() -> RigidObjectCfg:
    x_m = TABLE_FRONT_EDGE_X_M + TABLE_SIZE_M[0] / 2
    return RigidObjectCfg(shape=BoxShapeCfg(size_m=TABLE_SIZE_M), body_type="fixed", friction=0.8,
                          init_pos_m=(x_m, 0.0, TABLE_SIZE_M[2] / 2), color_rgb=TABLE_COLOR_RGB)


def cube_cfg() -> RigidObjectCfg:
    return RigidObjectCfg(shape=BoxShapeCfg(size_m=(CUBE_EDGE_M,) * 3), body_type="dynamic", mass_kg=CUBE_MASS_KG,
                          friction=1.0, init_pos_m=CUBE_START_POS_M, color_rgb=CUBE_COLOR_RGB)
