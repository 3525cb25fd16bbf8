"""Run an exported policy in plain MuJoCo (the C simulator, CPU), from its IO descriptor and the robot MJCF.

    agile export --task Velocity-G1-History-v0 --out exported/g1
    agile sim2mujoco --io exported/g1/io_descriptor.yaml --policy exported/g1/policy.pt \\
        --command 0.5 0 0 --episodes 3 --duration_s 10
    agile export --task Velocity-T1-v0 --format leapp --out exported/leapp
    agile sim2mujoco --bundle exported/leapp/Velocity-T1-v0/Velocity-T1-v0.yaml --episodes 10 --duration_s 20

Nothing of the training framework is used: observations and actions are rebuilt from the descriptor (or, for
a LEAPP bundle, computed by the bundle's own graph through LEAPP's runtime from raw MuJoCo state),
the joint torques come from the descriptor's gains and DC-motor limits (computed at the physics rate and
applied as joint forces), and the robot collides with a ground plane, with MuJoCo's own solver iterations
(--solver training: training's cap, unconverged contacts as in training). A recurrent policy carries its hidden
state from step to step and starts each episode from zeros. The actuator delays of training are not
modelled. Reports fall rate and velocity tracking errors like `agile eval` (and the base-height error for a
height command); writes JSON with --out. From Python: `sim2mujoco(io=..., policy=...)` or `sim2mujoco(bundle=...)`
returns the metrics.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
from agile.run.arguments import command
from agile.run import arguments
from agile.errors import AgileError
from agile.run.mujoco_commands import make_commands
from agile.deploy.mujoco_policy import (BundlePolicy, DescriptorPolicy, OnnxPolicy, TorchScriptPolicy,  # noqa: F401
                                     bundle_descriptor, read_bundle, yaml_load)
from agile.deploy.mujoco_robot import SOLVER_SETTINGS, Robot, build_model, rotate_inverse

IO_DESCRIPTOR_VERSION = 2  # what agile/rl_env/io_descriptor_file.py writes (this script does not import it)
FALL_TILT_RAD = math.radians(60.0)
FALL_HEIGHT_FRACTION = 0.5  # of the default root height


def run(descriptor: dict, mjcf: str, make_policy, episodes: int, duration_s: float, command=None,
        seed: int = 0, on_frame=None, height_ramp=None, solver: str = "mujoco") -> dict:
    """`make_policy(robot)` gives the controller (DescriptorPolicy or BundlePolicy): reset() at the start of an
    episode, then once per control step it sets the robot's joint targets from the MuJoCo state and the command
    (`agile.run.mujoco_commands`: drawn as in training, `command` fixed, or a `height_ramp` (top, bottom))."""
    import mujoco

    rng = np.random.default_rng(seed)
    model = build_model(descriptor, mjcf, solver)
    data = mujoco.MjData(model)
    robot = Robot(descriptor, model)
    policy = make_policy(robot)
    commands = make_commands(next(iter(descriptor["commands"].values())), rng, descriptor["control_dt_s"], command,
                             height_ramp)
    decimation = descriptor["decimation"]
    steps = int(round(duration_s / descriptor["control_dt_s"]))
    falls, lengths = 0, []
    # a fall: tilted over, or the root below half its lowest commanded height (a crouch is not a fall)
    fall_height_m = FALL_HEIGHT_FRACTION * min(descriptor["default_root_height_m"], commands.lowest_height_m)
    for _ in range(episodes):
        mujoco.mj_resetData(model, data)
        data.qpos[2] = descriptor["default_root_height_m"]
        data.qpos[robot.qpos_adr] = robot.default_q
        robot.target = robot.default_q.copy()
        mujoco.mj_forward(model, data)
        policy.reset()
        commands.start_episode(steps)
        for step in range(steps):
            policy(data, commands.command(step))
            for _ in range(decimation):
                data.qfrc_applied[robot.dof_adr] = robot.torque(data.qpos[robot.qpos_adr], data.qvel[robot.dof_adr])
                mujoco.mj_step(model, data)
            if on_frame is not None:
                on_frame(model, data)
            commands.measure(model, data, robot, step)
            gravity_z = rotate_inverse(data.qpos[3:7], np.array([0.0, 0.0, -1.0]))[2]
            tilt = math.acos(max(-1.0, min(1.0, -gravity_z)))
            if commands.ends_at_a_fall and (tilt > FALL_TILT_RAD or data.qpos[2] < fall_height_m):
                falls += 1
                break
        lengths.append((step + 1) * descriptor["control_dt_s"])
    return {"episodes": episodes, "falls": falls, "fall_rate": falls / episodes, **commands.metrics(),
            "mean_episode_length_s": float(np.mean(lengths))}


def default_mjcf(descriptor: dict) -> str:
    from agile.assets import asset_file
    from agile.assets.unitree_go1 import GO1_MODEL_FILE

    robots = {"t1.xml": "booster_t1/t1.xml", "g1_mjx.xml": "unitree_g1/g1_mjx.xml", "g1.xml": "unitree_g1/g1.xml"}
    name = descriptor["robot_model_file"]
    if name == os.path.basename(GO1_MODEL_FILE):  # shipped inside agile, not in the humanoid asset package
        return GO1_MODEL_FILE
    if name not in robots:
        raise AgileError(f"pass --mjcf for robot file '{name}'")
    return asset_file(robots[name])


class MujocoVideo:
    """Renders the MuJoCo rollout headless: the MuJoCo pose is copied into a Newton model of the same MJCF
    (visual geoms) and drawn by Newton's Warp ray-tracing camera, so no OpenGL context is needed."""

    def __init__(self, path: str, mjcf: str, fps: int):
        import newton

        from agile.run.recorders import CameraVideo

        builder = newton.ModelBuilder()
        builder.add_mjcf(mjcf, floating=True, parse_visuals=True)
        builder.add_ground_plane()
        self.model = builder.finalize(device="cpu")
        self.state = self.model.state()
        self.video = CameraVideo(path, self.model, fps)
        self.newton = newton

    def __call__(self, mj_model, data) -> None:
        if data.qpos.shape[0] != self.model.joint_coord_count:
            raise AgileError(f"MuJoCo has {data.qpos.shape[0]} position coordinates, Newton's import of the same MJCF "
                             f"{self.model.joint_coord_count}: cannot copy the pose for the video")
        q = data.qpos.astype(np.float32)
        q[3:7] = q[[4, 5, 6, 3]]  # free-joint quaternion: MuJoCo w, x, y, z -> Newton x, y, z, w
        self.state.joint_q.assign(q)
        self.newton.eval_fk(self.model, self.state.joint_q, self.state.joint_qd, self.state)
        self.video.write_frame(self.state, data.qpos[:3])

    def close(self) -> None:
        self.video.close()


