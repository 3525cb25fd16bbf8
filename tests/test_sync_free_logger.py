"""The training logger without a host sync per env step keeps what rsl-rl's logger keeps; the NaN check moved out of
rsl-rl's rollout loop into the wrapper still stops a rollout with NaN, naming its source."""

import pytest
import torch
from rsl_rl.utils.logger import Logger
from tensordict import TensorDict

from agile.rl.runner import CheckpointingRunner
from agile.rl.progress import PlainLogger, ProgressLogger
from agile.rl.logger import SyncFreeLogger
from agile.rl.vecenv_wrapper import RslRlVecEnvWrapper, defer_nan_check

NUM_ENVS = 3


def logger(cls, steps_per_env: int):
    made = cls(log_dir=None, cfg={"num_steps_per_env": steps_per_env, "algorithm": {}}, env_cfg={},
               num_envs=NUM_ENVS, is_distributed=False, gpu_world_size=1, gpu_global_rank=0, device="cpu")
    made.writer = object()  # the bookkeeping runs where a writer exists (rank 0 of a run with a log dir)
    return made


@pytest.mark.parametrize("steps_per_env", [4, 1000])
def test_the_same_episodes_in_the_same_order_as_rsl_rl_keeps(steps_per_env):
    generator = torch.Generator().manual_seed(0)
    plain, sync_free = logger(Logger, steps_per_env), logger(SyncFreeLogger, steps_per_env)
    for step in range(300):  # 4 steps a rollout: many flushes, also mid-rollout; 1000: one flush at the end
        rewards = torch.randn(NUM_ENVS, generator=generator)
        dones = (torch.rand(NUM_ENVS, generator=generator) < 0.3).long()
        extras = {"log": {"Episode_Reward/x": torch.tensor(float(step))}}
        plain.process_env_step(rewards, dones, extras)
        sync_free.process_env_step(rewards, dones, extras)
        if step % steps_per_env == steps_per_env - 1:
            sync_free.flush_ended_episodes()  # where it logs
    sync_free.flush_ended_episodes()
    assert len(plain.rewbuffer) == 100  # more than a window's episodes ended: the window holds the newest
    assert list(sync_free.rewbuffer) == list(plain.rewbuffer)
    assert list(sync_free.lenbuffer) == list(plain.lenbuffer)
    assert torch.equal(sync_free.cur_reward_sum, plain.cur_reward_sum)
    assert torch.equal(sync_free.cur_episode_length, plain.cur_episode_length)
    assert len(sync_free.ep_extras) == len(plain.ep_extras) == 300


def test_without_a_writer_nothing_is_kept():
    quiet = logger(SyncFreeLogger, 4)
    quiet.writer = None  # another rank of a multi-GPU run
    quiet.process_env_step(torch.ones(NUM_ENVS), torch.ones(NUM_ENVS, dtype=torch.long), {"log": {}})
    quiet.flush_ended_episodes()
    assert not quiet.rewbuffer and quiet.steps_held == 0


def test_the_training_runners_and_progress_loggers_are_sync_free():
    assert issubclass(PlainLogger, SyncFreeLogger) and issubclass(ProgressLogger, SyncFreeLogger)
    assert "SyncFreeLogger" in CheckpointingRunner.__init__.__code__.co_names


class ConstantEnv:
    """The least a wrapper needs: an env whose observations or rewards can be made NaN."""

    def __init__(self):
        self.num_envs, self.max_episode_length, self.device, self.cfg = 2, 10, "cpu", None
        self.action_manager = type("Actions", (), {"total_action_dim": 1})()
        self.obs = TensorDict({"policy": torch.zeros(2, 3), "critic": torch.zeros(2, 4)}, batch_size=[2])
        self.reward = torch.zeros(2)

    def step(self, actions):
        no = torch.zeros(2, dtype=torch.bool)
        return self.obs.clone(), self.reward.clone(), no, no, {"log": {}}


