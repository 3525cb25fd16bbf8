"""Blocks shared by the stand-up tasks (StandUp-T1, HeightTracking-G1), with the robot's bodies as arguments."""

from __future__ import annotations

from agile.rl_env.fallen_states import FallenStateDatasetCfg
from agile.rl_env.managers import EventTerm
from agile.tasks.stand_up import mdp
from agile.tasks.velocity.velocity_common import VelocityEventsCfg, velocity_events_cfg


def stand_up_events_cfg(base_body: str, base_mass_add_kg: tuple[float, float],
                        base_com_range_m: dict[str, tuple[float, float]], extremity_bodies: list[str],
                        standing_ratio: float) -> VelocityEventsCfg:
    """The velocity tasks' randomisation and disturbances, harder pushes (every 0-10 s, 1 m/s, 0.5 rad/s), and
    episodes started from the fallen-state dataset (a share `standing_ratio` standing) instead of the default
    pose."""
    events = velocity_events_cfg(base_body=base_body, base_mass_add_kg=base_mass_add_kg,
                                 base_com_range_m=base_com_range_m, extremity_bodies=extremity_bodies)
    events.push_robot.interval_range_s = (0.0, 10.0)
    events.push_robot.params["velocity_range"] = {"x": (-1.0, 1.0), "y": (-1.0, 1.0), "roll": (-0.5, 0.5),
                                                  "pitch": (-0.5, 0.5), "yaw": (-0.5, 0.5)}
    events.reset_base = EventTerm(func=mdp.reset_from_fallen_dataset, mode="reset",
                                  params={"standing_ratio": standing_ratio, "dataset": FallenStateDatasetCfg()})
    events.reset_robot_joints = None  # the dataset's states hold the joints; standing envs keep the default pose
    return events
