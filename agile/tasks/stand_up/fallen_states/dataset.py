"""The fallen-state dataset (AGILE `FallenStateDataset`): robots dropped from random poses onto every terrain row,
left to settle, and their resting states stored per row, before learning. A stand-up task resets its episodes
from these states (`reset_from_fallen_dataset`), so it learns to rise from how robots really lie.

Collection runs in every env at once on the device: for each terrain row (and `num_spawns_per_level` times),
envs are spread over the row's columns, their roots get a random yaw, a roll and pitch within
`roll_pitch_range_rad` and random velocities, their joints random positions within the soft limits and random
velocities; then `settle_time_s` of physics with a zero action (`ManagerBasedRLEnv.simulate`: no terminations, no
resets) and the training aids (lift, harness) off. The states are kept on the device and cached on disk
(`fallen_states.cache`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path

import torch
from tqdm import tqdm

from agile.tasks.stand_up.fallen_states import cache
from agile.utils.config import configclass, to_dict
from agile.utils.math import quat_from_euler_xyz, quat_mul

STATE_FIELDS = ("root_pos_env_m", "root_quat_xyzw", "root_vel_w", "joint_pos_rad", "joint_vel_radps", "level",
                "terrain_type")
"""What one state holds: root position relative to its cell's origin, orientation, COM velocity (world, 6),
joint positions and velocities, and the cell (terrain row and column) it lies in."""


@configclass
class FallenStateDatasetCfg:
    num_spawns_per_level: int = 1
    """Drops per env and terrain row: the dataset holds num_envs x num_spawns_per_level x num_rows states."""
    settle_time_s: float = 2.5
    """Physics time after the drop, with a zero action (AGILE: 2.5 s)."""
    roll_pitch_range_rad: float = math.radians(20.0)
    """Root roll and pitch drawn in +-this around the default pose (yaw: any)."""
    root_lin_vel_range_mps: float = 5.0
    root_ang_vel_range_radps: float = 5.0
    joint_vel_range_radps: float = 1.0
    max_root_speed_mps: float = 0.5
    """A state whose root still moves faster than this after settling is dropped (not at rest: e.g. thrown by a
    bad terrain contact); the collection reports how many."""
    cell_margin_m: float = 0.5
    """A stored root's xy stays this far inside its cell (AGILE: half the cell minus 0.5 m)."""
    use_cache: bool = True
    """Load the states from the disk cache when they were collected before for the same inputs."""
    cache_dir: str | None = None
    """Folder of the cache files (default: $AGILE_CACHE_DIR/fallen_states or ~/.cache/agile/fallen_states)."""

    def check(self) -> None:
        if self.num_spawns_per_level < 1:
            raise ValueError(f"fallen_states.num_spawns_per_level must be >= 1, got {self.num_spawns_per_level}")
        if self.settle_time_s <= 0.0:
            raise ValueError(f"fallen_states.settle_time_s must be > 0, got {self.settle_time_s}")


@dataclasses.dataclass
class FallenStates:
    """The dataset on the device: each field of STATE_FIELDS a tensor with one row per state, sorted by level."""

    tensors: dict[str, torch.Tensor]
    num_levels: int

    def __post_init__(self):
        order = torch.argsort(self.tensors["level"], stable=True)
        self.tensors = {name: value[order] for name, value in self.tensors.items()}
        counts = torch.bincount(self.tensors["level"], minlength=self.num_levels)
        self.level_count = counts
        """(num_levels,) states per terrain row."""
        self.level_start = torch.cumsum(counts, 0) - counts
        """(num_levels,) index of each row's first state."""
        # a row whose states were all dropped (not at rest) draws from the nearest lower row with states, else the
        # nearest higher one; decided once here (host side, at build time), applied on the device in `sample`
        filled = [level for level, n in enumerate(counts.tolist()) if n > 0]
        source = [max((f for f in filled if f <= level), default=min(filled, default=0)) for level in
                  range(self.num_levels)]
        self.source_level = torch.tensor(source, dtype=torch.long, device=counts.device)
        """(num_levels,) the row each terrain row draws its states from."""

    def __len__(self) -> int:
        return int(self.tensors["level"].shape[0])

    def sample(self, levels: torch.Tensor) -> torch.Tensor:
        """(N,) indices of states drawn uniformly from each env's terrain row (clamped to the rows collected; a
        row without states draws from the nearest lower one that has some, else the nearest higher). No host
        sync."""
        levels = self.source_level[levels.clamp(0, self.num_levels - 1)]
        count = self.level_count[levels]
        uniform = torch.rand(levels.shape, device=levels.device)
        return self.level_start[levels] + (uniform * count).long().clamp(max=(count - 1).clamp(min=0))