def test_the_deferred_nan_check_reports_once_per_rollout_naming_the_source():
    train_cfg = {"num_steps_per_env": 4, "check_for_nan": True}
    every = defer_nan_check(train_cfg)
    assert every == 4 and train_cfg["check_for_nan"] is False  # rsl-rl's per-step check off, the wrapper's on
    env = ConstantEnv()
    wrapped = RslRlVecEnvWrapper(env, every)
    for _ in range(4):
        wrapped.step(torch.zeros(2, 1))
    env.obs["critic"][1, 2] = float("nan")
    wrapped.step(torch.zeros(2, 1))  # seen, not yet reported: no host sync mid-rollout
    env.obs["critic"][1, 2] = 0.0
    wrapped.step(torch.zeros(2, 1))
    wrapped.step(torch.zeros(2, 1))
    with pytest.raises(ValueError, match=r"the observation group 'critic' returned by the environment contained "
                                         r"NaN values within the last 4 steps"):
        wrapped.step(torch.zeros(2, 1))
    env.reward[0] = float("nan")
    with pytest.raises(ValueError, match=r"^the rewards returned"):
        for _ in range(4):
            wrapped.step(torch.zeros(2, 1))


def test_a_config_without_the_nan_check_has_none():
    train_cfg = {"num_steps_per_env": 4, "check_for_nan": False}
    assert defer_nan_check(train_cfg) == 0
    env = ConstantEnv()
    env.reward[0] = float("nan")
    wrapped = RslRlVecEnvWrapper(env, 0)
    for _ in range(8):
        wrapped.step(torch.zeros(2, 1))
    with pytest.raises(ValueError, match="nan_check_every_steps must be >= 0"):
        RslRlVecEnvWrapper(env, -1)


def test_the_episode_extras_are_averaged_over_the_steps_as_rsl_rl_averages_them():
    generator = torch.Generator().manual_seed(1)
    steps = [{"Episode_Reward/a": torch.randn((), generator=generator), "Metrics/b": torch.rand((), generator=generator)}
             for _ in range(24)]
    sync_free = logger(SyncFreeLogger, 24)
    sync_free.ep_extras = list(steps)
    sync_free.average_episode_extras()
    assert len(sync_free.ep_extras) == 1
    for key in steps[0]:  # rsl-rl: the mean of every step's value of the key
        expected = torch.cat([step[key].unsqueeze(0) for step in steps]).mean()
        assert torch.allclose(sync_free.ep_extras[0][key], expected.unsqueeze(0), atol=1e-6)
    mixed = [{"a": torch.tensor(1.0)}, {"a": torch.tensor(2.0), "b": torch.tensor(3.0)}]  # keys differ: left as is
    sync_free.ep_extras = list(mixed)
    sync_free.average_episode_extras()
    assert sync_free.ep_extras == mixed
    floats = [{"a": 1.0}, {"a": 2.0}]  # not tensors: rsl-rl's log converts them itself
    sync_free.ep_extras = list(floats)
    sync_free.average_episode_extras()
    assert sync_free.ep_extras == floats


class RecordingWriter:
    """A tensorboard writer that keeps what it is given, as the floats tensorboard stores."""

    def __init__(self):
        self.scalars = []

    def add_scalar(self, tag, value, step):
        self.scalars.append((tag, float(value), step))


def rollouts(device: str, iterations: int) -> list[list[tuple]]:
    """Per iteration, 24 env steps of (rewards, dones, extras with 6 keys) on `device`."""
    generator = torch.Generator().manual_seed(2)
    return [[(torch.randn(NUM_ENVS, generator=generator).to(device),
              (torch.rand(NUM_ENVS, generator=generator) < 0.2).long().to(device),
              {"log": {f"Episode_Reward/term_{k}": torch.randn((), generator=generator).to(device) for k in range(5)}
               | {"Metrics/error": torch.rand((), generator=generator).to(device)}}) for _ in range(24)]
            for _ in range(iterations)]


def logged(cls, device: str, steps: list[list[tuple]]) -> tuple[list, str]:
    """(tensorboard scalars, console text) of logging each rollout of `steps` after its env steps."""
    import contextlib
    import io

    made = cls(log_dir=None, cfg={"num_steps_per_env": 24, "algorithm": {}}, env_cfg={}, num_envs=NUM_ENVS,
               is_distributed=False, gpu_world_size=1, gpu_global_rank=0, device=device)
    made.writer = RecordingWriter()
    action_std = torch.full((12,), 0.3, device=device)
    text = io.StringIO()
    for it, rollout in enumerate(steps):
        for rewards, dones, extras in rollout:
            made.process_env_step(rewards, dones, extras)
        with contextlib.redirect_stdout(text):
            made.log(it=it, start_it=0, total_it=len(steps), collect_time=0.25, learn_time=0.05,
                     loss_dict={"surrogate": 0.1, "value": 2.0}, learning_rate=1e-3, action_std=action_std,
                     rnd_weight=None)
    return made.writer.scalars, text.getvalue()


