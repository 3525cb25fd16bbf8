"""The sync-free update (`sync_free_update`: the learning rate adapted on the device, fused Adam, losses read once) and
the captured one (`captured_update`: its mini-batch step replayed as a CUDA graph) do rsl-rl's PPO math: from the same
weights and the same rollouts, the losses, the adapted learning rate and the weights after each update match the plain
update (CPU; the captured update's graph on a CUDA device)."""

from __future__ import annotations

import copy

import pytest
import torch
from rsl_rl.algorithms import PPO
from tensordict import TensorDict

from agile.rl.extensions import compose_algorithm

NUM_ENVS, NUM_STEPS, OBS_DIM, NUM_ACTIONS = 16, 12, 10, 4
UPDATES = {"rsl_rl": {}, "sync_free": {"sync_free_update": True}, "captured": {"captured_update": True}}
"""The PPO update by name -> the algorithm config's switches for it."""


class FakeEnv:
    """What rsl-rl's algorithm construction reads of an env."""

    num_envs = NUM_ENVS
    num_actions = NUM_ACTIONS


def flip(env, obs=None, actions=None):
    """A left-right mirror for the test: sign flips (the layout does not matter to the update's math)."""
    obs_aug = None if obs is None else TensorDict({k: torch.cat((obs[k], -obs[k])) for k in obs.keys()},
                                                  batch_size=[obs.batch_size[0] * 2])
    return obs_aug, None if actions is None else torch.cat((actions, -actions))


def make_algorithm(update: str, desired_kl: float, device: str = "cpu", symmetry_cfg: dict | None = None,
                   use_mixed_precision: bool = False):
    obs = TensorDict({"policy": torch.zeros(NUM_ENVS, OBS_DIM, device=device)}, batch_size=[NUM_ENVS])
    cfg = {"obs_groups": {"actor": ["policy"], "critic": ["policy"]}, "num_steps_per_env": NUM_STEPS,
           "multi_gpu": None,
           "actor": {"class_name": "MLPModel", "hidden_dims": [32, 32], "activation": "elu", "obs_normalization": True,
                     "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": 1.0}},
           "critic": {"class_name": "MLPModel", "hidden_dims": [32, 32], "activation": "elu",
                      "obs_normalization": True},
           "algorithm": {"class_name": "PPO", **UPDATES[update], "learning_rate": 1.0e-3, "schedule": "adaptive",
                         "desired_kl": desired_kl, "num_learning_epochs": 3, "num_mini_batches": 2,
                         "entropy_coef": 0.005, "symmetry_cfg": symmetry_cfg,
                         "use_mixed_precision": use_mixed_precision}}
    compose_algorithm(cfg["algorithm"])
    torch.manual_seed(0)
    return PPO.construct_algorithm(obs, FakeEnv(), cfg, device)


def fill_rollout(algorithm, seed: int = 1) -> None:
    generator = torch.Generator().manual_seed(seed)
    device = algorithm.device

    def observe():
        return TensorDict({"policy": torch.randn(NUM_ENVS, OBS_DIM, generator=generator).to(device)},
                          batch_size=[NUM_ENVS])

    obs = observe()
    torch.manual_seed(seed + 1)
    with torch.inference_mode():  # as rsl-rl's runner collects a rollout: no autograd record of the acting
        for _ in range(NUM_STEPS):
            algorithm.act(obs)
            obs = observe()
            rewards = torch.randn(NUM_ENVS, generator=generator).to(device)
            dones = (torch.rand(NUM_ENVS, generator=generator) < 0.1).to(device)
            algorithm.process_env_step(obs, rewards, dones,
                                       {"time_outs": torch.zeros(NUM_ENVS, dtype=torch.bool, device=device)})
        algorithm.compute_returns(obs)


