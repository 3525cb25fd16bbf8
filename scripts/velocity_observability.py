"""How well the base velocity can be read off what a Velocity-Height student observes (issue 44's velocity bound).

The students see the teacher's policy observations without `base_lin_vel` (AGILE's design: the robot does not
measure it). This rolls the shipped teacher out on its task as `agile eval` does (no observation noise, commands
drawn as in training), records at every step the student's observation (every policy term but `base_lin_vel`) and
the true planar base velocity, and fits least-squares estimators of that velocity from the last K steps of
observations (ridge regression for every K, a small MLP for some) on half the envs; it reports their RMSE on the other
half, against the commanded velocity as the estimate (where any estimator starts from: the commands are observed).

    python scripts/velocity_observability.py --device cpu --num_envs 64 --steps 750 --windows 1 5 10 25 50 \\
        --out docs/velocity_height/velocity_observability_cpu.json
"""

from __future__ import annotations

import argparse
import json

import torch

TASK = "Velocity-Height-G1-Teacher-v0"


def rollout(num_envs: int, steps: int, device: str, seed: int) -> tuple[torch.Tensor, ...]:
    """(frames (T, N, F), velocity (T, N, 2), command velocity (T, N, 2), alive (T, N)) over `steps` env steps: the
    student's observation terms of each step, the true planar base velocity in the base's yaw frame (the frame the
    command and the tracking reward use), the commanded one, and whether the env did not end at that step."""
    from agile.rl.checkpoints import load_checkpoint
    from agile.run import task_setup
    from agile.run.policy import inference_cfg, load_policy
    from agile.utils.math import yaw_from_quat

    checkpoint, overrides = task_setup.shipped_policy(task=TASK)
    env_cfg, agent_cfg, device = task_setup.load_task(task=TASK, num_envs=num_envs, device=device, seed=seed,
                                                 overrides=overrides)
    env = task_setup.make_env(task=TASK, env_cfg=inference_cfg(env_cfg), device=device)
    policy = load_policy(load_checkpoint(checkpoint, "cpu"), env, agent_cfg)
    robot = env.scene["robot"]
    obs, _ = env.reset()
    frames, velocity, command, alive = [], [], [], []
    with torch.inference_mode():
        for _ in range(steps):
            seen = obs["policy"]
            frames.append(torch.cat([seen[key].flatten(1) for key in seen.keys() if key != "base_lin_vel"], dim=1))
            yaw = yaw_from_quat(robot.root_quat_w)
            vx_w, vy_w = robot.root_lin_vel_w[:, 0], robot.root_lin_vel_w[:, 1]
            velocity.append(torch.stack((torch.cos(yaw) * vx_w + torch.sin(yaw) * vy_w,
                                         -torch.sin(yaw) * vx_w + torch.cos(yaw) * vy_w), dim=1))
            command.append(seen["velocity_height_commands"][:, :2].clone())
            obs, _, terminated, truncated, _ = env.step(policy(obs))
            alive.append(~(terminated | truncated))
    env.close()
    return torch.stack(frames), torch.stack(velocity), torch.stack(command), torch.stack(alive)


def windows_of(frames: torch.Tensor, k: int) -> torch.Tensor:
    """(T - k + 1, N, k * F): each step's last k frames, oldest first."""
    return torch.cat([frames[i:frames.shape[0] - k + 1 + i] for i in range(k)], dim=2)


def ridge_rmse(x: torch.Tensor, y: torch.Tensor, train: torch.Tensor, ridge: float) -> float:
    """RMSE [m/s] on the rows not in `train` of the ridge least-squares fit of y on x (standardised, with a bias)."""
    x = x.double()
    mean, std = x[train].mean(0), x[train].std(0).clamp(min=1e-6)
    x = torch.cat([(x - mean) / std, torch.ones(len(x), 1, dtype=x.dtype)], dim=1)
    a = x[train].T @ x[train] + ridge * len(x[train]) * torch.eye(x.shape[1], dtype=x.dtype)
    weights = torch.linalg.solve(a, x[train].T @ y[train].double())
    error = (x[~train] @ weights - y[~train].double()).norm(dim=1)
    return float(error.square().mean().sqrt())


