"""Sensor noise the simulator node adds to its published streams (a sensor model, off by default)."""

from __future__ import annotations

from typing import Any

import numpy as np

from gear_rotor_sim.ros.params import NOISE_FIELDS, STREAM_NAMES, broadcast
from gear_rotor_sim.streams import StreamSpec


class NoiseModel:
    """Gazebo-style Gaussian sensor noise of one stream: ``x + bias + N(mean, stddev)``.

    The bias of each channel is drawn once, from ``N(bias_mean, bias_stddev)``, when the model is
    built; the white part is drawn per sample. The generator is seeded, so a run is reproducible.
    """

    def __init__(self, n_channels: int, params: dict[str, list[float]], seed: int, stream: str) -> None:
        self.mean = np.asarray(broadcast(params["mean"], n_channels, f"noise.{stream}.mean"))
        self.stddev = np.asarray(broadcast(params["stddev"], n_channels, f"noise.{stream}.stddev"))
        bias_mean = np.asarray(broadcast(params["bias_mean"], n_channels, f"noise.{stream}.bias_mean"))
        bias_std = np.asarray(broadcast(params["bias_stddev"], n_channels, f"noise.{stream}.bias_stddev"))
        self._rng = np.random.default_rng(seed)
        self.bias = bias_mean + bias_std * self._rng.standard_normal(n_channels)
        self.active = bool(np.any(self.stddev) or np.any(self.mean) or np.any(self.bias))

    def apply(self, data: np.ndarray) -> np.ndarray:
        """Noisy copy of ``data`` (shape ``(n_samples, n_channels)``); ``data`` itself when inactive."""
        if not self.active:
            return data
        noise = self._rng.standard_normal(data.shape) * self.stddev
        return data + (self.mean + self.bias) + noise


def check_noise_lengths(streams: list[StreamSpec], values: dict[str, Any]) -> None:
    """Raise ``ParamError`` naming ``noise.<stream>.<field>`` when a list does not fit its stream."""
    for spec in streams:
        for f in NOISE_FIELDS:
            broadcast(values[f"noise.{spec.name}.{f}"], len(spec.channels), f"noise.{spec.name}.{f}")


def build_noise(streams: list[StreamSpec], values: dict[str, Any]) -> dict[str, NoiseModel]:
    """One :class:`NoiseModel` per stream from the ``noise.*`` parameters (seed + stream index)."""
    return {
        spec.name: NoiseModel(
            len(spec.channels),
            {f: values[f"noise.{spec.name}.{f}"] for f in NOISE_FIELDS},
            int(values["noise.seed"]) + STREAM_NAMES.index(spec.name),
            spec.name,
        )
        for spec in streams
    }