def cache_inputs(env, cfg: FallenStateDatasetCfg, robot_name: str) -> dict:
    """Everything the states depend on: the robot model (file digest, joints, default pose, actuators), the
    terrain config, the physics step, the action terms, the dataset config (cache location excluded) and the
    env count (the states are collected in every env at once)."""
    robot_cfg = env.cfg.scene.entities[robot_name]
    dataset = {k: v for k, v in to_dict(cfg).items() if k not in ("use_cache", "cache_dir")}
    return {"robot_model": cache.file_digest(robot_cfg.model_file), "robot_cfg": to_dict(robot_cfg),
            "terrain": to_dict(env.cfg.scene.terrain), "physics_dt_s": env.cfg.sim.physics_dt_s,
            "decimation": env.cfg.decimation, "actions": to_dict(env.cfg.actions), "dataset": dataset,
            "num_envs": env.num_envs}


def _drop(env, robot, cfg: FallenStateDatasetCfg, level: int) -> None:
    """Put every env on row `level` (column env % columns) with a random pose, velocities and joint state."""
    n, device = env.num_envs, env.device
    all_envs = torch.ones(n, dtype=torch.bool, device=device)
    columns = env.sim.terrain_origins_m.shape[1]
    env.sim.set_terrain_cells(torch.full((n,), level, device=device),
                              torch.arange(n, device=device) % columns, all_envs)
    env.sim.reset_worlds(all_envs)
    robot.reset_to_default(all_envs)

    def uniform(shape, half_width):
        return (torch.rand(shape, device=device) * 2.0 - 1.0) * half_width

    pose = robot.default_root_pose.clone()
    pose[:, :3] += env.env_origins
    tilt = quat_from_euler_xyz(uniform(n, cfg.roll_pitch_range_rad), uniform(n, cfg.roll_pitch_range_rad),
                               uniform(n, math.pi))
    pose[:, 3:7] = quat_mul(tilt, pose[:, 3:7])
    velocity = torch.cat((uniform((n, 3), cfg.root_lin_vel_range_mps), uniform((n, 3), cfg.root_ang_vel_range_radps)),
                         dim=1)
    robot.write_root_state(pose, velocity, all_envs)
    low, high = robot.soft_joint_pos_limits[..., 0], robot.soft_joint_pos_limits[..., 1]
    joint_pos = low + torch.rand_like(low) * (high - low)
    robot.write_joint_state(joint_pos, uniform(joint_pos.shape, cfg.joint_vel_range_radps), all_envs)
    env.sim.forward(all_envs)
    env.scene.update()


