"""The simulator node's sensor noise (ros/stream_noise.py) against its definition: ``x + bias +
N(mean, stddev)`` per channel, the bias drawn once per model from ``N(bias_mean, bias_stddev)``, seeded.

Statistical checks use tolerances of a few standard errors of the estimate (sigma / sqrt(n)), so a
wrong mean, spread, broadcast or bias rule fails while the seeded draws pass.
"""

from __future__ import annotations

import numpy as np
import pytest

from gear_rotor_sim.ros.params import ParamError
from gear_rotor_sim.ros.stream_noise import NoiseModel

N = 200_000


def _params(**kw: list[float]) -> dict[str, list[float]]:
    return {"mean": [], "stddev": [], "bias_mean": [], "bias_stddev": [], **kw}


def test_white_part_has_the_configured_mean_and_spread_per_channel() -> None:
    mean, std = np.array([1e-6, -2e-6, 0.0]), np.array([1e-6, 3e-6, 5e-7])
    model = NoiseModel(3, _params(mean=mean.tolist(), stddev=std.tolist()), seed=4, stream="dte")
    x = np.full((N, 3), 2.5e-5)  # a constant signal: the difference is the noise
    e = model.apply(x) - x
    assert np.all(np.abs(e.mean(axis=0) - mean) <= 5.0 * std / np.sqrt(N))
    # the sample standard deviation of Gaussian data has a standard error sigma / sqrt(2 n)
    assert np.all(np.abs(e.std(axis=0) - std) <= 5.0 * std / np.sqrt(2 * N))
    assert np.all(np.abs(np.corrcoef(e.T) - np.eye(3)) <= 5.0 / np.sqrt(N))  # channels independent


def test_bias_is_drawn_once_per_model_from_its_distribution() -> None:
    bias_mean, bias_std = 0.5, 0.1
    params = _params(bias_mean=[bias_mean], bias_stddev=[bias_std])
    model = NoiseModel(2, params, seed=1, stream="bearing_forces")
    x = np.zeros((1000, 2))
    first, second = model.apply(x), model.apply(x)
    # no white part: every sample of every block carries the same per-channel bias
    assert np.all(first == first[0]) and np.all(second == first[0])
    assert first[0, 0] != first[0, 1]  # drawn per channel
    # over many models (seeds) the biases follow N(bias_mean, bias_std)
    biases = np.array([NoiseModel(1, params, seed=s, stream="dte").bias[0] for s in range(4000)])
    se = bias_std / np.sqrt(biases.size)
    assert abs(biases.mean() - bias_mean) <= 5.0 * se
    assert abs(biases.std() - bias_std) <= 5.0 * bias_std / np.sqrt(2 * biases.size)


def test_a_seed_reproduces_the_run_and_no_noise_is_a_no_op() -> None:
    params = _params(stddev=[1.0], bias_stddev=[0.2])
    x = np.linspace(0.0, 1.0, 50).reshape(25, 2)
    a, b = NoiseModel(2, params, 7, "dte"), NoiseModel(2, params, 7, "dte")
    assert np.array_equal(a.apply(x), b.apply(x))
    assert not np.array_equal(NoiseModel(2, params, 8, "dte").apply(x), a.apply(x))
    quiet = NoiseModel(2, _params(), 7, "dte")
    assert not quiet.active and quiet.apply(x) is x


def test_a_list_of_the_wrong_length_names_the_parameter() -> None:
    with pytest.raises(ParamError, match=r"noise\.dte\.stddev: 2 values given.*one per channel \(3\)"):
        NoiseModel(3, _params(stddev=[1.0, 2.0]), 0, "dte")
