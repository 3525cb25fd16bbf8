"""What the G1's privileged walking MDPs share: Velocity-G1-Teacher (AGILE `G1LowerVelocityEnvCfg`) and the
Velocity-Height-G1 tasks (AGILE `locomotion_height/g1`, which build on the velocity family): the legs and feet, the
G1 on less-rough terrain with its foot scans, and the privileged policy and critic observation groups. Here, in the
velocity family, so that the Velocity-Height tasks build on the velocity family and never the other way round."""

from __future__ import annotations

from agile.assets.unitree_g1 import LOWER_BODY_JOINTS, g1_armature_actuators, g1_robot_cfg
from agile.rl_env.managers import ObsGroup, ObsTerm, SceneEntityCfg, Unoise
from agile.sim.scene_cfg import HeightScannerCfg, SceneCfg
from agile.sim.terrain import LESS_ROUGH_TERRAIN_CFG
from agile.tasks.velocity import mdp
from agile.tasks.velocity.velocity_common import BASE_HEIGHT_SENSOR, CONTACT_SENSOR, velocity_scene_cfg
from agile.utils.config import configclass

COMMAND = "base_velocity"
LEGS = SceneEntityCfg("robot", joint_names=LOWER_BODY_JOINTS)
"""The 12 joints the policy drives: hips, knees, ankles."""
FOOT_BODIES = ["left_ankle_roll_link", "right_ankle_roll_link"]
FEET = SceneEntityCfg("robot", body_names=FOOT_BODIES, preserve_order=True)
FEET_CONTACT = SceneEntityCfg(CONTACT_SENSOR, body_names=FOOT_BODIES, preserve_order=True)
TRUNK_CONTACT_BODIES = ["torso_link", "pelvis", ".*_hip_.*_link", ".*_knee_link"]
LEFT_FOOT_SCANNER, RIGHT_FOOT_SCANNER = "height_scanner_left_foot", "height_scanner_right_foot"
STANDING_HEIGHT_M = 0.72
"""G1's pelvis height standing (AGILE `DEFAULT_PELVIS_HEIGHT`): the harness target and the walking height."""


# -- scene ---------------------------------------------------------------------------------------------

def foot_height_scanner_cfg(foot_body: str) -> HeightScannerCfg:
    """AGILE: a 0.3 × 0.2 m grid of rays every 5 cm (7 × 5) centred 5 cm ahead of the ankle roll link."""
    return HeightScannerCfg(entity="robot", body_name=foot_body, offset_xy_m=(0.05, 0.0), size_m=(0.3, 0.2),
                            resolution_m=0.05)


def velocity_height_scene_cfg(actuators: dict | None = None) -> SceneCfg:
    """The G1 (FEB26 teacher: armature-derived gains, delayed implicit PD on legs and feet) on the less-rough
    terrain, a contact sensor on the feet and on every body whose contact ends an episode, the base-height ray
    and the foot scans."""
    return velocity_scene_cfg(
        g1_robot_cfg(g1_armature_actuators() if actuators is None else actuators), LESS_ROUGH_TERRAIN_CFG,
        base_body="pelvis", sensed_bodies=[*TRUNK_CONTACT_BODIES, *FOOT_BODIES],
        ground_friction=0.4,  # the bottom of this task's robot friction range (see velocity_scene_cfg)
        extra_height_scanners={LEFT_FOOT_SCANNER: foot_height_scanner_cfg(FOOT_BODIES[0]),
                               RIGHT_FOOT_SCANNER: foot_height_scanner_cfg(FOOT_BODIES[1])})


# -- observations --------------------------------------------------------------------------------------

@configclass
class PrivilegedPolicyObsCfg(ObsGroup):
    """AGILE `PrivilegedVelocityPolicyCfg`: noisy, one tensor per term, no history; sees its base velocity."""

    concatenate_terms = False
    enable_corruption = True
    velocity_height_commands = ObsTerm(func=mdp.generated_commands, params={"command_name": COMMAND})
    base_lin_vel = ObsTerm(func=mdp.base_lin_vel, noise=Unoise(-0.1, 0.1))
    base_ang_vel = ObsTerm(func=mdp.base_ang_vel, noise=Unoise(-0.2, 0.2))
    projected_gravity = ObsTerm(func=mdp.projected_gravity, noise=Unoise(-0.01, 0.01))
    joint_pos = ObsTerm(func=mdp.joint_pos_rel, noise=Unoise(-0.01, 0.01))
    joint_vel = ObsTerm(func=mdp.joint_vel_rel, scale=0.1, noise=Unoise(-1.5, 1.5))
    actions = ObsTerm(func=mdp.last_action, clip=(-10.0, 10.0))


@configclass
class PrivilegedCriticObsCfg(ObsGroup):
    """AGILE `PrivilegedVelocityCriticCfg`: noise-free, plus the base height and the terrain under the feet."""

    concatenate_terms = False
    velocity_height_commands = ObsTerm(func=mdp.generated_commands, params={"command_name": COMMAND})
    base_lin_vel = ObsTerm(func=mdp.base_lin_vel)
    base_ang_vel = ObsTerm(func=mdp.base_ang_vel)
    projected_gravity = ObsTerm(func=mdp.projected_gravity)
    joint_pos = ObsTerm(func=mdp.joint_pos_rel)
    joint_vel = ObsTerm(func=mdp.joint_vel_rel, scale=0.1)
    actions = ObsTerm(func=mdp.last_action, clip=(-10.0, 10.0))
    base_height = ObsTerm(func=mdp.base_height_from_sensor, params={"sensor_name": BASE_HEIGHT_SENSOR},
                          clip=(-10.0, 10.0))
    height_scan_feet = ObsTerm(func=mdp.height_scan_feet, clip=(-1.0, 1.0),
                               params={"left_sensor_name": LEFT_FOOT_SCANNER, "right_sensor_name": RIGHT_FOOT_SCANNER})
