import math

import pytest
import torch

from agile.sim.names import resolve_names, resolve_values
from agile.utils.math import quat_from_euler_xyz, quat_mul, quat_rotate, quat_rotate_inverse, wrap_to_pi, yaw_from_quat

NAMES = ["left_hip", "left_knee", "right_hip", "right_knee", "waist"]


def test_regex_matches_fully_in_name_order():
    ids, names = resolve_names([".*knee", "left_.*"], NAMES)
    assert ids == [0, 1, 3] and names == ["left_hip", "left_knee", "right_knee"]


def test_preserve_order_follows_expressions():
    ids, _ = resolve_names(["right_hip", "left_hip"], NAMES, preserve_order=True)
    assert ids == [2, 0]


def test_regex_matching_nothing_lists_the_names():
    with pytest.raises(ValueError, match=r"'ankle' matches no joint.*left_hip.*waist"):
        resolve_names("ankle", NAMES)


def test_resolve_values_scalar_and_dict():
    assert resolve_values(2.0, NAMES[:2]) == {0: 2.0, 1: 2.0}
    assert resolve_values({".*hip": 1.0, "waist": 3.0}, NAMES) == {0: 1.0, 2: 1.0, 4: 3.0}


def test_quaternion_helpers():
    q = quat_from_euler_xyz(torch.tensor([0.0]), torch.tensor([0.0]), torch.tensor([math.pi / 2]))
    v = torch.tensor([[1.0, 0.0, 0.0]])
    assert torch.allclose(quat_rotate(q, v), torch.tensor([[0.0, 1.0, 0.0]]), atol=1e-6)
    assert torch.allclose(quat_rotate_inverse(q, quat_rotate(q, v)), v, atol=1e-6)
    assert torch.allclose(yaw_from_quat(q), torch.tensor([math.pi / 2]), atol=1e-6)
    qq = quat_mul(q, q)  # 180 degrees about z
    assert torch.allclose(quat_rotate(qq, v), torch.tensor([[-1.0, 0.0, 0.0]]), atol=1e-6)
    assert torch.allclose(wrap_to_pi(torch.tensor([3 * math.pi / 2])), torch.tensor([-math.pi / 2]))