@pytest.mark.parametrize("update", ["sync_free", "captured"])  # on a CPU the captured update runs eagerly
@pytest.mark.parametrize("desired_kl", [0.01, 1.0e-6, 10.0])  # the learning rate held, lowered, raised
def test_the_sync_free_update_matches_rsl_rls_update(desired_kl, update):
    plain, sync_free = make_algorithm("rsl_rl", desired_kl), make_algorithm(update, desired_kl)
    sync_free.actor.load_state_dict(plain.actor.state_dict())
    sync_free.critic.load_state_dict(plain.critic.state_dict())
    results = []
    for algorithm in (plain, sync_free):
        fill_rollout(algorithm)
        torch.manual_seed(3)  # the mini-batch permutation
        losses = algorithm.update()
        results.append((losses, algorithm.learning_rate, copy.deepcopy(algorithm.actor.state_dict())))
    (plain_losses, plain_lr, plain_actor), (losses, lr, actor) = results
    assert lr == pytest.approx(plain_lr, rel=1e-6)
    if desired_kl == 1.0e-6:
        assert lr < 1.0e-3  # the rule acted: lowered at every mini-batch
    if desired_kl == 10.0:
        assert lr > 1.0e-3
    for name in ("value", "surrogate", "entropy"):
        assert losses[name] == pytest.approx(plain_losses[name], rel=1e-4, abs=1e-6), name
    for name, value in plain_actor.items():
        assert torch.allclose(actor[name], value, rtol=1e-4, atol=1e-6), name


@pytest.mark.parametrize("per_mini_batch", [False, True])
def test_the_returns_and_advantages_are_rsl_rls_to_the_bit(per_mini_batch):
    """the sync-free update's GAE (all TD errors at once, two kernels a step) computes rsl-rl's numbers exactly: the same
    operations in the same order on every element, over episodes that end mid-rollout."""
    plain, sync_free = make_algorithm("rsl_rl", 0.01), make_algorithm("sync_free", 0.01)
    sync_free.critic.load_state_dict(plain.critic.state_dict())
    for algorithm in (plain, sync_free):
        algorithm.normalize_advantage_per_mini_batch = per_mini_batch
        fill_rollout(algorithm, seed=5)
    assert plain.storage.dones.any() and not plain.storage.dones.all()
    for name in ("values", "rewards", "returns", "advantages"):
        assert torch.equal(getattr(sync_free.storage, name), getattr(plain.storage, name)), name
    for algorithm in (plain, sync_free):  # a second rollout: the recursion starts afresh
        algorithm.storage.clear()
        fill_rollout(algorithm, seed=6)
    assert torch.equal(sync_free.storage.advantages, plain.storage.advantages)


@pytest.mark.parametrize("mirror_loss", [False, True])
def test_the_sync_free_update_matches_rsl_rls_update_with_symmetry(mirror_loss):
    """Mirrored samples in every mini-batch, and the mirror loss either trained on or only logged (then computed
    without autograd here): the same losses and weights as rsl-rl's update."""
    symmetry = {"use_data_augmentation": True, "use_mirror_loss": mirror_loss, "mirror_loss_coeff": 0.5,
                "data_augmentation_func": flip}
    plain = make_algorithm("rsl_rl", 0.01, symmetry_cfg=dict(symmetry))
    sync_free = make_algorithm("sync_free", 0.01, symmetry_cfg=dict(symmetry))
    sync_free.actor.load_state_dict(plain.actor.state_dict())
    sync_free.critic.load_state_dict(plain.critic.state_dict())
    results = []
    for algorithm in (plain, sync_free):
        fill_rollout(algorithm)
        torch.manual_seed(3)
        results.append((algorithm.update(), copy.deepcopy(algorithm.actor.state_dict())))
    (plain_losses, plain_actor), (losses, actor) = results
    for name in ("value", "surrogate", "entropy", "symmetry"):
        assert losses[name] == pytest.approx(plain_losses[name], rel=1e-4, abs=1e-6), name
    for name, value in plain_actor.items():
        assert torch.allclose(actor[name], value, rtol=1e-4, atol=1e-6), name


