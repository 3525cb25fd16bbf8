"""The training logger without a host sync per env step keeps what rsl-rl's logger keeps; the NaN check moved out of
rsl-rl's rollout loop into the wrapper still stops a rollout with NaN, naming its source."""

import pytest
import torch
from rsl_rl.utils.logger import Logger
from tensordict import TensorDict

from agile.rl_env.rsl_rl.checkpoints import CheckpointingRunner
from agile.rl_env.rsl_rl.progress import PlainLogger, ProgressLogger
from agile.rl_env.rsl_rl.sync_free_logger import SyncFreeLogger
from agile.rl_env.rsl_rl.vecenv_wrapper import RslRlVecEnvWrapper, defer_nan_check

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
    """What a tensorboard writer is given, in order."""

    def __init__(self):
        self.scalars = []
        self.flushed_at = None

    def flush(self):
        self.flushed_at = len(self.scalars)

    def add_scalar(self, tag, value, step):
        self.scalars.append((tag, float(value), step))


def log_arguments(it: int, action_std: torch.Tensor) -> dict:
    return dict(it=it, start_it=0, total_it=3, collect_time=0.5, learn_time=0.25,
                loss_dict={"value": 0.5 + it, "surrogate": torch.tensor(-0.25 * it)}, learning_rate=1e-3,
                action_std=action_std, rnd_weight=None)


def test_the_deferred_log_writes_what_rsl_rl_writes_one_step_later(capsys):
    """The same scalars and console block as rsl-rl's logger on the same steps; written at the next env step."""
    generator = torch.Generator().manual_seed(2)
    plain, sync_free = logger(Logger, 4), logger(SyncFreeLogger, 4)
    plain.writer, sync_free.writer = RecordingWriter(), RecordingWriter()
    action_std = torch.tensor([0.3, 0.5])
    printed = {"plain": "", "sync_free": ""}
    for it in range(3):
        for step in range(4):
            rewards = torch.randn(NUM_ENVS, generator=generator)
            dones = (torch.rand(NUM_ENVS, generator=generator) < 0.4).long()
            extras = {"log": {"Episode_Reward/x": torch.rand((), generator=generator),
                              "Metrics/y": torch.tensor(float(step + it))}}
            for name, made in (("plain", plain), ("sync_free", sync_free)):
                made.process_env_step(rewards, dones, extras)
                printed[name] += capsys.readouterr().out
        written_before = len(sync_free.writer.scalars)
        plain.log(**log_arguments(it, action_std))
        sync_free.log(**log_arguments(it, action_std))
        printed["plain"] += capsys.readouterr().out
        assert len(sync_free.writer.scalars) == written_before and sync_free.pending is not None  # not yet
    sync_free.stop_logging_writer()  # the last one: written when the run stops, and on disk
    printed["sync_free"] += capsys.readouterr().out
    assert sync_free.pending is None and sync_free.writer.flushed_at == len(sync_free.writer.scalars)
    assert [(tag, step) for tag, _, step in sync_free.writer.scalars] == [(tag, step) for tag, _, step in plain.writer.scalars]
    for (tag, mine, _), (_, theirs, _) in zip(sync_free.writer.scalars, plain.writer.scalars):
        assert mine == pytest.approx(theirs, rel=1e-6, abs=1e-9), tag
    assert any(tag == "Train/mean_reward" for tag, _, _ in plain.writer.scalars)
    strip_times = lambda text: [line for line in text.splitlines() if "time" not in line.lower()]  # noqa: E731
    assert strip_times(printed["sync_free"]) == strip_times(printed["plain"])
    assert list(sync_free.rewbuffer) == list(plain.rewbuffer)


def test_a_pending_log_is_written_before_its_checkpoint_and_keeps_the_next_rollouts_extras():
    sync_free = logger(SyncFreeLogger, 4)
    sync_free.writer = RecordingWriter()
    sync_free.process_env_step(torch.ones(NUM_ENVS), torch.ones(NUM_ENVS, dtype=torch.long),
                               {"log": {"Metrics/a": torch.tensor(1.0)}})
    sync_free.log(**log_arguments(0, torch.ones(2)))
    sync_free.save_model("model_0.pt", 0)  # rsl-rl uploads a checkpoint after its log: the log comes first
    assert sync_free.pending is None and ("Metrics/a", 1.0, 0) in sync_free.writer.scalars
    sync_free.ep_extras.append({"Metrics/a": torch.tensor(5.0)})  # a step of the next rollout
    sync_free.log(**log_arguments(1, torch.ones(2)))
    sync_free.ep_extras.append({"Metrics/a": torch.tensor(7.0)})
    sync_free.log(**log_arguments(2, torch.ones(2)))  # two logs without a step between: the first written first
    assert ("Metrics/a", 5.0, 1) in sync_free.writer.scalars and sync_free.pending is not None
    sync_free.write_pending_log()
    assert ("Metrics/a", 7.0, 2) in sync_free.writer.scalars


def test_the_progress_loggers_write_the_deferred_block_and_a_title(capsys):
    plain_text = logger(PlainLogger, 4)
    plain_text.writer = RecordingWriter()
    plain_text.block_title = "[agile] group 'g1': robot_0"
    plain_text.process_env_step(torch.ones(NUM_ENVS), torch.ones(NUM_ENVS, dtype=torch.long), {"log": {}})
    plain_text.log(**log_arguments(0, torch.ones(2)))
    assert "Learning iteration" not in capsys.readouterr().out
    plain_text.write_pending_log()
    out = capsys.readouterr().out
    assert out.index("[agile] group 'g1': robot_0") < out.index("Learning iteration 0/3") and "\x1b[" not in out


@pytest.mark.gpu
@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
def test_on_the_gpu_the_log_call_does_not_wait_for_the_gpu():
    made = SyncFreeLogger(log_dir=None, cfg={"num_steps_per_env": 4, "algorithm": {}}, env_cfg={}, num_envs=4096,
                          is_distributed=False, gpu_world_size=1, gpu_global_rank=0, device="cuda:0")
    made.writer = RecordingWriter()
    for _ in range(4):
        made.process_env_step(torch.ones(4096, device="cuda:0"), torch.ones(4096, dtype=torch.long, device="cuda:0"),
                              {"log": {"Metrics/a": torch.tensor(1.0, device="cuda:0")}})
    arguments = log_arguments(0, torch.ones(2, device="cuda:0"))
    arguments["loss_dict"]["surrogate"] = arguments["loss_dict"]["surrogate"].cuda()
    torch.cuda.set_sync_debug_mode("error")
    try:
        made.log(**arguments)  # a synchronisation here would raise
    finally:
        torch.cuda.set_sync_debug_mode("default")
    made.write_pending_log()
    assert ("Metrics/a", 1.0, 0) in made.writer.scalars and list(made.rewbuffer) == [1.0] * 100  # rsl-rl keeps 100
