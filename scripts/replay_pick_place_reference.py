"""Drive the upper body of PickPlace-G1-v0 along the reference and report whether the cube is grasped, lifted and
put down at the goal: the physics check under the task (can the hand hold the cube at all?).

    python scripts/replay_pick_place_reference.py                          # every shipped trajectory, 4 envs, CPU
    python scripts/replay_pick_place_reference.py --trajectories pick_place_left --num_envs 2
    python scripts/replay_pick_place_reference.py --gravity_compensation --hold_anchor
    python scripts/replay_pick_place_reference.py --gravity_compensation --fixed_root   # the reference's feasibility
    python scripts/replay_pick_place_reference.py env.actions.upper_body_joint_pos.scale=0.1   # any env override

Every env starts at trajectory frame 0. Each env step the 17 upper-body joint targets are set to the reference
joints of the current frame (through the task's delta action: (target - current target) / scale) and the frozen
lower body is told to stand (vx, vy, wz = 0, height 0.72 m). The task is otherwise as registered (its friction
and cube-position randomisation included).

The arm and waist are soft PD joints (shoulder and elbow kp 14 N·m/rad): with the reference as their targets they
sag under gravity. `--gravity_compensation` adds the static gravity torque over kp to the waist and arm targets
(the torque from CPU MuJoCo on the robot's model at its measured state), so that the joints, not only their
targets, are at the reference; the fingers keep the reference, so they squeeze with kp × the angle the cube holds
them short of it. `--hold_anchor` steers the lower body (vx, vy, wz) toward the reference's torso position and
heading. These are actions the policy has too.

`--fixed_root` checks the reference itself: the robot's root fixed where the reference was solved (where the
frozen lower body stands, `make_pick_place_trajectories.STANDING_ROOT_*`) and the waist targets not clipped to the
task's ±0.1 rad (the reaching arm bends the soft waist forward 0.2-0.4 rad, more than a ±0.1 rad target can
hold). With `--gravity_compensation` the joints then follow the reference and the hand meets the cube where the
reference says: what is left is the grasp's physics (contacts, friction, finger force).

Printed: per phase and env, the cube's height above its start, the grasp point-cube distance and the right-hand finger
error; per env, the highest lift during the carry, how the episode ended and the command's episode metrics
(object_lifted, object_goal_distance_m, object_at_goal).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import gymnasium as gym
import mujoco
import numpy as np
import torch

import agile.tasks  # noqa: F401  (registers the tasks)
from agile.assets.unitree_g1_with_hands import PALM_BODY, GRASP_POINT_M
from agile.motion.trajectory_file import PHASES
from agile.tasks.pick_place import mdp
from agile.rl_env.managers import SceneEntityCfg
from agile.utils.math import quat_rotate_inverse
from make_pick_place_trajectories import STANDING_ROOT_PITCH_RAD, STANDING_ROOT_POS_M

TASK = "PickPlace-G1-v0"
SHIPPED = ["pick_place_left", "pick_place_near_left", "pick_place_right"]
STANDING_HEIGHT_M = 0.72
"""The frozen lower body's height command: the top of its range, where it was trained to stand."""
ANCHOR_GAIN_PER_S = 3.0
"""`--hold_anchor`: lower-body velocity command [m/s, rad/s] per metre (radian) of torso position (heading) error."""
LIFT_MARGIN_M = 0.02
"""The task's `object_lifted` margin: the cube counts as lifted this far above its start."""


@dataclass
class Replay:
    """Per env step and env (the episode's steps only; an env that ended early stops being recorded)."""

    trajectory: str
    phase: torch.Tensor              # (T, N) index into PHASES
    cube_lift_m: torch.Tensor        # (T, N) cube height above its start [m]
    grasp_cube_m: torch.Tensor       # (T, N) the hand's grasp point to the cube's centre [m]
    finger_error_rad: torch.Tensor   # (T, N) mean |q - q_ref| over the 7 right-hand joints
    valid: torch.Tensor              # (T, N) the env is still in its first episode at this step
    ended_step: list[int]            # per env: the env step its episode ended
    ended_by: list[str]              # per env: the termination terms that ended it
    metrics: dict[str, list[float]]  # "<term>/<name>" of each env's episode (env.last_episode_metrics)

    def carry_max(self, values: torch.Tensor) -> torch.Tensor:
        """(N,) the largest of (T, N) `values` over each env's carry phase (-inf if it never reached the carry)."""
        carry = (self.phase == PHASES.index("carry")) & self.valid
        return torch.where(carry, values, -torch.inf).amax(dim=0)

    def carry_lift_m(self) -> torch.Tensor:
        """(N,) the highest cube lift over each env's carry phase [m]."""
        return self.carry_max(self.cube_lift_m)

    def carry_grasp_distance_m(self) -> torch.Tensor:
        """(N,) the farthest the cube's centre is from the hand's grasp point over each env's carry phase [m]."""
        return self.carry_max(self.grasp_cube_m)


