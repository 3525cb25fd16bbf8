"""A training runs with what existed at its start out of the garbage collector's whole-heap passes, and gives it
back when it ends (agile/utils/heap.py)."""

from __future__ import annotations

import gc
import weakref

import pytest

from agile.utils.heap import heap_frozen, no_collection_while_capturing


class Cycle:
    def __init__(self):
        self.me = self


def test_the_heap_is_frozen_inside_and_given_back_after_even_on_an_error():
    assert gc.get_freeze_count() == 0
    with heap_frozen():
        assert gc.get_freeze_count() > 0
    assert gc.get_freeze_count() == 0
    with pytest.raises(RuntimeError, match="inside"), heap_frozen():
        raise RuntimeError("inside")
    assert gc.get_freeze_count() == 0


def test_garbage_from_before_the_start_is_collected_after_the_end_not_during():
    garbage = Cycle()
    alive = weakref.ref(garbage)
    with heap_frozen():
        del garbage
        gc.collect()
        assert alive() is not None  # frozen: no pass visits it
    gc.collect()
    assert alive() is None  # given back, and freed


def test_no_collection_runs_while_a_graph_captures_and_garbage_goes_at_the_next_one_after():
    """Inside, the collector is off, also for a nested capture, which leaves it to the outermost; cyclic garbage from
    before and from inside the capture waits for the next collection after it (no whole-heap pass on entry); after an
    error the collector is on again."""
    before = Cycle()
    freed_before = weakref.ref(before)
    del before
    with no_collection_while_capturing():
        assert not gc.isenabled()
        during = Cycle()
        freed_during = weakref.ref(during)
        del during
        for _ in range(3 * gc.get_threshold()[0]):  # allocations that would start a generation-0 collection
            Cycle()
        with no_collection_while_capturing():
            assert not gc.isenabled()
        assert not gc.isenabled() and freed_during() is not None and freed_before() is not None
    assert gc.isenabled()
    gc.collect()
    assert freed_before() is None and freed_during() is None
    with pytest.raises(RuntimeError, match="inside"), no_collection_while_capturing():
        raise RuntimeError("inside")
    assert gc.isenabled()


def test_a_callers_own_freeze_is_kept():
    """Garbage the caller froze stays out of the collector's reach after a `heap_frozen` block inside the freeze (the
    freeze count itself is no measure: a frozen object freed by its reference count leaves the count)."""
    garbage = Cycle()
    alive = weakref.ref(garbage)
    gc.freeze()
    try:
        del garbage
        with heap_frozen():
            pass
        gc.collect()
        assert alive() is not None and gc.get_freeze_count() > 0
    finally:
        gc.unfreeze()
    gc.collect()
    assert alive() is None


def test_the_training_runners_learn_runs_frozen_and_gives_the_heap_back(tmp_path):
    """Every env step of `learn` (the checkpointing runner that `agile train` and `agile benchmark` use) sees the heap
    frozen; after it, nothing is."""
    import gymnasium as gym

    import agile.tasks
    from agile.rl.runner import training_runner
    from agile.rl.vecenv_wrapper import RslRlVecEnvWrapper

    frozen_at_steps = []

    class Observed(RslRlVecEnvWrapper):
        def step(self, actions):
            frozen_at_steps.append(gc.get_freeze_count())
            return super().step(actions)

    _, agent_cfg = agile.tasks.load_cfgs("Velocity-T1-v0")
    agent_cfg.num_steps_per_env = 3
    env = gym.make("Velocity-T1-v0", num_envs=2, device="cpu", seed=0).unwrapped
    try:
        runner = training_runner(env, agent_cfg, str(tmp_path), wrap=Observed)
        runner.learn(num_learning_iterations=1)
    finally:
        env.close()
    assert len(frozen_at_steps) == 3 and min(frozen_at_steps) > 0
    assert gc.get_freeze_count() == 0
