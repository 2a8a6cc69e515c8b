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
0.157 and the tooth at 3 (docs/history/calibration_sessions.md Sec. 8.11).

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

Since the channels at the mesh name the tooth, a damaged tooth whose path is fitted must also be
seen there: its comb on its wheel's shaft at those channels must gain beyond the BIC threshold
(:func:`mesh_comb_gain`). With the bearing forces made neutral by their factor, nothing else stopped
a small tooth from reading the rattle's model-form comb at the node accelerations: on the healthy
8000 rpm record against the held 2000 rpm reference a pinion tooth (28, depth 0.08) took 20 % of
the excess that way while the DTE's comb got worse (docs/history/calibration_sessions.md Sec. 8.17).

Seen there it must also be a tooth: the family rules of ``comb_families.py`` (a broad comb over the
sideband families, the fundamental family with the others where the teeth separate) hold for the gain
at these channels as for the gain over all channels (:func:`mesh_comb_gain_by_family`). On the
independent worn 8000 rpm record against the 2000 rpm reference fitted at 64 steps per mesh a pinion
tooth gained 234 at the DTE in sum but only in two families; its broad gain and its fundamental came
from the node-5 accelerations (docs/history/calibration_sessions.md Sec. 8.21).

Against a held reference baseline (``--baseline``) the rule applies as without one. The reference's
bearing scales, identified by the lateral modes in contact, are linear properties of the shaft and
bearings and bring the model's path much nearer the machine's (fitted factors on the independent
pinion-tooth record about 0.4-0.5 in modulus with the 2000 rpm reference, against 0.05-0.07 without
one before Sec. 8.17's change of the factor fit); the factor corrects what is left.

A damaged tooth's path is fitted per band (``path_factors(bands=True)``, ``FitSettings.tooth_path_bands``;
docs/history/calibration_sessions.md Sec. 8.37): one factor for the low orders and one for the sidebands
``h z +- j`` of each mesh harmonic ``h``. Between the bands lie the modes that shape the path (at 8000 rpm
the FE model's mesh mode, 5.3-5.8 kHz, between the first harmonic's sidebands at 3.4-4.3 kHz and the
second's at 7.3-8.2 kHz; the independent gearbox's at 6.4 kHz): measured on the independent 8000 rpm
gear-tooth record against the held 2000 rpm reference, the fitted factors of ``bearing2_fx`` are
0.14, 0.79 and 0.20 in modulus for the three bands, and with one factor per channel the bearing
channels' comb kept a chi^2 of 8-42 per feature on the gear shaft (error ratio 0.527 against
0.434 with the bands).