def test_the_bf16_update_matches_rsl_rls_bf16_update():
    """`algorithm.use_mixed_precision` (the runner setting, bf16 autocast of the forward passes) reaches the update,
    and the sync-free update's bf16 update does rsl-rl's: the same losses and weights (to bf16's tolerance) from the same start."""
    from agile.rl import PpoAlgorithmCfg

    assert "use_mixed_precision" in vars(PpoAlgorithmCfg())
    plain, sync_free = make_algorithm("rsl_rl", 0.01, use_mixed_precision=True), \
        make_algorithm("sync_free", 0.01, use_mixed_precision=True)
    full = make_algorithm("sync_free", 0.01)
    assert plain.use_mixed_precision and sync_free.use_mixed_precision
    for algorithm in (sync_free, full):
        algorithm.actor.load_state_dict(plain.actor.state_dict())
        algorithm.critic.load_state_dict(plain.critic.state_dict())
    results = []
    for algorithm in (plain, sync_free, full):
        fill_rollout(algorithm)
        torch.manual_seed(3)
        results.append((algorithm.update(), copy.deepcopy(algorithm.actor.state_dict())))
    (plain_losses, plain_actor), (losses, actor), (full_losses, _) = results
    for name in ("value", "surrogate", "entropy"):
        assert losses[name] == pytest.approx(plain_losses[name], rel=1e-3, abs=1e-5), name
    for name, value in plain_actor.items():
        assert torch.allclose(actor[name], value, rtol=1e-3, atol=1e-5), name
    assert losses["value"] != full_losses["value"]  # bf16 did compute: the FP32 update differs


def test_a_checkpoint_of_the_sync_free_update_resumes_in_either():
    sync_free = make_algorithm("sync_free", 1.0e-6)
    fill_rollout(sync_free)
    sync_free.update()
    saved = sync_free.save()
    assert isinstance(saved["optimizer_state_dict"]["param_groups"][0]["lr"], float)
    plain, again = make_algorithm("rsl_rl", 0.01), make_algorithm("sync_free", 0.01)
    for algorithm in (plain, again):
        algorithm.load(saved, None, strict=True)
        assert algorithm.learning_rate == pytest.approx(sync_free.learning_rate)
    assert float(again.learning_rate_t) == pytest.approx(sync_free.learning_rate)
    assert again.optimizer.param_groups[0]["lr"] is again.learning_rate_t  # the update still adapts it on the device


@pytest.mark.parametrize("update", ["rsl_rl", "sync_free"])
def test_setting_the_learning_rate_reaches_the_optimizer(update):
    """What the critic warm-up does before and after its iterations: the update's learning rate, kept where the
    update adapts it (a float, or the sync-free update's device tensor, written in place)."""
    from agile.run.training_iterations import set_learning_rate

    algorithm = make_algorithm(update, 0.01)
    set_learning_rate(algorithm, 3.0e-4)
    assert algorithm.learning_rate == pytest.approx(3.0e-4)
    assert float(algorithm.optimizer.param_groups[0]["lr"]) == pytest.approx(3.0e-4)
    if update == "sync_free":
        assert algorithm.optimizer.param_groups[0]["lr"] is algorithm.learning_rate_t
        fill_rollout(algorithm)
        algorithm.update()  # the update reports the rate it adapted, from 3e-4
        assert algorithm.learning_rate == pytest.approx(float(algorithm.learning_rate_t))
        assert algorithm.learning_rate != pytest.approx(1.0e-3)


