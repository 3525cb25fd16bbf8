"""Evaluate a policy over the task's command range: tracking errors, fall rate, episode length, rewards.

    python scripts/eval.py --task Velocity-G1-History-v0 --num_envs 256 --num_episodes 2   # shipped policy
    python scripts/eval.py --task Velocity-T1-v0 --checkpoint model.pt --device cpu --num_envs 2 --out eval.json
    python scripts/eval.py --task Velocity-G1-History-v0 --device cpu --num_envs 2 --command 0.5 0 0   # walk

Each env runs `num_episodes` episodes of `episode_length_s` (pushes off unless --pushes). Commands are
drawn by the task's command term (uniform over its ranges, a share standing), or fixed with --command.
Without --checkpoint the policy shipped with agile for the task is evaluated. Prints and writes JSON.
"""

from __future__ import annotations

import argparse
import json

from utils import cli, multi_agent
from utils.policy import inference_cfg, load_policy


def evaluate(env, policy, num_episodes: int, command_name: str = "base_velocity", recorders=()) -> dict:
    import torch

    n = env.num_envs
    steps = num_episodes * env.max_episode_length
    lin_err_sum = torch.zeros((), device=env.device)
    ang_err_sum = torch.zeros((), device=env.device)
    moving_steps = torch.zeros((), device=env.device)
    ended = falls = 0
    episode_steps = torch.zeros(n, device=env.device)
    ended_length_steps = torch.zeros((), device=env.device)
    term_sums = {name: torch.zeros((), device=env.device) for name in env.reward_manager.weights}
    robot = env.scene[env.action_manager.policy_entity_name()]  # the robot the policy drives
    obs, _ = env.reset()
    with torch.inference_mode():
        for step in range(steps):
            command = env.command_manager.get_command(command_name).clone()
            obs, reward, terminated, truncated, _ = env.step(policy(obs))
            for recorder in recorders:
                recorder.record(env, step * env.step_dt)
            alive = ~(terminated | truncated)  # the state of a reset env is its new episode's first state
            lin_err = torch.linalg.norm(command[:, :2] - robot.root_lin_vel_b[:, :2], dim=1)
            ang_err = (command[:, 2] - robot.root_ang_vel_b[:, 2]).abs()
            lin_err_sum += (lin_err * alive).sum()
            ang_err_sum += (ang_err * alive).sum()
            moving_steps += alive.sum()
            for name in term_sums:
                term_sums[name] += env.reward_manager.step_reward[name].sum()
            done = terminated | truncated
            episode_steps += 1
            ended_length_steps += (episode_steps * done).sum()
            episode_steps.masked_fill_(done, 0.0)
            ended += int(done.sum())
            falls += int(terminated.sum())
    total = float(moving_steps)
    return {
        "num_envs": n, "episodes": ended, "falls": falls,
        "fall_rate": falls / max(ended, 1),
        "lin_vel_error_mps": float(lin_err_sum) / total,
        "ang_vel_error_radps": float(ang_err_sum) / total,
        "mean_episode_length_s": float(ended_length_steps) * env.step_dt / max(ended, 1),
        "reward_per_step": {name: float(v) / (n * steps) for name, v in term_sums.items()},
    }


def main(argv=None) -> None:
    parser = cli.new_parser(__doc__)
    cli.add_common_args(parser)
    parser.add_argument("--checkpoint", default=None, help="RSL-RL checkpoint (default: the shipped policy); "
                        "for a multi-agent task its training run folder (the newest model of each group)")
    parser.add_argument("--command", type=float, nargs=3, default=None, metavar=("VX", "VY", "WZ"),
                        help="a fixed velocity command [m/s, m/s, rad/s] for every env")
    parser.add_argument("--num_episodes", type=int, default=1, help="episodes per env")
    parser.add_argument("--episode_length_s", type=float, default=20.0)
    parser.add_argument("--pushes", action="store_true", help="keep the task's interval events (pushes)")
    parser.add_argument("--out", default=None, help="write the metrics as JSON here")
    parser.add_argument("--usd", default=None, metavar="PATH.usd", help="record the rollout as an animated USD stage")
    parser.add_argument("--video", default=None, metavar="PATH.mp4", help="render env 0 headless into an mp4")
    cli.add_checkpoint_args(parser)
    args = cli.parse(parser, argv)

    if multi_agent.is_multi_agent(args.task):
        multi_agent.eval_main(args)
        return
    checkpoint = args.checkpoint or cli.shipped_policy(args)
    if checkpoint is None:
        cli.fail(f"no --checkpoint given and agile ships no policy for {args.task}")
    contents = cli.read_checkpoint(str(checkpoint), args.trust_checkpoint)
    env_cfg, agent_cfg, device = cli.load_task(args)
    env_cfg = inference_cfg(env_cfg)
    if args.command is not None:
        command = env_cfg.commands.base_velocity
        vx, vy, wz = args.command
        command.ranges.lin_vel_x, command.ranges.lin_vel_y, command.ranges.ang_vel_z = (vx, vx), (vy, vy), (wz, wz)
        command.rel_standing_envs = 0.0
    env_cfg.episode_length_s = args.episode_length_s
    if not args.pushes and env_cfg.events is not None:
        from agile.rl_env.managers import EventTerm

        for name, term in vars(env_cfg.events).items():
            if isinstance(term, EventTerm) and term.mode == "interval":
                setattr(env_cfg.events, name, None)
    env = cli.make_env(args.task, env_cfg, device)
    from utils.recording import UsdRecorder, VideoRecorder

    recorders = []
    if args.usd:
        recorders.append(UsdRecorder(args.usd, env, num_frames=args.num_episodes * env.max_episode_length))
    if args.video:
        recorders.append(VideoRecorder(args.video, env))
    metrics = evaluate(env, load_policy(contents, env, agent_cfg), args.num_episodes, recorders=recorders)
    for recorder in recorders:
        recorder.close()
    metrics.update({"task": args.task, "checkpoint": checkpoint, "device": device, "command": args.command,
                    "episode_length_s": args.episode_length_s, "pushes": args.pushes})
    print(json.dumps(metrics, indent=2))
    if args.out:
        with open(args.out, "w") as f:
            json.dump(metrics, f, indent=2)


if __name__ == "__main__":
    main()