def collect_fallen_states(env, cfg: FallenStateDatasetCfg, robot_name: str = "robot") -> dict[str, torch.Tensor]:
    """Drop the robots on every terrain row and return their settled states (STATE_FIELDS, on the device). The
    envs are left on row 0 and must be reset before use (`env.reset()`)."""
    cfg.check()
    if env.sim.terrain is None:
        raise ValueError("the fallen-state dataset is collected on a terrain (scene.terrain is None)")
    robot = env.scene[robot_name]
    half_cell_m = env.sim.terrain_cell_size_m / 2.0 - cfg.cell_margin_m
    zero_action = torch.zeros(env.num_envs, env.action_manager.total_action_dim, device=env.device)
    settle_steps = max(1, round(cfg.settle_time_s / env.step_dt))
    pieces: dict[str, list[torch.Tensor]] = {name: [] for name in STATE_FIELDS}
    drops = [level for level in range(env.sim.max_terrain_level) for _ in range(cfg.num_spawns_per_level)]
    # training aids (lift, harness) off while the robots fall: the states are how a robot lies by itself. A lift that
    # follows a height command (HeightTracking-G1) would otherwise hold every robot towards the command it had at
    # the build: 8 G1s on CPU, one drop per row, tracked point 0.66-0.91 m up and 41 of 64 swinging faster than
    # 0.5 m/s (dropped); with it off 0.04-0.18 m and none dropped. Each aid's strength is put back afterwards.
    aids = []
    for name in env.action_manager.training_only_terms:
        aid = env.action_manager.get_term(name)
        if not callable(getattr(aid, "scale_forces", None)):
            raise ValueError(f"training-only action term '{name}' ({type(aid).__name__}) has no scale_forces(scale): "
                             f"the fallen-state collection cannot switch it off")
        aids.append(aid)
    strengths = [aid.scale.clone() for aid in aids]
    try:
        for aid in aids:
            aid.scale_forces(0.0)
        for level in tqdm(drops, desc="fallen states", unit="drop", dynamic_ncols=True):  # the ETA
            _drop(env, robot, cfg, level)
            env.simulate(zero_action, settle_steps)
            if torch.device(env.device).type == "cuda":  # the bar times finished drops, not launched ones
                torch.cuda.synchronize(env.device)
            root_pos_env = robot.root_pos_w - env.env_origins
            root_pos_env[:, :2] = root_pos_env[:, :2].clamp(-half_cell_m, half_cell_m)
            pieces["root_pos_env_m"].append(root_pos_env)
            pieces["root_quat_xyzw"].append(robot.root_pose_w[:, 3:7].clone())
            pieces["root_vel_w"].append(robot.root_com_vel_w.clone())
            pieces["joint_pos_rad"].append(robot.joint_pos.clone())
            pieces["joint_vel_radps"].append(robot.joint_vel.clone())
            pieces["level"].append(env.sim.terrain_levels.clone())
            pieces["terrain_type"].append(env.sim.terrain_types.clone())
    finally:
        for aid, strength in zip(aids, strengths):
            aid.scale_forces(strength)
    env.sim.set_terrain_levels(torch.zeros(env.num_envs, dtype=torch.long, device=env.device))
    states = {name: torch.cat(values) for name, values in pieces.items()}
    keep = torch.ones(states["level"].shape, dtype=torch.bool, device=env.device)
    for name in ("root_pos_env_m", "root_quat_xyzw", "root_vel_w", "joint_pos_rad", "joint_vel_radps"):
        keep &= torch.isfinite(states[name]).all(dim=1)  # a world that blew up leaves no state
    keep &= torch.linalg.norm(states["root_vel_w"][:, :3], dim=1) <= cfg.max_root_speed_mps
    dropped = int((~keep).sum())
    if dropped:
        print(f"[agile] fallen states: {dropped} of {keep.numel()} dropped (not at rest after {cfg.settle_time_s} s, "
              f"root faster than {cfg.max_root_speed_mps} m/s, or not finite)", flush=True)
    return {name: value[keep] for name, value in states.items()}


def load_or_collect(env, cfg: FallenStateDatasetCfg, task_name: str, robot_name: str = "robot") -> FallenStates:
    """The dataset for this env: from the disk cache when one was made for the same inputs, else collected (and
    cached). Prints where it came from and how long it took."""
    start = time.perf_counter()
    key = cache.cache_key(cache_inputs(env, cfg, robot_name))
    path = cache.cache_path(cfg.cache_dir or cache.default_cache_dir(), task_name, key)
    states = None
    if cfg.use_cache:
        states, why_not = cache.load_states(path, key, STATE_FIELDS)
        if states is not None:
            states = {name: value.to(env.device) for name, value in states.items()}
            print(f"[agile] fallen states: {len(states['level'])} loaded from the cache {path} in "
                  f"{time.perf_counter() - start:.2f} s", flush=True)
        elif Path(path).exists():
            print(f"[agile] fallen states: the cache {path} is {why_not}: collecting again", flush=True)
    if states is None:
        env.sim.capacity.clear()
        # on forked generators: the env's random numbers after the build are the same whether the dataset was
        # collected or loaded (a seeded run of a stand-up task drew other resets once the cache existed)
        cuda = torch.device(env.device).type == "cuda"
        with torch.random.fork_rng(devices=[torch.device(env.device).index or 0] if cuda else []):
            states = collect_fallen_states(env, cfg, robot_name)
        if cuda:  # the collection is asynchronous: time it whole
            torch.cuda.synchronize(env.device)
        print(f"[agile] fallen states: {len(states['level'])} collected in {time.perf_counter() - start:.1f} s "
              f"({env.num_envs} envs x {cfg.num_spawns_per_level} drops x {env.sim.max_terrain_level} rows)",
              flush=True)
        capacity = env.sim.capacity  # falls ask for the most constraint rows: size sim.solver.njmax from this
        print(f"[agile] fallen states: at most {int(capacity.peak_constraint_rows.item())} constraint rows in one "
              f"world (sim.solver.njmax {capacity.njmax}; {int(capacity.constraint_row_overflows.item())} world-steps "
              f"over it)", flush=True)
        if cfg.use_cache:
            cache.save_states(Path(path), key, states)
            print(f"[agile] fallen states: cached in {path}", flush=True)
    env.reset()
    return FallenStates(states, num_levels=env.sim.max_terrain_level)