class GravityTorque:
    """The static gravity torque on some joints of the robot at its measured state [N·m], from CPU MuJoCo on the
    robot's own model file (a policy could learn this function of the state; the replay computes it)."""

    def __init__(self, robot, joint_ids: torch.Tensor):
        self.robot = robot
        self.model = mujoco.MjModel.from_xml_path(robot.cfg.model_file)
        self.data = mujoco.MjData(self.model)
        self.qpos_adr = np.array([self.model.joint(n).qposadr[0] for n in robot.joint_names])
        self.dof_adr = np.array([self.model.joint(robot.joint_names[i]).dofadr[0] for i in joint_ids.tolist()])

    def __call__(self) -> torch.Tensor:
        root_pos = self.robot.root_pos_w.cpu().numpy()
        root_quat_xyzw = self.robot.root_quat_w.cpu().numpy()
        joint_pos = self.robot.joint_pos.cpu().numpy()
        torque = np.zeros((len(joint_pos), len(self.dof_adr)))
        for env in range(len(joint_pos)):
            self.data.qpos[:] = 0.0
            self.data.qpos[:3] = root_pos[env]
            self.data.qpos[3:7] = np.roll(root_quat_xyzw[env], 1)  # MuJoCo: w, x, y, z
            self.data.qpos[self.qpos_adr] = joint_pos[env]
            self.data.qvel[:] = 0.0  # at rest: the bias force is gravity alone
            mujoco.mj_forward(self.model, self.data)
            torque[env] = self.data.qfrc_bias[self.dof_adr]
        return torch.as_tensor(torque, dtype=torch.float32, device=self.robot.joint_pos.device)


def fixed_root_overrides() -> list[str]:
    """The robot's root fixed where the reference was solved; the waist targets within the joints' soft limits only."""
    x, y, z = STANDING_ROOT_POS_M.tolist()
    half_pitch = STANDING_ROOT_PITCH_RAD / 2
    return ["scene.entities.robot.fixed_base=true", f"scene.entities.robot.init_pos_m=[{x},{y},{z}]",
            f"scene.entities.robot.init_rot_xyzw=[0.0,{np.sin(half_pitch)},0.0,{np.cos(half_pitch)}]",
            "actions.upper_body_joint_pos.joint_limits={}"]


def heading_rad(quat_xyzw: torch.Tensor) -> torch.Tensor:
    """(N,) the yaw of orientations (x, y, z, w) [rad]."""
    x, y, z, w = quat_xyzw.unbind(-1)
    return torch.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def make_env(trajectory: str, num_envs: int, device: str, overrides: list[str], fixed_root: bool = False):
    """The task with one trajectory, every episode from frame 0."""
    overrides = [f'commands.reference.trajectory_files=["{trajectory}"]', "commands.reference.start_step_range=[0,0]",
                 *(fixed_root_overrides() if fixed_root else []), *overrides]
    return gym.make(TASK, num_envs=num_envs, device=device, overrides=overrides).unwrapped


def replay(env, trajectory: str, gravity_compensation: bool = False, hold_anchor: bool = False,
           num_steps: int | None = None) -> Replay:
    """One episode of reference replay in every env: the whole 8 s unless it ends early, or `num_steps` env steps."""
    reference = env.command_manager.get_term("reference")
    upper = env.action_manager.get_term("upper_body_joint_pos")
    robot, cube = env.scene["robot"], env.scene["object"]
    palm = SceneEntityCfg("robot", body_names=PALM_BODY)
    palm.resolve(env)
    hand = torch.tensor([i for i, n in enumerate(reference.joint_names) if n.startswith("right_hand_")])
    # the reference joints in the action's joint order (both are the task's 17, the order may differ)
    order = torch.tensor([reference.joint_names.index(n) for n in upper.joint_names], device=env.device)
    arm = torch.tensor([not n.startswith("right_hand_") for n in upper.joint_names], device=env.device)
    stiffness = robot.joint_stiffness[:, upper.joint_ids]
    gravity = GravityTorque(robot, upper.joint_ids) if gravity_compensation else None
    lower = torch.zeros(env.num_envs, 4, device=env.device)
    lower[:, 3] = STANDING_HEIGHT_M

    env.reset()
    start_z = cube.root_pos_w[:, 2].clone()
    n, steps = env.num_envs, num_steps or env.max_episode_length
    rows = {key: torch.zeros(steps, n) for key in ("phase", "lift", "grasp", "finger", "valid")}
    running = torch.ones(n, dtype=torch.bool)
    ended_step, ended_by = [steps] * n, ["(still running)"] * n
    metrics = {key: [float("nan")] * n for key in env.last_episode_metrics}
    for step in range(steps):
        # recorded before the step: after it, an ended env has been reset already
        grasp_pos, _ = mdp.palm_pose_w(env, palm, GRASP_POINT_M)
        rows["phase"][step] = reference.phase.float().cpu()
        rows["lift"][step] = (cube.root_pos_w[:, 2] - start_z).cpu()
        rows["grasp"][step] = torch.linalg.norm(cube.root_pos_w - grasp_pos, dim=-1).cpu()
        error = (reference.robot_joint_pos - reference.joint_pos)[:, hand].abs().mean(dim=-1)
        rows["finger"][step] = error.cpu()
        rows["valid"][step] = running.float()

        targets_rad = reference.joint_pos[:, order]
        if gravity is not None:  # the PD's steady error under gravity is torque / kp: aim that much further
            targets_rad = targets_rad + torch.where(arm, gravity() / stiffness, 0.0)
        if hold_anchor:  # the env clips the command to the lower body's range
            error_b = quat_rotate_inverse(robot.root_quat_w, reference.anchor_pos_w - reference.robot_anchor_pos_w)
            lower[:, :2] = ANCHOR_GAIN_PER_S * error_b[:, :2]
            yaw_error = heading_rad(reference.anchor_quat_w) - heading_rad(reference.robot_anchor_quat_w)
            lower[:, 2] = ANCHOR_GAIN_PER_S * torch.atan2(torch.sin(yaw_error), torch.cos(yaw_error))
        env.step(torch.cat([upper.actions_for_targets(targets_rad), lower], dim=-1))

        ended = env.reset_buf.cpu() & running
        for i in torch.nonzero(ended).flatten().tolist():
            ended_step[i] = step + 1
            ended_by[i] = ",".join(name for name, done in env.termination_manager.term_dones.items()
                                   if bool(done[i])) or "sim_unstable/invalid_action"
            for key, value in env.last_episode_metrics.items():
                metrics[key][i] = float(value[i])
        running &= ~ended
    return Replay(trajectory, rows["phase"].long(), rows["lift"], rows["grasp"], rows["finger"],
                  rows["valid"].bool(), ended_step, ended_by, metrics)


