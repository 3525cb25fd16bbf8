"""The velocity-observability analysis (scripts/velocity_observability.py): its windows and estimators on data
whose answer is known."""

import importlib.util
from pathlib import Path

import torch

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "velocity_observability.py"
spec = importlib.util.spec_from_file_location("velocity_observability", SCRIPT)
analysis = importlib.util.module_from_spec(spec)
spec.loader.exec_module(analysis)


def test_a_window_holds_each_steps_last_frames_oldest_first():
    frames = torch.arange(6.0).reshape(6, 1, 1)  # (T, N, F): frame t holds t
    windows = analysis.windows_of(frames, 3)
    assert windows.shape == (4, 1, 3)
    assert windows[:, 0].tolist() == [[0, 1, 2], [1, 2, 3], [2, 3, 4], [3, 4, 5]]


def test_the_estimators_find_a_velocity_that_is_in_the_features_and_not_one_that_is_not():
    generator = torch.Generator().manual_seed(0)
    x = torch.randn(4000, 6, generator=generator)
    train = torch.arange(4000) % 2 == 0
    readable = torch.stack((x[:, 0] - 2 * x[:, 3], 0.5 * x[:, 1]), dim=1)  # a linear function of the features
    hidden = torch.randn(4000, 2, generator=generator) * 0.1  # independent of them: RMSE ~ its own, 0.1 * sqrt(2)
    assert analysis.ridge_rmse(x, readable, train, ridge=1e-6) < 1e-3
    assert abs(analysis.ridge_rmse(x, hidden, train, ridge=1e-6) - 0.1 * 2 ** 0.5) < 0.01
    assert analysis.mlp_rmse(x, readable, train, iterations=350, seed=0) < 0.1
    assert analysis.mlp_rmse(x, hidden, train, iterations=100, seed=0) > 0.12