Assumes: at least one channel at the mesh is measured (the DTE of the issue-6 contract); the
bearing path changes the signature's amplitude, not its shape, within a band of ``+-6`` shaft orders
around a mesh harmonic (a damaged tooth: one factor per band; a misaligned gear: one per channel).
Not applied in contact, where the fitted gains and transfer slopes and the 5 % tolerance hold the
path (unless ``FitSettings.tooth_path_in_contact``, ``candidates_tooth_path.py``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.optimize import minimize

from gear_rotor_sim.calibration.comb_families import sideband_family
from gear_rotor_sim.calibration.residual import ModelFeatures

#: Largest transfer factor of a bearing channel relative to the model's path.
A_MAX = 2.0
#: Reweighted solutions of a path factor (:func:`path_factors`) and their relative convergence tolerance.
MAX_ITER = 12
REL_TOL = 1e-3


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


def order_terms(cmp: Any, feats: ModelFeatures, c: int, s: int) -> np.ndarray:
    """Per-order normalised squared residual of channel ``c`` on shaft ``s`` (gains held at 1, no time
    shift; left-out features are not finite)."""
    m = cmp.order_gain(np.ones(cmp.nc), c, s) * feats.order[c][s]
    return np.abs(cmp.d_order[c][s] - m) ** 2 / cmp.order_sigma2(c, s, m)


def channels_chi2(
    cmp: Any, feats: ModelFeatures, mask: np.ndarray, select: list[list[np.ndarray]] | None = None
) -> float:
    """Order chi^2 of the channels in ``mask`` on every shaft (gains held at 1, no time shift; left-out
    features have no weight); ``select[c][s]`` (optional) keeps only those orders of channel ``c`` on shaft
    ``s``."""
    out = 0.0
    for c in np.flatnonzero(mask):
        for s in range(len(cmp.shafts)):
            v = order_terms(cmp, feats, c, s)
            keep = np.isfinite(v) if select is None else select[c][s] & np.isfinite(v)
            out += 2.0 * float(np.sum(v[keep]))
    return out


def mesh_comb_gain_by_order(
    cmp: Any, before: ModelFeatures, after: ModelFeatures, shaft: int
) -> np.ndarray | None:
    """Order chi^2 gain from ``before`` to ``after`` per order of ``shaft`` at the channels that measure
    the mesh (:func:`mesh_channels`; gains held at 1, no time shift; carriers and left-out features
    gain 0). None if no such channel is measured."""
    mask = mesh_channels(cmp.names)
    if not mask.any():
        return None
    out = np.zeros(cmp.shafts[shaft].orders.size)
    k = ~cmp.carriers(shaft)
    for c in np.flatnonzero(mask):
        for f, sign in ((before, 1.0), (after, -1.0)):
            v = order_terms(cmp, f, c, shaft)
            out += sign * 2.0 * np.where(k & np.isfinite(v), v, 0.0)
    return out


def mesh_comb_gain(cmp: Any, before: ModelFeatures, after: ModelFeatures, shaft: int) -> float:
    """Order chi^2 gain from ``before`` to ``after`` on the comb (non-carrier orders) of ``shaft`` at
    the channels that measure the mesh (:func:`mesh_channels`; gains held at 1, as where the path is
    fitted). ``nan`` if no such channel is measured.

    A damaged tooth whose path to the other channels is fitted is named by these channels
    (``Calibrator._fit_tooth``); it must also be seen there. On the independent healthy 8000 rpm
    record against the held 2000 rpm reference a pinion tooth (tooth 28, depth 0.08) took 22 % of the
    excess from the node-5 accelerations' rattle comb while the DTE's comb on the pinion shaft got
    worse (415 -> 572; docs/history/calibration_sessions.md Sec. 8.17)."""
    gain = mesh_comb_gain_by_order(cmp, before, after, shaft)
    return float("nan") if gain is None else float(np.sum(gain))


def mesh_comb_gain_by_family(
    cmp: Any, before: ModelFeatures, after: ModelFeatures, shaft: int
) -> dict[int, float]:
    """:func:`mesh_comb_gain` per sideband family ``j`` of ``shaft`` (``comb_families.sideband_family``:
    the low order ``j`` and ``m z +- j``); empty if no channel measures the mesh or the shaft carries
    no gear.

    Seen at the mesh, a damaged tooth is a broad comb as everywhere: the family rules of
    ``comb_families.py`` hold at these channels too (``Calibrator._tooth_comb_check``). On the
    independent worn 8000 rpm record (1 s, 20 um) against the 2000 rpm reference fitted at 64 steps
    per mesh (mesh x1.21), a pinion tooth of depth 0.19 gained 234 at the DTE in sum, but per family
    -153, -135, +283, +413, (5 left out), -174: two rattle components, not a tooth; its fundamental
    family gained only at the node-5 accelerations (docs/history/calibration_sessions.md Sec. 8.21)."""
    sh = cmp.shafts[shaft]
    gain = mesh_comb_gain_by_order(cmp, before, after, shaft)
    if gain is None or not sh.teeth:
        return {}
    fam = sideband_family(sh.orders, sh.teeth)
    return {int(j): float(np.sum(gain[fam == j])) for j in np.unique(fam) if j > 0}


def order_bands(cmp: Any) -> list[np.ndarray]:
    """Band of every analysed order, per shaft: 0 for the low orders (below the first mesh harmonic's
    sidebands), ``h`` for the orders ``h z +- j`` around the mesh harmonic ``h`` (``z`` the shaft's
    teeth; a shaft without a gear: all 0)."""
    out = []
    for sh in cmp.shafts:
        out.append(np.rint(sh.orders / sh.teeth).astype(int) if sh.teeth else np.zeros(sh.orders.size, int))
    return out


def n_bands(cmp: Any) -> int:
    """Number of path bands: the low orders and each analysed mesh harmonic."""
    return 1 + max((int(b.max()) for b in order_bands(cmp) if b.size), default=0)


def envelope_band_index(cmp: Any, c: int, nb: int) -> int:
    """Path band whose factor a channel's envelope (band-passed) signal takes: the mesh harmonic nearest
    the centre of the channel's envelope band (the low band if the channel has none or no mesh)."""
    bands = getattr(cmp, "bands", None)
    band = bands[c] if bands is not None and c < len(bands) else None
    if band is None or not getattr(cmp, "mesh_hz", 0.0):
        return 0
    return int(np.clip(np.rint(0.5 * (band[0] + band[1]) / cmp.mesh_hz), 0, nb - 1))


def scale_channels(sig: ModelFeatures, a: np.ndarray, cmp: Any = None) -> ModelFeatures:
    """``sig`` with the order and band features of channel ``c`` multiplied by ``a[c]`` (complex) and its
    mean by ``|a[c]|`` (a path has no phase at zero frequency).

    With banded factors (``a`` of shape ``(channels, bands)``, :func:`path_factors` with ``bands=True``;
    ``cmp`` then needed) order ``k`` of a shaft takes the factor of its band (:func:`order_bands`), the
    envelope signal that of :func:`envelope_band_index` and the mean that of the low band."""
    a = np.asarray(a)
    if a.ndim == 2:
        ob = order_bands(cmp)
        nb = a.shape[1]
        order = [
            [a[c][np.minimum(ob[s], nb - 1)] * x for s, x in enumerate(xs)] for c, xs in enumerate(sig.order)
        ]
        env = [a[c, envelope_band_index(cmp, c, nb)] * x for c, x in enumerate(sig.analytic)]
        static = sig.static * np.abs(a[:, 0]) if sig.static.size == a.shape[0] else sig.static
        return ModelFeatures(order, env, static)
    return ModelFeatures(
        [[a[c] * x for x in xs] for c, xs in enumerate(sig.order)],
        [a[c] * x for c, x in enumerate(sig.analytic)],
        sig.static * np.abs(a) if sig.static.size == a.size else sig.static,
    )


def _comb_terms(
    cmp: Any,
    cur: ModelFeatures,
    sig: ModelFeatures,
    c: int,
    a: complex,
    sel: Sequence[np.ndarray] | None = None,
) -> tuple[complex, float, float]:
    """Weighted least-squares terms of channel ``c``'s comb (only the orders ``sel[s]`` of each shaft if
    given) with the weights taken at the model ``m + a s``: ``sum w conj(s) (d - m)``, ``sum w |s|^2``
    and the comb chi^2 at ``a``."""
    num, den, chi2 = 0j, 0.0, 0.0
    g = np.ones(cmp.nc)
    for s in range(len(cmp.shafts)):
        gs = cmp.order_gain(g, c, s)
        m = gs * cur.order[c][s]
        ds = gs * sig.order[c][s]
        w = 1.0 / cmp.order_sigma2(c, s, m + a * ds)
        ok = np.isfinite(w) & ~cmp.carriers(s)
        if sel is not None:
            ok &= sel[s]
        r = cmp.d_order[c][s] - m
        num += complex(np.sum((w * np.conj(ds) * r)[ok]))
        den += float(np.sum((w * np.abs(ds) ** 2)[ok]))
        chi2 += 2.0 * float(np.sum((w * np.abs(r - a * ds) ** 2)[ok]))
    return num, den, chi2


def _capped(a: complex) -> complex:
    """``a`` with its modulus at most :data:`A_MAX`."""
    return complex(a * min(1.0, A_MAX / max(abs(a), 1e-300)))


def path_factors(
    cmp: Any,
    cur: ModelFeatures,
    sig: ModelFeatures,
    mask: np.ndarray,
    max_iter: int = MAX_ITER,
    bands: bool = False,
) -> np.ndarray:
    """Transfer factor of each channel for the signature ``sig`` added to ``cur``.

    For a channel in ``mask``: the complex ``a`` (modulus at most ``A_MAX``) that minimises the
    channel's chi^2 over its order comb (the non-carrier orders, where a damaged tooth's signature
    lies; the carriers' change is small against their model-form misfit) on every shaft,
    ``sum |d - g m - a g s|^2 / sigma^2(g m + a g s)`` (``s`` the signature, ``m`` the current model,
    ``d`` the record, ``g`` the held gain; left-out features have no weight), i.e. the chi^2 the
    channel is scored with. Other channels: 1.

    ``sigma^2`` depends on the model it is taken at (the model-form tolerance is relative to
    ``min(|model|, |data|)``). Solved once with the weights at ``m + s``, as before, the factor was
    scored at ``m + a s``: on the independent 8000 rpm pinion-tooth record against the held 2000 rpm
    reference (depth 0.3) it came out -0.04+0.07j with a comb chi^2 of ``bearing2_fx`` of 49080,
    against 7572 with the model's own path ``a = 1`` (docs/history/calibration_sessions.md Sec. 8.17). Now:
    weighted least squares with the weights iterated to the model they are taken at (at most ``max_iter``
    solutions), then a simplex search of the chi^2 itself from the best of those and ``a = 1``; the
    model's path stays a candidate, so the fitted path is never worse than it.

    Parameters
    ----------
    cmp : Comparison
    cur, sig : ModelFeatures
        Current model and the candidate's signature (change relative to the current model).
    mask : numpy.ndarray
        Channels whose factor is fitted (:func:`path_channels`).
    max_iter : int
        Largest number of reweighted least-squares solutions per channel.
    bands : bool
        One factor per channel and path band (:func:`order_bands`: the low orders and the sidebands of
        each mesh harmonic), each fitted on its band's comb alone; shape ``(channels, bands)``
        (docs/history/calibration_sessions.md Sec. 8.37). Else one factor per channel, shape ``(channels,)``.
    """
    if bands:
        ob = order_bands(cmp)
        nb = n_bands(cmp)
        out = np.ones((cmp.nc, nb), dtype=complex)
        for c in np.flatnonzero(mask):
            for h in range(nb):
                out[c, h] = _fit_factor(cmp, cur, sig, c, max_iter, [b == h for b in ob])
        return out
    a = np.ones(cmp.nc, dtype=complex)
    for c in np.flatnonzero(mask):
        a[c] = _fit_factor(cmp, cur, sig, c, max_iter, None)
    return a


def _fit_factor(
    cmp: Any, cur: ModelFeatures, sig: ModelFeatures, c: int, max_iter: int, sel: Sequence[np.ndarray] | None
) -> complex:
    """The factor of channel ``c`` (on the orders ``sel``) of :func:`path_factors`: reweighted least
    squares, then a simplex search of the chi^2 from the best of those and ``a = 1``."""
    num, den, chi2_one = _comb_terms(cmp, cur, sig, c, 1.0 + 0j, sel)
    best = (chi2_one, 1.0 + 0j)
    ac = 1.0 + 0j
    for _ in range(max_iter):
        r = _capped(num / den) if den > 0 else 1.0 + 0j
        num, den, chi2_r = _comb_terms(cmp, cur, sig, c, r, sel)
        if chi2_r < best[0]:
            best = (chi2_r, r)
        converged = abs(r - ac) <= REL_TOL * max(abs(r), abs(ac), 1e-12)
        ac = r
        if converged:
            break
    if best[0] > 0 and np.isfinite(best[0]):

        def chi2(p: np.ndarray) -> float:
            return _comb_terms(cmp, cur, sig, c, _capped(complex(p[0], p[1])), sel)[2]

        step = max(0.05 * abs(best[1]), 0.01)
        x0 = np.array([best[1].real, best[1].imag])
        res = minimize(
            chi2,
            x0,
            method="Nelder-Mead",
            options={
                "initial_simplex": x0 + np.array([[0.0, 0.0], [step, 0.0], [0.0, step]]),
                "xatol": REL_TOL * max(abs(best[1]), 0.01),
                "fatol": 1e-6 * best[0],
                "maxfev": 200,
            },
        )
        if res.fun < best[0]:
            best = (float(res.fun), _capped(complex(res.x[0], res.x[1])))
    return best[1]


def with_path(
    cmp: Any, cur: ModelFeatures, feats: ModelFeatures, mask: np.ndarray, bands: bool = False
) -> tuple[ModelFeatures, np.ndarray]:
    """Full-run features ``feats`` with the change from ``cur`` transferred to the bearing channels by
    fitted factors: ``cur + a * (feats - cur)`` (``bands``: one factor per path band, :func:`path_factors`).
    Returns the features and the factors."""
    sig = feats.combo(cur, -1.0)
    a = path_factors(cmp, cur, sig, mask, bands=bands)
    return cur.combo(scale_channels(sig, a, cmp), 1.0), a