def sim2mujoco(*, bundle: str | None = None, io: str | None = None, policy: str | None = None,
               mjcf: str | None = None, episodes: int = 3, duration_s: float = 10.0, command=None, height_ramp=None,
               seed: int = 0, video: str | None = None, solver: str = "mujoco") -> dict:
    """Run an exported policy in plain MuJoCo for `episodes` episodes of `duration_s` from the default pose: a LEAPP
    `bundle` (its TASK.yaml), or the IO descriptor `io` with the TorchScript or ONNX file `policy`. `mjcf`: the robot
    (default: the asset package's file the descriptor names); `command`: a fixed command (VX VY WZ [HEIGHT], or one
    HEIGHT), `height_ramp`: (top, bottom) of a height command going down and up, else commands drawn per episode with
    `seed` as in training; `video`: the rollout rendered headless into this mp4; `solver`: MuJoCo's own solver
    iterations ("mujoco") or training's cap ("training", `build_model`). Returns the metrics (fall rate,
    tracking errors) and what was run. Raises AgileError for inputs it cannot run, before anything runs."""
    by_bundle = bundle is not None and io is None and policy is None
    by_descriptor = bundle is None and io is not None and policy is not None
    if not (by_bundle or by_descriptor):
        raise AgileError("give either --bundle, or --io and --policy")
    if solver not in SOLVER_SETTINGS:
        raise AgileError(f"solver must be one of {', '.join(SOLVER_SETTINGS)}, got {solver!r}")
    if bundle:
        descriptor = bundle_descriptor(read_bundle(bundle))

        def make_policy(robot):
            return BundlePolicy(bundle, robot)
    else:
        descriptor = yaml_load(io)
        if descriptor.get("version") != IO_DESCRIPTOR_VERSION:
            raise AgileError(f"{io} is an IO descriptor of version {descriptor.get('version')}, this script reads "
                             f"version {IO_DESCRIPTOR_VERSION}: export the policy again with agile export")
        not_joint_targets = [f"{a['name']} ({a['type']})" for a in descriptor["actions"] if "offset" not in a]
        if not_joint_targets:
            raise AgileError(f"{io}: sim2mujoco runs policies whose actions are joint targets (action · scale + "
                             f"offset); these action terms are not: {not_joint_targets}")

        def make_policy(robot):
            return DescriptorPolicy(descriptor, robot, policy)
    try:  # the command and the height ramp checked against the policy's command before anything runs
        make_commands(next(iter(descriptor["commands"].values())), np.random.default_rng(seed),
                      descriptor["control_dt_s"], command, height_ramp)
    except ValueError as err:
        raise AgileError(str(err))
    mjcf = mjcf or default_mjcf(descriptor)
    recorder = MujocoVideo(video, mjcf, round(1.0 / descriptor["control_dt_s"])) if video else None
    try:
        metrics = run(descriptor, mjcf, make_policy, episodes, duration_s, command, seed, on_frame=recorder,
                      height_ramp=height_ramp, solver=solver)
    finally:
        if recorder is not None:
            recorder.close()
            print(f"[sim2mujoco] video ({recorder.video.frames} frames) written to {video}")
    metrics.update({"io_descriptor": io, "policy": policy, "bundle": bundle, "mjcf": mjcf, "command": command,
                    "duration_s": duration_s, "solver": solver})
    return metrics


