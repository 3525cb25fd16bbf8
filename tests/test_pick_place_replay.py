"""The shipped pick-and-place reference can physically lift the cube: replayed in PickPlace-G1-v0 on CPU, 2 envs,
the robot's root fixed where the reference was solved and the waist and arm targets compensated for gravity
(`scripts/replay_pick_place_reference.py --fixed_root --gravity_compensation`), so that the joints follow the
reference, the hand lifts the cube more than the task's 2 cm lift margin above its start during the carry, and
holds it at the hand's grasp point (the point of the task's hand-object reward: within 2 cm all through the carry).

Before the table's near edge moved from 0.22 m to 0.28 m and the trajectories were remade (a pinch that fits the
cube, the thumb closing toward the fingers, every frame clear of the table), the same replay lifted nothing: the
hand started 3-5 cm inside the table's front and stayed caught under its edge, the palm 22-25 cm from the cube."""

import replay_pick_place_reference as replay_script

TRAJECTORY = "pick_place_left"
LIFT_END_S = 4.6
"""The reference closes the hand by 3.5 s and has lifted the cube 12 cm by 4.5 s: replaying to here is enough."""
MAX_GRASP_DISTANCE_M = 0.02
"""The held cube's centre stays 0.5-1.1 cm from the grasp point in the replay (the palm's centre: 4.9 cm)."""


def test_reference_replay_lifts_the_cube():
    env = replay_script.make_env(TRAJECTORY, num_envs=2, device="cpu", overrides=[], fixed_root=True)
    result = replay_script.replay(env, TRAJECTORY, gravity_compensation=True,
                                  num_steps=round(LIFT_END_S / env.step_dt))
    env.close()
    lift_m = result.carry_lift_m()
    assert (lift_m > replay_script.LIFT_MARGIN_M).all(), f"highest lift during the carry per env: {lift_m.tolist()} m"
    grasp_m = result.carry_grasp_distance_m()
    assert (grasp_m < MAX_GRASP_DISTANCE_M).all(), f"farthest cube from the grasp point in the carry: {grasp_m.tolist()} m"
    assert result.ended_by == ["(still running)"] * 2, result.ended_by
