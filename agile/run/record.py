"""Record demonstrations: a policy runs a recording task (e.g. PickPlace-G1-Record-v0) and every episode it plays is
written as a LeRobot dataset in NVIDIA GR00T's layout (see agile/run/lerobot_dataset.py and docs/howto/record.md).

    agile record --task PickPlace-G1-Record-v0 --checkpoint model.pt --num_envs 16 --num_episodes 100 --out demos/
    agile record --task PickPlace-G1-Record-v0 --num_envs 4 --num_episodes 2 --out demos/   # the shipped policy

Per control step (the task's rate: fps = 1 / step_dt) the dataset holds the task's `record` observation group
before the step (its image terms as videos, its vector terms concatenated as `observation.state`), the action
taken, as each action term records it (`demonstration_action`: absolute joint targets, a lower-body command), the
reward and whether the episode ended. Every episode is its own (an early end too); episodes still running when
`--num_episodes` are written are dropped. The scene's light changes direction and brightness about every 1.2 s
(`--fixed_light` keeps it); each episode draws its props' colours from the task's palettes (`color_palettes` in its
registration: the table top and the cube; `--fixed_colors` keeps the scene's).
"""

from __future__ import annotations

import importlib.util
import math
import os
import time

from agile.run.arguments import command
from agile.run import arguments, task_setup
from agile.errors import AgileError

RECORD_GROUP = "record"
LIGHT_CHANGE_STEPS = 60


def recording_layout(env):
    """(state slices, video shapes {key: (height, width)}, action slices) of an env's `record` group and action
    terms; ValueError naming what is missing."""
    from agile.rl_env.managers.term_cfg import SceneEntityCfg, index_list
    from agile.run.lerobot_dataset import Slices

    manager = env.observation_manager
    if RECORD_GROUP not in manager.group_cfgs:
        raise ValueError(f"task '{env.task_name}' has no '{RECORD_GROUP}' observation group: it is not a recording "
                         f"task (its groups: {sorted(manager.group_cfgs)})")
    parts, names, videos = [], [], {}
    for name, shape in manager.term_shapes[RECORD_GROUP].items():
        if len(shape) == 3:
            videos[name] = (shape[0], shape[1])
            continue
        dim = shape[0]
        term_names = [f"{name}_{i}" for i in range(dim)]
        asset_cfg = manager.term_cfgs[RECORD_GROUP][name].params.get("asset_cfg")
        if isinstance(asset_cfg, SceneEntityCfg) and asset_cfg.joint_names is not None:
            entity = env.scene[asset_cfg.name]
            joints = [entity.joint_names[i] for i in index_list(asset_cfg.joint_ids, entity.num_joints)]
            if len(joints) == dim:
                term_names = [f"{name}.{joint}" for joint in joints]
        parts.append((name, dim))
        names += term_names
    if not videos:
        raise ValueError(f"task '{env.task_name}': the '{RECORD_GROUP}' group has no image term to record")
    action_parts, action_names = [], []
    for name, term in env.action_manager.terms.items():
        term_names, _ = term.demonstration_action()
        action_parts.append((name, len(term_names)))
        action_names += [f"{name}.{n}" for n in term_names]
    return Slices(parts, names), videos, Slices(action_parts, action_names)


def randomise_light(env, generator) -> None:
    """Every camera's light: from a random direction 30-80 degrees above the horizon, 0.6-1.2 of full brightness."""
    import torch

    elevation = math.radians(30.0 + 50.0 * float(torch.rand(1, generator=generator)))
    azimuth = 2.0 * math.pi * float(torch.rand(1, generator=generator))
    brightness = 0.6 + 0.6 * float(torch.rand(1, generator=generator))
    direction = (-math.cos(elevation) * math.cos(azimuth), -math.cos(elevation) * math.sin(azimuth),
                 -math.sin(elevation))
    for camera in env.scene.cameras.values():
        camera.set_light(direction, (brightness,) * 3)


def randomise_colors(env, palettes: dict, generator, env_mask) -> None:
    """Each masked env's entities in a colour drawn from their palettes ({entity name: ((r, g, b), ...)})."""
    import torch

    for name, palette in palettes.items():
        choices = torch.tensor(palette, dtype=torch.float32)
        drawn = choices[torch.randint(len(palette), (env.num_envs,), generator=generator)]
        env.scene[name].set_color(drawn.to(env.device), env_mask)