def mlp_rmse(x: torch.Tensor, y: torch.Tensor, train: torch.Tensor, iterations: int, seed: int) -> float:
    """RMSE [m/s] on the rows not in `train` of an MLP (256, 256, ELU) fit to y on the train rows (Adam, batches of
    2,048): a nonlinear estimator, as the students' networks are."""
    generator = torch.Generator().manual_seed(seed)
    torch.manual_seed(seed)
    x = x.float()
    mean, std = x[train].mean(0), x[train].std(0).clamp(min=1e-6)
    x = (x - mean) / std
    x_fit, y_fit = x[train], y[train].float()
    model = torch.nn.Sequential(torch.nn.Linear(x.shape[1], 256), torch.nn.ELU(), torch.nn.Linear(256, 256),
                                torch.nn.ELU(), torch.nn.Linear(256, 2))
    optimizer = torch.optim.Adam(model.parameters(), lr=1e-3, weight_decay=1e-5)
    for _ in range(iterations):
        rows = torch.randint(len(x_fit), (2048,), generator=generator)
        loss = (model(x_fit[rows]) - y_fit[rows]).square().sum(dim=1).mean()
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    with torch.no_grad():
        error = (model(x[~train]) - y[~train].float()).norm(dim=1)
    return float(error.square().mean().sqrt())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--num_envs", type=int, default=64)
    parser.add_argument("--steps", type=int, default=750, help="env steps (50 per second)")
    parser.add_argument("--windows", type=int, nargs="+", default=[1, 5, 10, 25, 50], help="window lengths K, steps")
    parser.add_argument("--skip_steps", type=int, default=100, help="the start of each episode, not scored")
    parser.add_argument("--ridge", type=float, default=1e-3)
    parser.add_argument("--mlp_windows", type=int, nargs="*", default=[1, 5, 25],
                        help="window lengths also fit by an MLP (slower)")
    parser.add_argument("--mlp_iterations", type=int, default=3000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=None)
    args = parser.parse_args()

    frames, velocity, command, alive = rollout(args.num_envs, args.steps, args.device, args.seed)
    frames, velocity, command, alive = frames.cpu(), velocity.cpu(), command.cpu(), alive.cpu()
    # only steps of the first episode (an env that ended stops counting), past its start
    ended_before = torch.cat([torch.zeros_like(alive[:1]), ~alive[:-1]]).long().cumsum(dim=0) > 0
    lived = ~ended_before
    train_envs = torch.arange(args.num_envs) % 2 == 0
    rows = []
    for k in args.windows:
        start = max(args.skip_steps, k - 1)
        x = windows_of(frames, k)[start - k + 1:]
        y, kept = velocity[start:], lived[start:]
        train = train_envs.expand_as(kept)[kept]
        x, y, c = x[kept], y[kept], command[start:][kept]
        rmse = ridge_rmse(x, y, train, args.ridge)
        command_rmse = float((c[~train] - y[~train]).norm(dim=1).square().mean().sqrt())
        row = {"window_steps": k, "window_s": k * 0.02, "linear_rmse_mps": rmse,
               "command_as_estimate_rmse_mps": command_rmse, "samples_fit": int(train.sum()),
               "samples_scored": int((~train).sum())}
        if k in args.mlp_windows:
            row["mlp_rmse_mps"] = mlp_rmse(x, y, train, args.mlp_iterations, args.seed)
        rows.append(row)
        mlp = f", MLP {row['mlp_rmse_mps']:.4f}" if "mlp_rmse_mps" in row else ""
        print(f"K = {k:3d} steps ({k * 0.02:.2f} s): velocity RMSE linear {rmse:.4f}{mlp} m/s (the command as the "
              f"estimate: {command_rmse:.4f})", flush=True)
    if args.out:
        with open(args.out, "w") as f:
            json.dump({"task": TASK, "device": args.device, "num_envs": args.num_envs, "steps": args.steps,
                       "features_per_step": frames.shape[2], "ridge": args.ridge, "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
