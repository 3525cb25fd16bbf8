"""The frozen lower-body action: its leg targets equal running the exported policy by hand on observations built
by hand; history kept per env; a descriptor that does not fit the robot or the env is refused, naming why."""

import copy

import pytest
import torch
import yaml
from fakes import FakeEnv

from agile.rl_env.mdp.actions.frozen_policy_action import (FrozenPolicyAction, FrozenPolicyActionCfg,
                                                           shipped_frozen_policy)

POLICY, DESCRIPTOR = shipped_frozen_policy()
with open(DESCRIPTOR) as f:
    TEACHER = yaml.safe_load(f)
HAND_JOINTS = [f"right_hand_{n}_joint" for n in ("thumb_0", "thumb_1", "index_0")]
RANGES = {"lin_vel_x": (-0.2, 0.5), "lin_vel_y": (-0.4, 0.4), "ang_vel_z": (-0.5, 0.5), "base_height_m": (0.65, 0.72)}


def hands_robot_env(num_envs: int = 3) -> FakeEnv:
    """A robot with the policy's 29 joints in another order and hand joints among them, as the G1 with hands."""
    names = list(reversed(TEACHER["joint_names"]))
    names[5:5] = HAND_JOINTS
    env = FakeEnv(num_envs, joint_names=names)
    env.step_dt = TEACHER["control_dt_s"]
    return env


def randomise_state(env: FakeEnv, generator: torch.Generator) -> None:
    robot = env.robot
    for buf in (robot.joint_pos, robot.joint_vel, robot.root_lin_vel_b, robot.root_ang_vel_b):
        buf.copy_(torch.randn(buf.shape, generator=generator))
    gravity = torch.randn(robot.projected_gravity_b.shape, generator=generator)
    robot.projected_gravity_b.copy_(gravity / gravity.norm(dim=-1, keepdim=True))


def teacher_obs_by_hand(env: FakeEnv, command: torch.Tensor, last_output: torch.Tensor) -> torch.Tensor:
    robot, names = env.robot, TEACHER["joint_names"]
    ids = [robot.joint_names.index(n) for n in names]
    default = torch.tensor(TEACHER["default_joint_pos"])
    low = torch.tensor([r[0] for r in RANGES.values()])
    high = torch.tensor([r[1] for r in RANGES.values()])
    return torch.cat([torch.minimum(torch.maximum(command, low), high), robot.root_lin_vel_b, robot.root_ang_vel_b,
                      robot.projected_gravity_b, robot.joint_pos[:, ids] - default, robot.joint_vel[:, ids] * 0.1,
                      last_output.clamp(-10.0, 10.0)], dim=-1)


def test_leg_targets_equal_the_exported_policy_run_by_hand():
    env = hands_robot_env()
    term = FrozenPolicyAction(FrozenPolicyActionCfg(command_ranges=RANGES), env)
    policy = torch.jit.load(POLICY)
    action = TEACHER["actions"][0]
    leg_ids = [env.robot.joint_names.index(n) for n in action["joint_names"]]
    generator = torch.Generator().manual_seed(0)
    last_output = torch.zeros(env.num_envs, 12)
    for _ in range(3):
        randomise_state(env, generator)
        command = torch.randn(env.num_envs, 4, generator=generator)  # partly outside the ranges: clipped
        with torch.no_grad():
            output = policy(teacher_obs_by_hand(env, command, last_output)).clamp(-6.0, 6.0)
        term.process_actions(command)
        term.apply_actions()
        expected = output * torch.tensor(action["scale"]) + torch.tensor(action["offset"])
        torch.testing.assert_close(env.robot.joint_pos_target[:, leg_ids], expected)
        last_output = output
    assert not env.robot.joint_pos_target[:, [env.robot.joint_names.index(n) for n in HAND_JOINTS]].any()


def history_policy_files(tmp_path, history_length: int, obs_dim: int) -> tuple[str, str]:
    """A TorchScript linear policy (12 outputs) and the teacher's descriptor with every term's history set."""
    descriptor = copy.deepcopy(TEACHER)
    for term in descriptor["observations"]["policy"]:
        term["history_length"] = history_length
    torch.jit.save(torch.jit.script(torch.nn.Linear(obs_dim, 12)), tmp_path / "policy.pt")
    with open(tmp_path / "io_descriptor.yaml", "w") as f:
        yaml.safe_dump(descriptor, f)
    return str(tmp_path / "policy.pt"), str(tmp_path / "io_descriptor.yaml")