def record_cameras(env) -> dict:
    """{image term: scene camera} of the record group; ValueError for an image term that names no camera (its frames
    could not be rendered again after a colour change)."""
    manager = env.observation_manager
    cameras = {name: manager.term_cfgs[RECORD_GROUP][name].params.get("sensor_name")
               for name, shape in manager.term_shapes[RECORD_GROUP].items() if len(shape) == 3}
    unnamed = [term for term, camera in cameras.items() if camera is None]
    if unnamed:
        raise ValueError(f"image terms {unnamed} name no scene camera (`sensor_name`): their frames cannot be "
                         "rendered again after a colour change (--fixed_colors records without colour changes)")
    return cameras


def rerender(env, obs, image_sensors: dict) -> None:
    """Render the record group's images of `obs` again (after a colour change), {term: camera name}."""
    for term, sensor_name in image_sensors.items():
        camera = env.scene[sensor_name]
        camera.mark_stale()
        obs[RECORD_GROUP][term] = camera.rgb(env.sim.state).clone()


def record(env, policy, writer, num_episodes: int, randomise_lights: bool = True, seed: int = 0,
           progress=print, color_palettes: dict | None = None) -> dict:
    """Run `policy` in `env` until `num_episodes` episodes are written by `writer`; returns the counts and speed.
    `color_palettes` ({entity name: colours}): each episode draws its entities' colours from them."""
    import torch

    manager = env.observation_manager
    shapes = manager.term_shapes[RECORD_GROUP]
    vector_terms = [name for name, shape in shapes.items() if len(shape) == 1]
    image_terms = [name for name, shape in shapes.items() if len(shape) == 3]
    image_sensors = record_cameras(env) if color_palettes else {}
    generator = torch.Generator().manual_seed(seed)
    obs = env.obs_buf
    if color_palettes:  # the first episodes' colours, in their first frames too
        randomise_colors(env, color_palettes, generator, torch.ones(env.num_envs, dtype=torch.bool, device=env.device))
        rerender(env, obs, image_sensors)
    written, frames, steps = 0, 0, 0
    start = time.perf_counter()
    with torch.inference_mode():
        while written < num_episodes:
            recorded = obs[RECORD_GROUP]
            state = torch.cat([recorded[name].float() for name in vector_terms], dim=-1).cpu().numpy()
            images = {name: recorded[name].cpu().numpy() for name in image_terms}
            action = policy(obs)
            if randomise_lights and steps % LIGHT_CHANGE_STEPS == 0:  # the frames from the next step on
                randomise_light(env, generator)
            obs, reward, terminated, truncated, _ = env.step(action)
            demonstration = torch.cat([term.demonstration_action()[1] for term in env.action_manager.terms.values()],
                                      dim=-1).cpu().numpy()
            done = (terminated | truncated).cpu().numpy()
            reward = reward.cpu().numpy()
            for i in range(env.num_envs):
                writer.add_frame(i, state[i], demonstration[i], reward[i], done[i],
                                 {name: image[i] for name, image in images.items()})
            frames += env.num_envs
            steps += 1
            if color_palettes and done.any():  # the new episodes' colours, from their first frame on
                randomise_colors(env, color_palettes, generator, torch.as_tensor(done, device=env.device))
                rerender(env, obs, image_sensors)
            for i in done.nonzero()[0]:
                if written < num_episodes:
                    index = writer.end_episode(int(i))
                    written += 1
                    how = "time-out" if bool(truncated[i]) else "terminated"
                    progress(f"[agile] episode {index + 1}/{num_episodes} written (env {i}, "
                             f"{writer.episodes[index]['length']} frames, {how})")
                else:
                    writer.drop_episode(int(i))
    writer.close()
    seconds = time.perf_counter() - start
    return {"episodes": written, "frames_written": writer.total_frames, "frames_rendered": frames,
            "seconds": seconds, "frames_per_s": frames / seconds}


