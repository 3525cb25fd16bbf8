"""Property-based test of config validation: every scalar field of the two velocity tasks (a field both have, on
one of them), overridden with values drawn by hypothesis, either builds and steps with finite observations and reward
terms, or raises the project's ConfigError naming that field (never a crash deep inside, never NaN hidden by the
env's rules)."""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from commands import FLAT_GROUND, SMALL_TERRAIN

import agile.tasks  # noqa: F401  (registration)
from agile.rl import flatten_groups
from agile.tasks import load_cfgs
from agile.utils.config import ConfigError, apply_overrides

TASKS = ("Velocity-T1-v0", "Velocity-G1-History-v0")
NUM_ENVS = 2
NUM_STEPS = 3
TERRAIN_FIELDS = ("scene.terrain.", "scene.max_init_terrain_level", "curriculum.terrain_levels.")
MANAGER_GROUPS = ("commands", "actions", "observations", "rewards", "terminations", "events", "curriculum")


@dataclasses.dataclass(frozen=True)
class Field:
    parts: tuple[str, ...]
    """Path from the env config: field names and dict keys."""
    default: int | float | tuple
    dict_keys: tuple[int, ...]
    """Indices of the parts that are dict keys (a param, a sub-terrain, a joint regex), not field names."""

    @property
    def path(self) -> str:
        return ".".join(self.parts)

    @property
    def names_in_error(self) -> list[str]:
        """What a ConfigError about this field must name: the field, every dict key on the way (the entity,
        actuator group, sub-terrain, param or axis), the field a keyed value sits in (a joint's `stiffness`,
        a param's axis), and the manager term (and the observation group and term)."""
        names = [self.parts[-1]] + [self.parts[i] for i in self.dict_keys]
        if len(self.parts) - 1 in self.dict_keys and self.parts[-2] != "params":
            names.append(self.parts[-2])
        if self.parts[0] in MANAGER_GROUPS:
            names.append(self.parts[1])
            if self.parts[0] == "observations" and len(self.parts) > 3:
                names.append(self.parts[2])
        return names

    @property
    def base(self) -> tuple[str, ...]:
        """Most draws build on flat ground (a fifth of the time of the small terrain); a terrain field's on that."""
        return SMALL_TERRAIN if self.path.startswith(TERRAIN_FIELDS) else FLAT_GROUND


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _walk(obj, parts: tuple[str, ...], dict_keys: tuple[int, ...], out: list[Field]) -> None:
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        for f in dataclasses.fields(obj):
            _walk(getattr(obj, f.name), (*parts, f.name), dict_keys, out)
    elif isinstance(obj, dict):
        for key, value in obj.items():
            if isinstance(key, str):
                _walk(value, (*parts, key), (*dict_keys, len(parts)), out)
    elif _is_number(obj) or (isinstance(obj, tuple) and obj and all(_is_number(x) for x in obj)):
        out.append(Field(parts, obj, dict_keys))


def scalar_fields(task: str) -> list[Field]:
    """Every int, float and numeric tuple (ranges, vectors) in the task's env config, params and dicts included."""
    cfg = load_cfgs(task)[0]
    apply_overrides({"env": cfg}, [f"env.{o}" for o in SMALL_TERRAIN])
    cfg.num_envs = NUM_ENVS  # the default the draws scale: not 4,096 envs on a CPU
    out: list[Field] = []
    _walk(cfg, (), (), out)
    return out


def _set(cfg, parts: tuple[str, ...], value) -> None:
    """Set a value whose path holds a dict key with dots (a joint regex: no command-line override reaches it)."""
    obj = cfg
    for part in parts[:-1]:
        obj = obj[part] if isinstance(obj, dict) else getattr(obj, part)
    if isinstance(obj, dict):
        obj[parts[-1]] = value
    else:
        setattr(obj, parts[-1], value)


def try_override(task: str, changes: list[tuple[Field, object]]) -> str:
    """Build the task with the changes and step it; "built" or "refused". Raises AssertionError when the
    outputs are not finite or a ConfigError names none of the changed fields; any other error propagates."""
    cfg = load_cfgs(task)[0]
    try:
        base = changes[0][0].base if all(f.base == changes[0][0].base for f, _ in changes) else SMALL_TERRAIN
        apply_overrides({"env": cfg}, [f"env.{o}" for o in base])
        cfg.num_envs, cfg.seed = NUM_ENVS, 0  # set here, not by gym.make, so that a draw may change them
        for field, value in changes:
            if any("." in part for part in field.parts):
                _set(cfg, field.parts, value)
            else:
                apply_overrides({"env": cfg}, [f"env.{field.path}={value!r}"])
        env = gym.make(task, cfg=cfg, device="cpu").unwrapped
    except ConfigError as err:
        assert any(all(name in str(err) for name in field.names_in_error) for field, _ in changes), \
            f"{changes}: the error does not name the field: {err}"
        return "refused"
    generator = torch.Generator().manual_seed(0)
    for _ in range(NUM_STEPS):
        action = torch.rand(env.num_envs, env.action_manager.total_action_dim, generator=generator) * 2.0 - 1.0
        obs, reward, _, _, _ = env.step(action)
        for group, value in flatten_groups(obs).items():
            assert torch.isfinite(value).all(), f"{changes}: observation group '{group}' is not finite"
        assert torch.isfinite(reward).all(), f"{changes}: reward {reward}"
    nonfinite = {name: int(count) for name, count in env.reward_manager.nonfinite_count.items() if int(count)}
    assert not nonfinite, f"{changes}: reward terms were NaN or infinite (env-steps): {nonfinite}"
    env.close()
    return "built"


