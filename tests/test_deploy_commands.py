"""agile deploy's commands: the keyboard's, the command topic's and the G1 remote's, kept within the ranges the
policy was trained on."""

from __future__ import annotations

import numpy as np

from deploy_fakes import Clock, state


def test_the_remote_round_trips_and_maps_the_sticks():
    from agile.deploy.unitree_g1 import Remote

    remote = Remote.parse(bytes(Remote.pack(buttons=("start", "A"), lx=0.5, ly=1.0, rx=-0.25, ry=0.1)))
    assert remote.buttons == {"start", "A"}
    assert (remote.lx, remote.ly, remote.rx) == (0.5, 1.0, -0.25)
    np.testing.assert_allclose(remote.velocity_command(0.5, 0.4, 1.0), [0.5, -0.2, 0.25])
    assert Remote.parse(bytes(40)).buttons == frozenset()



def test_the_command_stays_in_the_trained_ranges_and_refuses_what_is_not_finite():
    from agile.deploy.commands import PolicyCommand, command_ranges, parse_keyboard_line

    commands = {"base_velocity": {"ranges": {"lin_vel_x": [-0.5, 1.0], "lin_vel_y": [-0.5, 0.5],
                                             "ang_vel_z": [-1.0, 1.0], "base_height_m": [0.4, 0.75]}}}
    lower, upper = command_ranges(commands, ("lin_vel_x", "lin_vel_y", "ang_vel_z", "base_height"))
    np.testing.assert_allclose(lower, [-0.5, -0.5, -1.0, 0.4])
    command = PolicyCommand(initial=np.array([0.0, 0.0, 0.0, 0.72]), lower=lower, upper=upper, clock=Clock())
    assert command.set(parse_keyboard_line("2.0 0 -3"), "the keyboard")  # clipped, the height kept
    np.testing.assert_allclose(command(), [1.0, 0.0, -1.0, 0.72])
    assert command.set([0.3, 0.1, 0.2, 0.1], "the keyboard")
    np.testing.assert_allclose(command(), [0.3, 0.1, 0.2, 0.4])
    assert command.clipped == 2
    assert not command.set([np.nan, 0, 0], "the keyboard") and not command.set([0.1, 0.2], "the keyboard")
    assert not command.set([0, 0, 0, 0.5, 1], "the keyboard")
    assert command.refused == 3 and parse_keyboard_line("go") is None and parse_keyboard_line("1 2") is None
    np.testing.assert_allclose(command(), [0.3, 0.1, 0.2, 0.4])
    assert [e.text for e in command.events] == ["the keyboard: command 1 0 -1 0.72", "the keyboard: command 0.3 0.1 0.2 0.4"]


def test_a_silent_command_topic_leaves_the_robot_standing_until_it_speaks_again():
    from agile.deploy.commands import PolicyCommand

    clock = Clock()
    command = PolicyCommand(initial=np.zeros(3), lower=np.full(3, -0.5), upper=np.full(3, 0.5),
                            stream_timeout_s=0.5, clock=clock)
    np.testing.assert_allclose(command(), 0.0)  # before the first message: the initial command
    command.set_velocity_stream(0.4, 0.0, 2.0)
    np.testing.assert_allclose(command(), [0.4, 0.0, 0.5])
    command.set_velocity_stream(float("nan"), 0.0, 0.0)  # refused: the last good one holds
    clock.now_s = 0.4
    np.testing.assert_allclose(command(), [0.4, 0.0, 0.5])
    clock.now_s = 0.6
    np.testing.assert_allclose(command(), 0.0)
    clock.now_s = 0.7
    command.set_velocity_stream(-0.2, 0.1, 0.0)
    np.testing.assert_allclose(command(), [-0.2, 0.1, 0.0])
    assert [e.text for e in command.events] == ["command topic silent for more than 0.5 s: standing",
                                                "command topic speaking again"]
    assert command.summary()["stream_messages"] == 3 and command.refused == 1


def test_the_remote_sticks_are_read_per_state_within_the_ranges():
    from agile.deploy.commands import PolicyCommand
    from agile.deploy.unitree_g1 import Remote

    command = PolicyCommand(initial=np.zeros(3), lower=np.array([-0.5, -0.5, -1.0]), upper=np.array([1.0, 0.5, 1.0]),
                            per_state=lambda s: Remote.parse(s.remote).velocity_command(1.0, 0.5, 1.0))
    s = state()
    s.remote = bytes(Remote.pack(ly=-1.0, lx=-1.0, rx=0.5))
    np.testing.assert_allclose(command(s), [-0.5, 0.5, -0.5])
