"""Actuator models against closed forms, on hand-made Newton arrays (no solver)."""

import math
from types import SimpleNamespace

import pytest
import torch
import warp as wp

from agile.actuators import DCMotorCfg, DelayedDCMotorCfg, ExplicitActuatorGroup, IdealPDActuatorCfg
from agile.actuators import action_scale, armature_gains
from agile.assets import unitree_g1

J = 2  # joints per world


def world_major(num_envs: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Coordinate and DoF indices of the J joints after a free root, world-major (Articulation.world_major_indices)."""
    world = torch.arange(num_envs).unsqueeze(1)
    local = torch.arange(J).unsqueeze(0)
    return ((world * (7 + J) + 7 + local).flatten().to(torch.int32),
            (world * (6 + J) + 6 + local).flatten().to(torch.int32))


def make_group(cfg, num_envs=1, kp=100.0, kd=0.0, effort=50.0, velocity=10.0, saturation=80.0):
    dofs, coords = num_envs * (6 + J), num_envs * (7 + J)
    state = SimpleNamespace(joint_q=wp.zeros(coords, dtype=float), joint_qd=wp.zeros(dofs, dtype=float))
    control = SimpleNamespace(joint_target_q=wp.zeros(coords, dtype=float), joint_target_qd=wp.zeros(dofs, dtype=float),
                              joint_act=wp.zeros(dofs, dtype=float), joint_f=wp.zeros(dofs, dtype=float))
    computed = wp.zeros(dofs, dtype=float)
    full = lambda v: torch.full((J,), v)  # noqa: E731
    values = {"stiffness": full(kp), "damping": full(kd), "effort_limit": full(effort), "velocity_limit": full(velocity),
              "saturation_effort": full(saturation)}
    group = ExplicitActuatorGroup("test", cfg, list(range(J)), *world_major(num_envs), values, state, control,
                                  computed, num_envs, torch.device("cpu"))
    views = SimpleNamespace(
        q=wp.to_torch(state.joint_q).view(num_envs, -1)[:, 7:], qd=wp.to_torch(state.joint_qd).view(num_envs, -1)[:, 6:],
        target=wp.to_torch(control.joint_target_q).view(num_envs, -1)[:, 7:],
        torque=wp.to_torch(control.joint_f).view(num_envs, -1)[:, 6:],
        computed=wp.to_torch(computed).view(num_envs, -1)[:, 6:])
    return group, views


@pytest.mark.parametrize("delay", [0, 1, 3])
def test_delay_of_k_steps_shifts_the_torque_by_k_steps(delay):
    cfg = DelayedDCMotorCfg(min_delay=delay, max_delay=delay, saturation_effort=1e6)
    group, v = make_group(cfg, effort=1e6)
    group.reset(torch.ones(1, dtype=torch.bool))
    torques = []
    for step in range(8):
        if step == 2:
            v.target[:] = 0.1  # a step in the setpoint at physics step 2
        group.step(0.005, step, 8)
        torques.append(v.torque[0, 0].item())
    expected = [0.0 if s < 2 + delay else 100.0 * 0.1 for s in range(8)]
    assert torques == pytest.approx(expected, abs=1e-5)


def test_envs_draw_different_delays_and_a_reset_redraws_them():
    torch.manual_seed(0)
    group, _ = make_group(DelayedDCMotorCfg(min_delay=0, max_delay=8, saturation_effort=80.0), num_envs=64)
    everyone = torch.ones(64, dtype=torch.bool)
    group.reset(everyone)
    first = group.delay_steps[:, 0].clone()
    assert (group.delay_steps == first.unsqueeze(1)).all()  # one lag per env for all its joints
    assert first.min() >= 0 and first.max() <= 8 and len(first.unique()) > 4
    only_half = torch.arange(64) < 32
    group.reset(only_half)
    assert (group.delay_steps[32:, 0] == first[32:]).all()
    assert (group.delay_steps[:32, 0] != first[:32]).any()


@pytest.mark.parametrize("velocity", [-12.0, -5.0, 0.0, 3.0, 8.0, 10.0, 20.0])
def test_dc_motor_torque_speed_clip_matches_formula(velocity):
    tau_sat, v_lim, tau_lim, kp = 80.0, 10.0, 50.0, 100.0
    group, v = make_group(DCMotorCfg(saturation_effort=tau_sat), kp=kp, effort=tau_lim, velocity=v_lim,
                          saturation=tau_sat)
    v.qd[:] = velocity
    for target in (2.0, -2.0):  # ask for +200 / -200 N·m
        v.target[:] = target
        group.step(0.005, 0, 2)
        corner = v_lim * (1 + tau_lim / tau_sat)  # Isaac Lab clips the speed to this first
        speed = max(-corner, min(corner, velocity))
        tau_max = min(tau_sat * (1 - speed / v_lim), tau_lim)
        tau_min = max(tau_sat * (-1 - speed / v_lim), -tau_lim)
        expected = max(tau_min, min(tau_max, kp * target))
        assert v.torque[0, 0].item() == pytest.approx(expected, abs=1e-4)
        assert v.computed[0, 0].item() == pytest.approx(kp * target, abs=1e-4)


def test_ideal_pd_torque_and_effort_limit():
    group, v = make_group(IdealPDActuatorCfg(), kp=100.0, kd=2.0, effort=30.0)
    v.target[:] = torch.tensor([0.1, 1.0])
    v.qd[:] = torch.tensor([1.0, 0.0])
    group.step(0.005, 0, 2)
    assert v.torque[0].tolist() == pytest.approx([100 * 0.1 - 2.0 * 1.0, 30.0])  # second joint clipped
    assert (v.torque.abs() <= 30.0 + 1e-6).all()


def test_armature_gains_and_action_scales_match_the_reference_table():
    assert armature_gains(0.003609725) == pytest.approx((14.251, 0.9072), rel=1e-3)
    assert armature_gains(0.010177520) == pytest.approx((40.179, 2.5579), rel=1e-3)
    assert armature_gains(0.025101925) == pytest.approx((99.098, 6.3088), rel=1e-3)
    assert armature_gains(0.00425) == pytest.approx((16.778, 1.0681), rel=1e-3)
    assert armature_gains(2 * 0.003609725) == pytest.approx((28.5, 1.81), abs=5e-3)  # table rounds
    scales = unitree_g1.ACTION_SCALE
    assert scales[".*_hip_(pitch|yaw)_joint"] == pytest.approx(0.548, abs=1e-3)
    assert scales[".*_hip_roll_joint|.*_knee_joint"] == pytest.approx(0.351, abs=1e-3)
    assert scales[".*_ankle_.*_joint"] == pytest.approx(0.439, abs=1e-3)
    assert scales[".*_wrist_(pitch|yaw)_joint"] == pytest.approx(0.0745, abs=1e-3)
    assert action_scale(88.0, 40.179) == pytest.approx(0.25 * 88.0 / 40.179)
    assert math.isclose(armature_gains(1.0, natural_freq_hz=1.0, damping_ratio=1.0)[0], (2 * math.pi) ** 2)


def test_tasks_run_on_delayed_dc_motors(t1_env):
    robot = t1_env.scene["robot"]
    assert robot.explicit_joints.all()
    group = t1_env.sim.actuator_groups[0]
    assert isinstance(group.cfg, DelayedDCMotorCfg) and group.max_delay == 8
    t1_env.step(torch.full((t1_env.num_envs, 12), 0.3))
    t1_env.step(torch.full((t1_env.num_envs, 12), 0.3))
    assert (robot.applied_torque.abs() <= robot.joint_effort_limit + 1e-4).all()
    assert robot.applied_torque.abs().sum() > 0


@pytest.mark.parametrize("delay", [1, 3])
def test_delayed_implicit_shifts_the_solver_targets_by_k_steps_and_restores_the_command(delay):
    from agile.actuators import DelayedImplicitActuatorCfg, DelayedTargetGroup

    n = 1
    control = SimpleNamespace(joint_target_q=wp.zeros(n * (7 + J), dtype=float),
                              joint_target_qd=wp.zeros(n * (6 + J), dtype=float))
    group = DelayedTargetGroup("legs", DelayedImplicitActuatorCfg(min_delay=delay, max_delay=delay), [0, 1],
                               *world_major(n), control, n, torch.device("cpu"))
    group.reset(torch.ones(n, dtype=torch.bool))
    target = wp.to_torch(control.joint_target_q).view(n, -1)[:, 7:]
    seen = []
    for env_step in range(3):
        if env_step == 1:
            target[:] = 0.5  # a new setpoint at the second env step (physics step 4)
        for substep in range(4):
            group.step(0.005, substep, 4)
            seen.append(target[0, 0].item())  # what the solver sees at this physics step
        group.after_physics()
        assert target[0, 0].item() == (0.5 if env_step >= 1 else 0.0)  # the command is back
    assert seen == pytest.approx([0.0 if k < 4 + delay else 0.5 for k in range(12)])


def test_g1_armature_set_builds_with_delayed_implicit_legs():
    from agile.actuators import DelayedTargetGroup
    from agile.assets.unitree_g1 import g1_armature_actuators, g1_robot_cfg
    from scenes import robot_sim

    sim = robot_sim(g1_robot_cfg(g1_armature_actuators()), 2)
    groups = [g for g in sim.actuator_groups if isinstance(g, DelayedTargetGroup)]
    assert len(groups) == 1 and len(groups[0].joint_ids) == 12
    knee = sim.scene["robot"].find_joints("left_knee_joint")[0][0]
    assert sim.scene["robot"].joint_stiffness[0, knee].item() == pytest.approx(99.098, rel=1e-3)
    assert not sim.scene["robot"].explicit_joints.any()
    sim.scene["robot"].reset_actuators(torch.ones(2, dtype=torch.bool))
    sim.step(4)
    assert torch.isfinite(sim.scene["robot"].joint_pos).all()
