"""A mesh fault's response at the bearings: its transfer fitted as a nuisance where the teeth separate.

A damaged tooth acts at the mesh. The channels measured at the mesh (the transmission error, the
gear nodes' accelerations) see it directly; a channel measured at a bearing (bearing force, housing
accelerometer) sees it through the shaft and the bearing, whose transfer at the comb frequencies
(the sidebands ``m z +- j`` of the mesh harmonics, 1-5 kHz at 8000 rpm) is the least certain part of
any model of the gearbox: it depends on shaft bending modes and bearing stiffness placed a few
percent off. Where the teeth separate that path carries impacts, and the error grows: measured at
8000 rpm on a damaged pinion tooth (tooth 7, depth 0.4) of the independent lumped gearbox, the
FE signature's bearing-force sidebands are 3-5 times the record's at the true depth and their
phases alone point to teeth 2-3; scored with them at the model's transfer the depth came out at
0.157 and the tooth at 3 (docs/calibration.md Sec. 8.11).

Rule (applied with the rattle rules of ``features_rattle.py``): a damaged tooth's signature enters
each bearing channel multiplied by a complex factor ``a_c`` (amplitude and phase of the path at the
comb frequencies relative to the model's, ``|a_c| <= A_MAX``) fitted by weighted least squares
(closed form) for every tooth and depth tried; the channels at the mesh keep ``a_c = 1`` and set
the depth alone (``Calibrator._param_chi2``: a fitted factor corrects amplitude and phase, not the
shape of the model's response over the comb; against the 2000 rpm reference the bearing forces'
shape misfit pulled the depth to 0.13 for 0.4). The candidate is scored and ranked on every
feature. The factor is a transfer nuisance like the sensor gain, reported in the notes, never a
finding. Measured: on the FE model's own 8000 rpm records (damping x1.2, +-3 % gains, noise) the
factors are 0.80-0.87 in amplitude, phase -0.2 rad; on the lumped records 0.05-0.07 (pinion tooth)
and 0.25 (gear tooth): the independent model's bearings see the damaged tooth far less.

The tooth, i.e. the angular position of the damage in the damaged wheel's synchronous average, is
taken from the channels that measure the mesh itself (:func:`mesh_channels`: the DTE):
the phase of a sideband at a bearing or at a shaft node follows the path's phase at that frequency,
which the model places as uncertainly as its amplitude (on that record the node-5 accelerations'
sidebands alone prefer tooth 12, the bearing forces' teeth 2-3, the DTE's tooth 7).

Assumes: at least one channel at the mesh is measured (the DTE of the issue-6 contract); the
bearing path changes the signature's amplitude, not its shape over the comb (one factor per
channel). Not applied in contact, where the fitted gains and transfer slopes and the 5 % tolerance
hold the path, nor against a held reference baseline (``--baseline``): there it let a pinion tooth
of depth 0.08 claim 22 % of the healthy 8000 rpm record's excess (not traced; Sec. 8.11).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.residual import ModelFeatures

#: Largest transfer factor of a bearing channel relative to the model's path.
A_MAX = 2.0


def path_channels(names: Sequence[str]) -> np.ndarray:
    """Lateral channels measured at a bearing (radial force under it, housing accelerometer): True; at
    the mesh (DTE, mesh force, gear-node motion) and the axial bearing forces: False.

    The axial force of a spur gearbox carries only quasi-static loads (the thermal preload, a tilted
    wheel's axial mesh force at its order 1), transmitted by the static load path (a lever rule over
    the bearing stiffnesses), not by the lateral shaft dynamics at kHz: at 8000 rpm the 1 mrad gear
    misalignment's axial force at gear order 1 is 0.730 N in the FE model and 0.717 N in the lumped
    one (measured, Sec. 8.11)."""
    return np.array(
        [(n.startswith("bearing") and not n.endswith("_fz")) or n.startswith("housing") for n in names],
        dtype=bool,
    )


def axial_channels(names: Sequence[str]) -> np.ndarray:
    """Axial bearing-force channels: the quasi-static axial load path of a spur gearbox."""
    return np.array([n.startswith("bearing") and n.endswith("_fz") for n in names], dtype=bool)


def channels_excess(cmp: Any, feats: ModelFeatures, mask: np.ndarray) -> float:
    """Order chi^2 of the channels in ``mask`` beyond its expectation under noise (2 per complex
    coefficient with a finite uncertainty)."""
    n = 0
    for c in np.flatnonzero(mask):
        for s in range(len(cmp.shafts)):
            n += 2 * int(np.count_nonzero(np.isfinite(cmp.order_sigma2(c, s))))
    return channels_chi2(cmp, feats, mask) - n


def mesh_channels(names: Sequence[str]) -> np.ndarray:
    """Channels that measure the mesh itself (transmission error, mesh force): no shaft, bearing or
    housing dynamics between the tooth and the sensor."""
    return np.array([n.startswith("dte") or n.startswith("mesh") for n in names], dtype=bool)


def channels_chi2(cmp: Any, feats: ModelFeatures, mask: np.ndarray) -> float:
    """Order chi^2 of the channels in ``mask`` on every shaft (gains held at 1, no time shift; left-out
    features have no weight)."""
    g = np.ones(cmp.nc)
    out = 0.0
    for c in np.flatnonzero(mask):
        for s in range(len(cmp.shafts)):
            m = cmp.order_gain(g, c, s) * feats.order[c][s]
            v = np.abs(cmp.d_order[c][s] - m) ** 2 / cmp.order_sigma2(c, s, m)
            out += 2.0 * float(np.sum(v[np.isfinite(v)]))
    return out


def scale_channels(sig: ModelFeatures, a: np.ndarray) -> ModelFeatures:
    """``sig`` with the order and band features of channel ``c`` multiplied by ``a[c]`` (complex) and its
    mean by ``|a[c]|`` (a path has no phase at zero frequency)."""
    a = np.asarray(a)
    return ModelFeatures(
        [[a[c] * x for x in xs] for c, xs in enumerate(sig.order)],
        [a[c] * x for c, x in enumerate(sig.analytic)],
        sig.static * np.abs(a) if sig.static.size == a.size else sig.static,
    )


def path_factors(cmp: Any, cur: ModelFeatures, sig: ModelFeatures, mask: np.ndarray) -> np.ndarray:
    """Transfer factor of each channel for the signature ``sig`` added to ``cur``.

    For a channel in ``mask``: ``a = sum w conj(s) (d - g m) / sum w |s|^2`` (complex) over its order comb
    (the non-carrier orders, where a damaged tooth's signature lies; the carriers' change is small
    against their model-form misfit) on every shaft (``s`` the signature, ``m`` the current model,
    ``d`` the record, ``g`` the held gain, ``w = 1 / sigma^2`` at the model ``m + s``; left-out
    features have no weight), its modulus at most ``A_MAX``. Other channels: 1.

    Parameters
    ----------
    cmp : Comparison
    cur, sig : ModelFeatures
        Current model and the candidate's signature (change relative to the current model).
    mask : numpy.ndarray
        Channels whose factor is fitted (:func:`path_channels`).
    """
    a = np.ones(cmp.nc, dtype=complex)
    g = np.ones(cmp.nc)
    for c in np.flatnonzero(mask):
        num, den = 0j, 0.0
        for s in range(len(cmp.shafts)):
            gs = cmp.order_gain(g, c, s)
            m = gs * cur.order[c][s]
            ds = gs * sig.order[c][s]
            w = 1.0 / cmp.order_sigma2(c, s, m + ds)
            ok = np.isfinite(w) & ~cmp.carriers(s)
            num += complex(np.sum((w * np.conj(ds) * (cmp.d_order[c][s] - m))[ok]))
            den += float(np.sum((w * np.abs(ds) ** 2)[ok]))
        r = num / den if den > 0 else 1.0
        a[c] = r * min(1.0, A_MAX / max(abs(r), 1e-300))
    return a


def with_path(
    cmp: Any, cur: ModelFeatures, feats: ModelFeatures, mask: np.ndarray
) -> tuple[ModelFeatures, np.ndarray]:
    """Full-run features ``feats`` with the change from ``cur`` transferred to the bearing channels by
    fitted factors: ``cur + a * (feats - cur)``. Returns the features and the factors."""
    sig = feats.combo(cur, -1.0)
    a = path_factors(cmp, cur, sig, mask)
    return cur.combo(scale_channels(sig, a), 1.0), a