def test_what_the_captured_graph_baked_in_is_in_its_key_and_the_normalisers_go_back_to_its_tensors():
    """The captured update keeps its graph while `graph_is_current()`: it is not after a change with a Python-number setting of the step,
    of which parameters learn or of the optimizer's state tensors, and is after one of the learning rate's log mirror;
    and
    `rebind_buffers` puts the tensors the graph read back into the normalisers, with the values that replaced them
    (CPU: the bookkeeping only, no graph)."""
    algorithm = make_algorithm("captured", 0.01)
    fill_rollout(algorithm)
    algorithm.update()  # the optimizer's state exists from here on
    algorithm.graph = "a graph"  # what graph_is_current compares against, as after a capture
    algorithm.captured_key, algorithm.captured_state = algorithm.graph_key(), algorithm.optimizer_state()
    assert algorithm.graph_is_current()
    algorithm.learning_rate = 0.5
    assert algorithm.graph_is_current()
    algorithm.entropy_coef = 0.01
    assert not algorithm.graph_is_current()
    algorithm.entropy_coef = 0.005
    next(algorithm.actor.parameters()).requires_grad_(False)
    assert not algorithm.graph_is_current()
    next(algorithm.actor.parameters()).requires_grad_(True)
    assert algorithm.graph_is_current()
    algorithm.optimizer.load_state_dict(copy.deepcopy(algorithm.optimizer.state_dict()))  # a resume: new tensors
    assert not algorithm.graph_is_current()
    algorithm.graph = None

    algorithm.captured_buffers = algorithm.model_buffers()
    normaliser = algorithm.actor.obs_normalizer
    std_read_by_graph = normaliser._std
    fill_rollout(algorithm, seed=5)
    algorithm.update()  # the normalisers learn the rollout: a new std tensor
    assert normaliser._std is not std_read_by_graph
    learned_std = normaliser._std.clone()
    algorithm.rebind_buffers()
    assert normaliser._std is std_read_by_graph and torch.equal(normaliser._std, learned_std)


@pytest.mark.gpu
def test_the_captured_update_matches_the_eager_update_on_the_gpu():
    """Four updates (the first eager, then captured again each time: the entropy coefficient changes, a setting the
    graph bakes in) against the sync-free update's eager updates; the normalisers learn between updates."""
    eager, captured = make_algorithm("sync_free", 0.01, "cuda"), make_algorithm("captured", 0.01, "cuda")
    assert captured.captures
    captured.actor.load_state_dict(eager.actor.state_dict())
    captured.critic.load_state_dict(eager.critic.state_dict())
    for update in range(4):
        results = []
        for algorithm in (eager, captured):
            algorithm.entropy_coef = 0.005 * (update + 1)
            fill_rollout(algorithm, seed=10 * update)
            torch.manual_seed(100 + update)
            losses = algorithm.update()
            results.append((losses, algorithm.learning_rate, copy.deepcopy(algorithm.actor.state_dict())))
        (eager_losses, eager_lr, eager_actor), (losses, lr, actor) = results
        assert lr == pytest.approx(eager_lr, rel=1e-5), update
        for name in ("value", "surrogate", "entropy"):
            assert losses[name] == pytest.approx(eager_losses[name], rel=1e-3, abs=1e-5), (update, name)
        for name, value in eager_actor.items():
            assert torch.allclose(actor[name], value, rtol=1e-3, atol=1e-5), (update, name)
    assert captured.graph is not None and captured.updates_done == 4 and captured.captures_made == 3


@pytest.mark.gpu
def test_the_captured_graph_is_kept_across_updates_and_memory_stays_flat_on_the_gpu():
    """Settings unchanged: one capture for eight updates that still match the eager updates (the normalisers learn
    a new std every rollout, which the kept graph must read), and the memory in use does not grow from update to
    update (captured afresh each time, a training kept ~0.85 GB of every update's graph and ran out of memory)."""
    eager, captured = make_algorithm("sync_free", 0.01, "cuda"), make_algorithm("captured", 0.01, "cuda")
    captured.actor.load_state_dict(eager.actor.state_dict())
    captured.critic.load_state_dict(eager.critic.state_dict())
    allocated = []
    for update in range(8):
        for algorithm in (eager, captured):
            fill_rollout(algorithm, seed=10 * update)
            torch.manual_seed(100 + update)
            algorithm.update()
        torch.cuda.synchronize()
        allocated.append(torch.cuda.memory_allocated())
        for name, value in eager.actor.state_dict().items():
            assert torch.allclose(captured.actor.state_dict()[name], value, rtol=1e-3, atol=1e-5), (update, name)
    assert captured.captures_made == 1
    assert max(allocated[2:]) == min(allocated[2:]), allocated