def test_the_log_writes_what_rsl_rls_writes():
    """Averaged on the host (one copy) instead of per key on the logger's device: the same tags, steps and values
    (to float rounding of the means' summation order) and the same console block, but for the timings' lines."""
    plain_scalars, plain_text = logged(Logger, "cpu", rollouts("cpu", 3))
    scalars, text = logged(SyncFreeLogger, "cpu", rollouts("cpu", 3))
    assert [(tag, step) for tag, _, step in scalars] == [(tag, step) for tag, _, step in plain_scalars]
    assert [value for _, value, _ in scalars] == pytest.approx([value for _, value, _ in plain_scalars], rel=1e-5)
    untimed = [line for line in text.splitlines() if "time" not in line.lower() and "ETA" not in line]
    assert untimed == [line for line in plain_text.splitlines() if "time" not in line.lower() and "ETA" not in line]
    assert "Episode_Reward/term_4:" in text and "Metrics/error:" in text



def test_each_log_stamps_its_iteration_on_the_hosts_clock():
    """What `agile benchmark` times an iteration by: one (iteration, clock) per log, in order, the newest kept."""
    import contextlib
    import io
    import time

    from agile.rl import logger as sync_free_logger

    made = logger(SyncFreeLogger, 24)
    made.writer = RecordingWriter()
    before = time.perf_counter()
    for it, rollout in enumerate(rollouts("cpu", 3), start=7):
        for rewards, dones, extras in rollout:
            made.process_env_step(rewards, dones, extras)
        with contextlib.redirect_stdout(io.StringIO()):
            made.log(it=it, start_it=7, total_it=10, collect_time=0.25, learn_time=0.05, loss_dict={"value": 1.0},
                     learning_rate=1e-3, action_std=torch.full((12,), 0.3), rnd_weight=None)
    assert [it for it, _ in made.iteration_stamps_s] == [7, 8, 9]
    clocks = [stamp for _, stamp in made.iteration_stamps_s]
    assert before <= clocks[0] <= clocks[1] <= clocks[2] <= time.perf_counter()
    assert made.iteration_stamps_s.maxlen == sync_free_logger.STAMPS_KEPT

@pytest.mark.gpu
def test_the_log_reads_the_gpu_back_a_few_times_not_per_key():
    import warnings

    def synchronisations(cls) -> int:
        steps = rollouts("cuda", 1)  # on the GPU before counting
        torch.cuda.synchronize()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            torch.cuda.set_sync_debug_mode("warn")
            try:
                logged(cls, "cuda", steps)
            finally:
                torch.cuda.set_sync_debug_mode("default")
        return sum("synchroniz" in str(w.message) for w in caught)

    # rsl-rl's: one per env step (its episode bookkeeping) and two per extras key; ours: the episodes' flush, the
    # means' one copy, the action std's
    plain, sync_free = synchronisations(Logger), synchronisations(SyncFreeLogger)
    assert sync_free <= 6 < 24 < plain, (sync_free, plain)


def test_the_tensorboard_writer_is_closed_when_a_run_ends(tmp_path):
    """rsl-rl stops only its own writer kinds; a tensorboard writer left open keeps a thread and unflushed events."""
    from torch.utils.tensorboard import SummaryWriter

    made = SyncFreeLogger(log_dir=str(tmp_path), cfg={"num_steps_per_env": 4, "algorithm": {}}, env_cfg={},
                          num_envs=NUM_ENVS, is_distributed=False, gpu_world_size=1, gpu_global_rank=0, device="cpu")
    made.init_logging_writer()
    assert isinstance(made.writer, SummaryWriter)
    made.writer.add_scalar("x", 1.0, 0)
    made.stop_logging_writer()
    assert made.writer.all_writers is None  # closed: flushed and its thread ended
    assert any(path.name.startswith("events.out.tfevents") and path.stat().st_size > 0 for path in tmp_path.iterdir())
