"""A damaged tooth's impacts that scatter from revolution to revolution where the teeth separate
(issue 11; docs/history/calibration_sessions.md Sec. 8.14).

Where the teeth stay in contact a damaged tooth changes the response once per revolution of its
wheel in the same way every time: the change is synchronous with the wheel, lies in its synchronous
average (the order family) and leaves nothing in the envelope of the non-synchronous part (every
shaft's synchronous average removed, ``features_orders.remove_synchronous``), which is kept for
bearing defects. Where the teeth separate the damaged tooth strikes a pair in free flight whose
state at that instant depends on the rattle; in a machine whose rattle is not locked to the mesh the
response to each pass of the tooth differs from the last. The non-synchronous part then holds the
revolution-to-revolution scatter of that response, ``(eps_i - 1) s(t)`` in revolution ``i`` for a
response ``s`` to the tooth and a random factor ``eps_i`` of mean 1, and its squared envelope holds
lines at the harmonics of the wheel's rate with the shape of the envelope of ``s`` in the band: in
expectation ``var(eps)^2`` times the envelope spectrum of ``s``'s band-passed signal at those lines.

Measured on the independent lumped gearbox at 8000 rpm (gear tooth 5 at depth 0.4): 93 % of the
envelope family's misfit of the radial bearing forces lies at the gear-rate harmonics
(``k 78.9 Hz``), chi^2 11856 and 16280 over 159 bins; the FE model's response there is periodic over
the hunting period and predicts none of it. With the FE tooth's own band-passed response at the
fitted depth (0.251) scaled by one factor per channel, 0.134 and 0.135, the two channels' envelope
chi^2 fall to 301 and 309 (the noise level is 159 each): the lines have the shape of the tooth's
response envelope, and only their level is not predicted.

Rule (:func:`with_scatter`, applied to a damaged tooth's candidate where the healthy model's teeth
separate and the envelope is that of the non-synchronous part): the tooth's response change ``s``
(its full run minus the current model, band-passed to each envelope channel's band) enters that
channel's non-synchronous analytic signal times a factor ``sigma_c`` in ``[0, SIGMA_MAX]``, fitted
per channel to the channel's envelope chi^2 (grid, then bounded Brent). ``sigma_c`` is the RMS
scatter of the tooth's response at that channel relative to the model's response (the product of
the scatter share and the path factor of ``fault_path.py``): a transfer nuisance, reported in the
notes, never a finding, and counted as a parameter of the candidate in its BIC. It is bounded by 1,
the scatter as large as the response itself, so that the lines follow the tooth's depth: a small
tooth cannot claim large lines. The depth and the tooth index are set by the order features as
before (``fault_path.py``).

Assumes: the damaged tooth's response in the envelope band has the model's shape over the
revolution (the lines' relative levels), only its level scatters; the scatter is the same in
character at every line (one factor per channel). A machine whose rattle is locked to the mesh (a
periodic response, like the FE model's own) has no scatter: then ``sigma_c = 0`` fits best and the
rule changes nothing.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from gear_rotor_sim.analysis.signals import analytic_band
from gear_rotor_sim.calibration.features_rattle import MIN_CONTACT_LOSS
from gear_rotor_sim.calibration.residual import ModelFeatures

#: Largest scatter factor: the revolution-to-revolution RMS scatter of the tooth's response as large
#: as the model's response itself.
SIGMA_MAX = 1.0
#: Grid of the scatter factor before the bounded refinement (the envelope chi^2 is steep in it: the
#: lines grow like ``sigma^4``).
SIGMA_GRID: tuple[float, ...] = (0.0, 0.01, 0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0)


def scatter_applies(cmp: Any, contact_loss: float) -> bool:
    """The envelope family is that of the non-synchronous part and the healthy model's teeth separate
    (contact-loss fraction above ``features_rattle.MIN_CONTACT_LOSS``)."""
    return bool("envelope" in cmp.families and cmp.env_non_sync and contact_loss > MIN_CONTACT_LOSS)


def band_signature(cmp: Any, change: np.ndarray) -> list[np.ndarray]:
    """Analytic signal of a response change ``change`` (n, channels), band-passed to each envelope
    channel's band (zeros on the channels without envelope features)."""
    out = []
    for c in range(cmp.nc):
        x = change[:, c]
        if cmp.env_use[c] and cmp.env_floor[c] > 0 and np.any(x):
            out.append(analytic_band(x, cmp.fs, cmp.bands[c]))
        else:
            out.append(np.zeros(change.shape[0], dtype=complex))
    return out


def channel_chi2(cmp: Any, feats: ModelFeatures, c: int) -> float:
    """Envelope chi^2 of channel ``c`` for the model features ``feats`` (``Comparison.score``, whose
    envelope noise model it uses)."""
    r2 = cmp.score(feats).envelope_r2
    return float(np.sum(r2[c])) if c < len(r2) else 0.0


def _with_channel(feats: ModelFeatures, c: int, analytic: np.ndarray) -> ModelFeatures:
    out = list(feats.analytic)
    out[c] = analytic
    return ModelFeatures(feats.order, out, feats.static)


def fit_scatter(cmp: Any, feats: ModelFeatures, sig: np.ndarray, c: int) -> tuple[float, float]:
    """Scatter factor of channel ``c`` minimising its envelope chi^2 with the channel's analytic signal
    ``feats.analytic[c] + sigma sig``. Returns ``(sigma, chi2)``; ``sigma = 0`` when no factor improves
    the fit."""
    a0 = feats.analytic[c]

    def chi(s: float) -> float:
        return channel_chi2(cmp, _with_channel(feats, c, a0 + s * sig), c)

    vals = [(s, chi(s)) for s in SIGMA_GRID if s <= SIGMA_MAX]
    k = int(np.argmin([v for _, v in vals]))
    best = vals[k]
    if k > 0:
        lo, hi = vals[k - 1][0], vals[min(k + 1, len(vals) - 1)][0]
        res = minimize_scalar(chi, bounds=(lo, hi), method="bounded", options={"xatol": 1e-3 * hi})
        if res.fun < best[1]:
            best = (float(res.x), float(res.fun))
    return best


def with_scatter(cmp: Any, feats: ModelFeatures, change: np.ndarray) -> tuple[ModelFeatures, np.ndarray]:
    """Features ``feats`` with the scatter of a damaged tooth's response ``change`` (n, channels; the
    candidate's full run minus the current model) added to the non-synchronous analytic signal of
    each envelope channel, its factor fitted per channel (module docstring).

    Returns the features and the factors (0 where no scatter improves the channel's envelope)."""
    sigs = band_signature(cmp, change)
    sigma = np.zeros(cmp.nc)
    out = feats
    for c in range(cmp.nc):
        if c >= len(out.analytic) or not np.any(sigs[c]):
            continue
        if sigs[c].size != out.analytic[c].size:
            raise ValueError(f"change: {sigs[c].size} samples, the model's features {out.analytic[c].size}")
        sc, _ = fit_scatter(cmp, out, sigs[c], c)
        if sc > 0:
            sigma[c] = sc
            out = _with_channel(out, c, out.analytic[c] + sc * sigs[c])
    return out, sigma
