"""Run a task with a policy: a checkpoint, the policy shipped with agile, or sinusoidal test actions.

    python scripts/play.py --task Velocity-G1-History-v0 --num_envs 2 --num_steps 50   # shipped policy
    python scripts/play.py --task Velocity-T1-v0 --checkpoint logs/rsl_rl/velocity_t1/<run>/model_3000.pt
    python scripts/play.py --task Velocity-T1-v0 --sinusoidal       # test actions, no policy
    python scripts/play.py --task Velocity-G1-History-v0 --viewer viser   # browser viewer on http://localhost:8080

Without --checkpoint the task's shipped policy runs if agile has one (agile/data/policy/), else
sinusoidal test actions. Headless by default. Observation noise and curricula are switched off.
"""

from __future__ import annotations

import argparse
import math
import time

from utils import cli
from utils.policy import inference_cfg, load_policy


def sinusoidal_actions(step: int, step_dt: float, num_envs: int, action_dim: int, device):
    """0.5·sin(2π(0.5 + 0.2·(i mod 5))·t + iπ/dim) on action i: exercises every joint without a policy."""
    import torch

    i = torch.arange(action_dim, device=device, dtype=torch.float32)
    freq_hz = 0.5 + 0.2 * torch.remainder(i, 5)
    t = step * step_dt
    return (0.5 * torch.sin(2 * math.pi * freq_hz * t + i * math.pi / action_dim)).expand(num_envs, -1)


LOCAL_HOST = "127.0.0.1"


def open_viewer(model, port: int, host: str = LOCAL_HOST):
    """The viser viewer of `model`, listening on `host` only (the loopback address unless the user says)."""
    import newton.viewer

    if host not in (LOCAL_HOST, "localhost", "::1"):
        print(f"[agile] warning: the viewer listens on {host}:{port} without authentication: anyone who can reach "
              f"that address watches the run (and drives it, once a GUI has controls)")
    viewer = newton.viewer.ViewerViser(port=port, host=host)
    viewer.set_model(model)
    print(f"[agile] viewer on http://{'localhost' if host == LOCAL_HOST else host}:{port}")
    return viewer


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    cli.add_common_args(parser)
    parser.add_argument("--checkpoint", default=None, help="RSL-RL checkpoint (model_<it>.pt) to run")
    parser.add_argument("--sinusoidal", action="store_true", help="sinusoidal test actions instead of a policy")
    parser.add_argument("--num_steps", type=int, default=1000, help="env steps to run")
    parser.add_argument("--viewer", choices=["none", "viser"], default="none", help="viser: browser viewer")
    parser.add_argument("--port", type=int, default=8080, help="viser port")
    parser.add_argument("--host", default=LOCAL_HOST,
                        help=f"address the viewer listens on (default {LOCAL_HOST}: this machine only; from another "
                             "machine use SSH port forwarding, see the README). 0.0.0.0 exposes it to the network")
    parser.add_argument("--real_time", action="store_true", help="slow down to the control rate")
    parser.add_argument("--usd", default=None, metavar="PATH.usd", help="record the rollout as an animated USD stage")
    parser.add_argument("--video", default=None, metavar="PATH.mp4", help="render env 0 headless into an mp4")
    cli.add_checkpoint_args(parser)
    args = parser.parse_args(argv)

    checkpoint = args.checkpoint
    if checkpoint is None and not args.sinusoidal:
        checkpoint = cli.shipped_policy(args)
    contents = cli.read_checkpoint(str(checkpoint), args.trust_checkpoint) if checkpoint and not args.sinusoidal \
        else None
    env_cfg, agent_cfg, device = cli.load_task(args)
    import torch
    env = cli.make_env(args.task, inference_cfg(env_cfg), device)
    policy = load_policy(contents, env, agent_cfg) if contents is not None else None
    print(f"[agile] {args.task}: {env.num_envs} envs on {device}, "
          f"{'policy ' + checkpoint if policy else 'sinusoidal test actions'}")

    viewer = None
    if args.viewer == "viser":
        viewer = open_viewer(env.sim.model, args.port, args.host)

    recorder = None
    if args.usd:
        from utils.recording import UsdRecorder

        recorder = UsdRecorder(args.usd, env, num_frames=args.num_steps)
    video = None
    if args.video:
        from utils.recording import VideoRecorder

        video = VideoRecorder(args.video, env)
    obs, _ = env.reset()
    episodes = falls = 0
    reward_sum = torch.zeros((), device=env.device)
    wall_start = time.perf_counter()
    with torch.inference_mode():
        for step in range(args.num_steps):
            start = time.perf_counter()
            if policy is not None:
                actions = policy(obs)
            else:
                actions = sinusoidal_actions(step, env.step_dt, env.num_envs, env.action_manager.total_action_dim,
                                             env.device)
            obs, reward, terminated, truncated, _ = env.step(actions)
            reward_sum += reward.mean()
            episodes += int((terminated | truncated).sum())
            falls += int(terminated.sum())
            if recorder is not None:
                recorder.record(env, step * env.step_dt)
            if video is not None:
                video.record(env)
            if viewer is not None:
                if not viewer.is_running():
                    break
                viewer.begin_frame(step * env.step_dt)
                viewer.log_state(env.sim.state)
                viewer.end_frame()
            if args.real_time:
                time.sleep(max(0.0, env.step_dt - (time.perf_counter() - start)))
    elapsed = time.perf_counter() - wall_start
    print(f"[agile] {step + 1} steps in {elapsed:.1f} s ({(step + 1) * env.num_envs / elapsed:.0f} env-steps/s); "
          f"mean reward per step {float(reward_sum) / (step + 1):.4f}; episodes ended {episodes}, by failure {falls}")
    if viewer is not None:
        viewer.close()
    if recorder is not None:
        recorder.close()
        print(f"[agile] USD stage written to {recorder.path}")
    if video is not None:
        video.close()
        print(f"[agile] video ({video.frames} frames) written to {video.path}")
    env.close()


if __name__ == "__main__":
    main()
