"""The iterations of an `agile train` run: a critic warm-up where the policy comes from elsewhere, then PPO, in
chunks with a video clip after each where asked (`learn`)."""

from __future__ import annotations

import os

from agile.run import task_setup
from agile.run.train_options import TrainOptions


def set_learning_rate(algorithm, learning_rate: float) -> None:
    """The PPO algorithm's learning rate, as its adaptive schedule sets it (the attribute and every group). A
    group's learning rate held as a tensor (the sync-free update adapts it on the device) is written in place."""
    import torch

    algorithm.learning_rate = learning_rate
    for group in algorithm.optimizer.param_groups:
        if isinstance(group["lr"], torch.Tensor):
            group["lr"].fill_(learning_rate)
        else:
            group["lr"] = learning_rate


def warm_up_critic(runner, iterations: int, learning_rate: float) -> None:
    """Train `iterations` PPO iterations at `learning_rate` with the actor's weights held (its gradients off;
    Adam skips weights without one, and the actor's unchanged outputs leave the adaptive learning rate as it
    is): only the critic learns the returns of the policy it will judge. PPO then starts at the algorithm's
    own learning rate."""
    actor, ppo_learning_rate = runner.alg.get_policy(), runner.alg.learning_rate
    print(f"[agile] critic warm-up: {iterations} iterations with the actor held, learning rate {learning_rate:g}")
    actor.requires_grad_(False)
    set_learning_rate(runner.alg, learning_rate)
    runner.learn(num_learning_iterations=iterations, init_at_random_ep_len=True)
    runner.current_learning_iteration += 1  # RSL-RL leaves the counter on the last iteration done
    actor.requires_grad_(True)
    set_learning_rate(runner.alg, ppo_learning_rate)


def learn_with_clips(runner, options, env_cfg, device: str, log_dir: str, iterations: int,
                     random_episode_starts: bool = True) -> None:
    """Train in chunks of --video_interval iterations, recording a clip of the current policy after each."""
    import copy

    import torch
    from agile.run.policy import inference_cfg
    from agile.run.recorders import VideoRecorder

    from agile.rl import flatten_groups

    record = log_dir is not None  # distributed: the other ranks learn the same chunks and record nothing
    if record:
        video_cfg = inference_cfg(copy.deepcopy(env_cfg))
        video_cfg.num_envs = 1
        video_env = task_setup.make_env(task=options.task, env_cfg=video_cfg, device=device,
                                        collect_datasets_anew=options.collect_datasets_anew)
        os.makedirs(os.path.join(log_dir, "videos"), exist_ok=True)
    done = 0
    while done < iterations:
        chunk = min(options.video_interval, iterations - done)
        runner.learn(num_learning_iterations=chunk, init_at_random_ep_len=random_episode_starts and done == 0)
        # RSL-RL leaves the counter on the last iteration done; the next chunk starts one later
        runner.current_learning_iteration += 1
        done += chunk
        if not record:
            continue
        policy = runner.get_inference_policy(device=str(video_env.device))
        # a recurrent actor holds the rollout's hidden state (a row per training env): set it aside for the clip
        training_hidden_state = policy.get_hidden_state()
        policy.reset()
        path = os.path.join(log_dir, "videos", f"iteration_{done}.mp4")
        recorder = VideoRecorder(path, video_env)
        obs, _ = video_env.reset()
        with torch.inference_mode():
            for _ in range(options.video_length):
                obs, _, terminated, truncated, _ = video_env.step(policy(flatten_groups(obs)))
                policy.reset(terminated | truncated)
                recorder.record(video_env)
        recorder.close()
        policy.reset(hidden_state=training_hidden_state)
        print(f"[agile] clip: {path}")
    if record:
        video_env.close()


def learn(runner, env_cfg, agent_cfg, device: str, options: TrainOptions, log_dir: str | None, start: dict) -> None:
    """The run's iterations: a critic warm-up where the policy comes from elsewhere (an initial policy, a checkpoint
    trained without reward normalisation), then PPO (in chunks with a clip after each, where asked)."""
    from agile.rl.algorithms.reward_normalization import starts_normalizing

    iterations, warmup = agent_cfg.max_iterations, 0
    rescaled = starts_normalizing(agent_cfg, start["resume_contents"])
    if rescaled:
        print("[agile] the checkpoint was trained without reward normalisation: its statistics start afresh, and the "
              "critic learned returns of another scale (critic_warmup_iterations applies)")
    if start["init_policy"] or rescaled:
        warmup = min(getattr(agent_cfg, "critic_warmup_iterations", 0), iterations)
    if warmup > 0:
        warm_up_critic(runner, warmup, agent_cfg.critic_warmup_learning_rate)
        iterations -= warmup
    if options.video:
        learn_with_clips(runner, options, env_cfg, device, log_dir, iterations, random_episode_starts=warmup == 0)
    elif iterations > 0:
        runner.learn(num_learning_iterations=iterations, init_at_random_ep_len=warmup == 0)