@command
def main(argv=None) -> None:
    parser = arguments.new_parser(__doc__)
    parser.add_argument("--io", default=None, help="io_descriptor.yaml written by agile export (with --policy)")
    parser.add_argument("--policy", default=None, help="policy.pt (TorchScript) or policy.onnx (with --io)")
    parser.add_argument("--bundle", default=None, metavar="TASK.yaml",
                        help="a LEAPP bundle (agile export --format leapp), run by LEAPP's runtime; instead of "
                             "--io and --policy")
    parser.add_argument("--mjcf", default=None, help="robot MJCF (default: the asset package's file)")
    parser.add_argument("--episodes", type=int, default=3, help="episodes to run, each from the default pose")
    parser.add_argument("--duration_s", type=float, default=10.0, help="length of each episode [s]")
    parser.add_argument("--command", type=float, nargs="+", default=None, metavar="V",
                        help="fixed command VX VY WZ [HEIGHT], or one HEIGHT for a height command (default: drawn "
                             "per episode as in training)")
    parser.add_argument("--height_ramp", type=float, nargs=2, default=None, metavar=("TOP", "BOTTOM"),
                        help="a height command going TOP -> BOTTOM -> TOP over each episode, held at TOP for its last "
                             "second; reports the height error and the final height (HeightTracking-G1)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the commands drawn per episode")
    parser.add_argument("--solver", choices=SOLVER_SETTINGS, default="mujoco",
                        help="MuJoCo's own solver iterations (100, line search 50), or training's cap from the IO "
                             "descriptor (10, 20: unconverged contacts, as the policy was trained)")
    parser.add_argument("--out", default=None, help="write the metrics as JSON here")
    parser.add_argument("--video", default=None, metavar="PATH.mp4",
                        help="render the rollout headless into an mp4 (camera following the robot)")
    args = arguments.parse(parser, argv)
    metrics = sim2mujoco(bundle=args.bundle, io=args.io, policy=args.policy, mjcf=args.mjcf, episodes=args.episodes,
                         duration_s=args.duration_s, command=args.command, height_ramp=args.height_ramp,
                         seed=args.seed, video=args.video, solver=args.solver)
    print(json.dumps(metrics, indent=2))
    if args.out:
        Path(args.out).write_text(json.dumps(metrics, indent=2))


if __name__ == "__main__":
    main()