def record_dataset(*, task: str, out: str, num_episodes: int, checkpoint: str | None = None,
                   num_envs: int | None = None, device: str | None = None, seed: int | None = None,
                   rnn: str | None = None, overrides=(), task_description: str | None = None, fixed_light: bool = False,
                   fixed_colors: bool = False, encode_processes: int | None = None, trust_checkpoint: bool = False,
                   collect_datasets_anew: bool = False) -> dict:
    """Record `num_episodes` episodes of a recording task (its spec's kind "record") played by `checkpoint` (default:
    the shipped policy) into `out`, a new folder, as a LeRobot dataset; each episode draws its light (unless
    `fixed_light`) and its props' colours from the task's palettes (unless `fixed_colors`). The videos are encoded in
    `encode_processes` worker processes (0: in this one; None: one per env, at most the CPU cores less two).
    Returns what `record` counts (episodes, frames written, seconds, frames/s)."""
    missing = [name for name in ("av", "pyarrow") if importlib.util.find_spec(name) is None]
    if missing:
        raise AgileError(f"agile record writes videos and parquet files with {' and '.join(missing)}: "
                         "pip install 'agile[record]'")
    if encode_processes is not None and encode_processes < 0:
        raise AgileError(f"encode_processes {encode_processes}: give 0 (encode in this process) or more")
    if os.path.exists(out):
        raise AgileError(f"--out {out} exists: give a new folder (a dataset is never written over another)")
    task_setup.check_writable(out, "out")

    import agile.tasks
    from agile.run.lerobot_dataset import LeRobotDatasetWriter
    from agile.run.policy import inference_cfg
    from agile.utils.config import load_entry_point

    spec = agile.tasks.task_spec(task)
    if spec.kind != "record":
        recording = [t for t in agile.tasks.registered_tasks() if agile.tasks.task_kind(t) == "record"]
        raise AgileError(f"{task} is not a recording task; recording tasks: {', '.join(recording)}")
    checkpoint, overrides = task_setup.policy_to_run(task=task, checkpoint=checkpoint, overrides=overrides)
    contents = task_setup.read_checkpoint(checkpoint, trust_checkpoint)
    env_cfg, agent_cfg, device = task_setup.load_task(task=task, num_envs=num_envs, device=device, seed=seed,
                                                      rnn=rnn, overrides=overrides)
    env = task_setup.make_env(task=task, env_cfg=inference_cfg(env_cfg), device=device,
                              collect_datasets_anew=collect_datasets_anew)
    palettes = None if fixed_colors else spec.color_palettes
    if palettes:  # registered as "module:attribute" entry points (registering imports no simulator code)
        palettes = {name: load_entry_point(colors) if isinstance(colors, str) else colors
                    for name, colors in palettes.items()}
    try:
        state, videos, action = recording_layout(env)
        if palettes:
            record_cameras(env)
    except ValueError as err:
        raise AgileError(str(err)) from err
    policy = task_setup.load_policy(contents, env, agent_cfg)
    if encode_processes is None:
        encode_processes = max(0, min(env.num_envs, (os.cpu_count() or 1) - 2))
    writer = LeRobotDatasetWriter(out, fps=round(1.0 / env.step_dt),
                                  task_description=task_description or spec.task_description or task,
                                  robot_type=spec.robot_type or "robot", state=state, action=action,
                                  video_shapes=videos, streams=env.num_envs, encode_processes=encode_processes)
    print(f"[agile] recording {num_episodes} episodes of {task} with {checkpoint} into {out} "
          f"({env.num_envs} envs, {round(1.0 / env.step_dt)} fps, videos {', '.join(videos)}, encoded "
          f"{f'in {encode_processes} processes' if encode_processes else 'in this process'})", flush=True)
    try:
        result = record(env, policy, writer, num_episodes, randomise_lights=not fixed_light,
                        seed=env_cfg.seed if env_cfg.seed is not None else 0,
                        progress=lambda line: print(line, flush=True), color_palettes=palettes)
    finally:
        env.close()
    print(f"[agile] wrote {result['episodes']} episodes, {result['frames_written']} frames in "
          f"{result['seconds']:.1f} s ({result['frames_per_s']:.1f} frames/s rendered and encoded over "
          f"{env.num_envs} envs): {out}")
    return result


@command
def main(argv=None) -> None:
    parser = arguments.new_parser(__doc__)
    arguments.add_common_args(parser)
    parser.add_argument("--checkpoint", default=None,
                        help="RSL-RL checkpoint of the task's policy (default: the shipped policy)")
    parser.add_argument("--num_episodes", type=int, required=True, help="episodes to write")
    parser.add_argument("--out", required=True, help="a new folder for the dataset (never overwritten)")
    parser.add_argument("--task_description", default=None,
                        help="the language annotation of every episode (default: the task's)")
    parser.add_argument("--fixed_light", action="store_true", help="keep the scene's light as it is")
    parser.add_argument("--fixed_colors", action="store_true",
                        help="keep the scene's colours (default: each episode draws its props' colours from the "
                        "task's palettes)")
    parser.add_argument("--encode_processes", type=int, default=None, metavar="N",
                        help="encode the videos in N worker processes (0: in this one; default: one per env, at "
                        "most the CPU cores less two)")
    arguments.add_checkpoint_args(parser)
    args = arguments.parse(parser, argv)
    record_dataset(task=args.task, out=args.out, num_episodes=args.num_episodes, checkpoint=args.checkpoint,
                   num_envs=args.num_envs, device=args.device, seed=args.seed, rnn=args.rnn, overrides=args.overrides,
                   task_description=args.task_description, fixed_light=args.fixed_light,
                   fixed_colors=args.fixed_colors, encode_processes=args.encode_processes,
                   trust_checkpoint=args.trust_checkpoint, collect_datasets_anew=args.no_cache)


if __name__ == "__main__":
    main()