def test_history_is_kept_per_env_and_refilled_after_a_reset(tmp_path):
    dims = [t["dim"] for t in TEACHER["observations"]["policy"]]
    policy, descriptor = history_policy_files(tmp_path, history_length=3, obs_dim=sum(dims) * 3)
    env = hands_robot_env(num_envs=2)
    term = FrozenPolicyAction(FrozenPolicyActionCfg(policy_file=policy, io_descriptor_file=descriptor,
                                                    command_ranges=RANGES), env)
    generator = torch.Generator().manual_seed(1)

    def next_frame() -> torch.Tensor:
        """A new state, command and last action; the frame built by hand, the observation by the term."""
        randomise_state(env, generator)
        command = torch.rand(2, 4, generator=generator) * 0.05 + torch.tensor([0.0, 0.0, 0.0, 0.66])
        last_output = torch.randn(2, 12, generator=generator)
        term.command.copy_(command)  # as process_actions leaves them
        term.policy_action.copy_(last_output)
        return teacher_obs_by_hand(env, command, last_output), term.observation()

    def stacked(frames: list[torch.Tensor]) -> torch.Tensor:
        """Per term, its values in the frames oldest first; terms in the descriptor's order."""
        out, start = [], 0
        for dim in dims:
            out += [frame[:, start:start + dim] for frame in frames]
            start += dim
        return torch.cat(out, dim=-1)

    frames = []
    for _ in range(4):
        frame, obs = next_frame()
        frames.append(frame)
    torch.testing.assert_close(obs, stacked(frames[-3:]))

    # env 0 resets: its history refills with its next frame; env 1's rolls on
    term.reset(torch.tensor([True, False]))
    frame, obs = next_frame()
    torch.testing.assert_close(obs[0], stacked([frame, frame, frame])[0])
    torch.testing.assert_close(obs[1], stacked([frames[-2], frames[-1], frame])[1])


def edited_descriptor(tmp_path, edit) -> str:
    descriptor = copy.deepcopy(TEACHER)
    edit(descriptor)
    path = tmp_path / "io_descriptor.yaml"
    with open(path, "w") as f:
        yaml.safe_dump(descriptor, f)
    return str(path)


def rename_joint(descriptor: dict) -> None:
    descriptor["joint_names"][3] = "left_knee_pitch_joint"
    descriptor["observations"]["policy"][4]["joint_names"][3] = "left_knee_pitch_joint"


@pytest.mark.parametrize("edit, message", [
    (rename_joint, "joints ['left_knee_pitch_joint'] are not in robot 'robot'"),
    (lambda d: d["actions"][0]["joint_names"].append("tail_joint"), "action: joints ['tail_joint']"),
    (lambda d: d.update(control_dt_s=0.01), "control_dt_s 0.01 s != this env's step 0.02 s"),
    (lambda d: d["observations"]["policy"][1].update(func="height_scan_feet"), "uses 'height_scan_feet'"),
    (lambda d: d["observations"]["policy"][4].update(dim=28, joint_names=d["joint_names"][:28]),
     "does not take the 82 observations its descriptor lists"),
    (lambda d: d["policy"].update(recurrent=True), "recurrent policy"),
])
def test_a_descriptor_that_does_not_fit_is_refused_naming_the_mismatch(tmp_path, edit, message):
    cfg = FrozenPolicyActionCfg(policy_file=POLICY, io_descriptor_file=edited_descriptor(tmp_path, edit))
    with pytest.raises(ValueError) as err:
        FrozenPolicyAction(cfg, hands_robot_env())
    assert message in str(err.value)


def test_bad_command_ranges_are_named():
    with pytest.raises(ValueError, match=r"unknown axes \['height'\], missing \['base_height_m'\]"):
        FrozenPolicyAction(FrozenPolicyActionCfg(command_ranges={**{k: v for k, v in RANGES.items()
                                                                    if k != "base_height_m"}, "height": (0.6, 0.7)}),
                           hands_robot_env())


def test_the_frozen_policy_file_is_the_shipped_teacher():
    """The TorchScript export frozen into pick-and-place holds the very weights of the shipped Velocity-Height-G1
    teacher: re-shipping the teacher without re-exporting it (docs/pick_place.md) fails here."""
    import agile.tasks

    shipped = torch.load(agile.tasks.pretrained_policy("Velocity-Height-G1-Teacher-v0"), weights_only=False,
                         map_location="cpu")["actor_state_dict"]
    frozen = [p.detach() for p in torch.jit.load(POLICY, map_location="cpu").parameters()]
    layers = [v for k, v in shipped.items() if k.endswith(("weight", "bias")) and "normalizer" not in k]
    assert len(frozen) == len(layers) > 0
    for weights in layers:
        assert any(weights.shape == p.shape and torch.equal(weights, p) for p in frozen)