# -- what hypothesis draws ----------------------------------------------------------------------------

MULTIPLES = (0.0, -1.0, -0.5, 0.1, 0.5, 2.0, 10.0)
"""Values drawn as multiples of the default: zero and sign flips find most domain errors; small and large
multiples find budgets and divisions. Multiples, not arbitrary floats: a terrain cell of 1e-300 m would draw
an image too large for any machine, which is not what this test is about."""


def number_values(default) -> st.SearchStrategy:
    scale = abs(default) or 1
    if isinstance(default, int):
        return st.one_of(st.sampled_from([0, -1, 1]), st.integers(-2 * scale - 1, 2 * scale + 1))
    return st.one_of(st.sampled_from([0.0, -1.0, 1.0]), st.sampled_from(MULTIPLES).map(lambda m: m * scale),
                     st.integers(-30, 30).map(lambda k: k / 10 * scale))


def values(field: Field) -> st.SearchStrategy:
    if isinstance(field.default, tuple):  # a range or a vector: elements drawn alone, so also out of order
        scale = max(abs(x) for x in field.default) or 1.0
        return st.tuples(*[number_values(float(scale) if isinstance(x, float) else int(scale)) for x in field.default])
    return number_values(field.default)


FIELDS = {task: scalar_fields(task) for task in TASKS}


def field_cases() -> list:
    """Each field once, two fields a build (a build and three steps cost about 1 s of CPU; 273 fields): a path both
    tasks have (a command range, a reward weight, a terrain cell: validated by the same code) on one of them, taking
    turns in path order; a path one task alone has (its actuator groups, its joints) on that task; the fields of a
    task paired in path order. Both tasks' combined draws (`test_a_few_fields_at_once`) range over all their fields."""
    paths = {task: {field.path: field for field in FIELDS[task]} for task in TASKS}
    shared = sorted(set(paths[TASKS[0]]) & set(paths[TASKS[1]]))
    turn = {path: TASKS[i % len(TASKS)] for i, path in enumerate(shared)}
    cases = []
    for task in TASKS:
        fields = [field for field in FIELDS[task] if turn.get(field.path, task) == task]
        for i in range(0, len(fields), 2):
            pair = tuple(fields[i:i + 2])
            cases.append(pytest.param(task, pair, id=f"{task}:" + "+".join(field.path for field in pair)))
    return cases


CASES = field_cases()


@pytest.fixture(scope="module", autouse=True)
def private_cache(tmp_path_factory):
    """The terrains drawn here go to a cache of their own (not the user's)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("AGILE_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
        yield


@pytest.mark.parametrize("task, fields", CASES)
@settings(max_examples=1, deadline=None)  # one draw per field and run; the draws differ from run to run
@given(data=st.data())
def test_each_field_builds_and_steps_or_is_refused_by_name(task, fields, data):
    """A refusal names one of the two fields: the one refused (try_override)."""
    try_override(task, [(field, data.draw(values(field), label=field.path)) for field in fields])


def test_the_pairs_cover_each_field_once():
    covered = [(case.values[0], field.path) for case in CASES for field in case.values[1]]
    assert len(covered) == len(set(covered)) and len(CASES) < len(covered) <= 2 * len(CASES)
    assert {path for _, path in covered} == {field.path for task in TASKS for field in FIELDS[task]}


@pytest.mark.parametrize("task", TASKS)
@settings(max_examples=20, deadline=None)
@given(data=st.data())
def test_a_few_fields_at_once(task, data):
    fields = data.draw(st.lists(st.sampled_from(FIELDS[task]), min_size=2, max_size=4, unique=True), label="fields")
    changes = [(field, data.draw(values(field), label=field.path)) for field in fields]
    try_override(task, changes)


def test_the_draw_covers_the_fields_the_issue_names():
    """The walk reaches into commands, terrain, event params, sim and observation histories (a walk that
    stopped at the first dict would make the test above pass on nothing)."""
    for task in TASKS:
        paths = {field.path for field in FIELDS[task]}
        for expected in ("decimation", "episode_length_s", "sim.physics_dt_s", "scene.terrain.num_rows",
                         "scene.max_init_terrain_level", "commands.base_velocity.ranges.lin_vel_x",
                         "observations.policy.history_length", "events.push_robot.interval_range_s",
                         "events.push_robot.params.velocity_range.x", "rewards.track_lin_vel_xy_exp.params.std"):
            assert expected in paths, (task, expected)
        assert len(paths) > 150
    assert math.isclose(next(f.default for f in FIELDS[TASKS[0]] if f.path == "scene.terrain.size_m"), 2.0)