def report(result: Replay, step_dt_s: float) -> None:
    n = result.phase.shape[1]
    print(f"\n=== {result.trajectory} ({n} envs) ===")
    print("phase     time [s]     cube lift [cm] (max, per env)  grasp-cube [cm] (min)   finger error [rad] (mean)")
    for index, phase in enumerate(PHASES):
        mask = (result.phase == index) & result.valid
        if not mask.any():
            continue
        steps = torch.nonzero(mask.any(dim=1)).flatten()
        lift = torch.where(mask, result.cube_lift_m, -torch.inf).amax(dim=0) * 100
        grasp = torch.where(mask, result.grasp_cube_m, torch.inf).amin(dim=0) * 100
        finger = (result.finger_error_rad * mask).sum(dim=0) / mask.sum(dim=0).clamp(min=1)
        print(f"{phase:<9} {steps[0] * step_dt_s:4.2f}-{(steps[-1] + 1) * step_dt_s:4.2f}  "
              f"{' '.join(f'{v:6.1f}' for v in lift.tolist()):<31} {' '.join(f'{v:5.1f}' for v in grasp.tolist()):<23} "
              f"{' '.join(f'{v:5.2f}' for v in finger.tolist())}")
    carry = result.carry_lift_m()
    for i in range(n):
        lifted = "LIFTED" if carry[i] > LIFT_MARGIN_M else "not lifted"
        metrics = ", ".join(f"{k.split('/')[-1]} {v[i]:.3f}" for k, v in result.metrics.items())
        print(f"env {i}: carry max lift {carry[i] * 100:5.1f} cm ({lifted}); ended at "
              f"{result.ended_step[i] * step_dt_s:.2f} s by {result.ended_by[i]}; {metrics}")


def main(argv=None) -> list[Replay]:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--trajectories", nargs="+", default=SHIPPED, help="shipped names or paths")
    parser.add_argument("--num_envs", type=int, default=4)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--gravity_compensation", action="store_true",
                        help="add the static gravity torque / kp to the waist and arm targets")
    parser.add_argument("--hold_anchor", action="store_true",
                        help="steer the lower body (vx, vy, wz) toward the reference torso position and heading")
    parser.add_argument("--fixed_root", action="store_true",
                        help="fix the root where the reference was solved and do not clip the waist targets")
    parser.add_argument("overrides", nargs="*", help="env config overrides, e.g. env.sim.physics_dt_s=0.002")
    args = parser.parse_args(argv)
    results = []
    for trajectory in args.trajectories:
        env = make_env(trajectory, args.num_envs, args.device, args.overrides, args.fixed_root)
        result = replay(env, trajectory, args.gravity_compensation, args.hold_anchor)
        report(result, env.step_dt)
        results.append(result)
        env.close()
    lifted = torch.cat([r.carry_lift_m() > LIFT_MARGIN_M for r in results])
    at_goal = [v for r in results for v in r.metrics.get("reference/object_at_goal", [])]
    print(f"\nlifted > {LIFT_MARGIN_M * 100:.0f} cm during the carry in {int(lifted.sum())} of {len(lifted)} episodes; "
          f"at the goal at the end in {int(np.nansum(at_goal))} of {len(at_goal)}")
    return results


if __name__ == "__main__":
    main()
