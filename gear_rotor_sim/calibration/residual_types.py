"""The comparison's feature families and settings (``ResidualSettings``), the linear model features
(``ModelFeatures``) and a model's goodness of fit (``Score``)
(moved from ``residual.py`` in session 16, unchanged).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

FAMILIES = ("order", "envelope", "static")


@dataclass
class ModelFeatures:
    """Linear representation of a model signal set.

    ``order[c][s]``: complex order coefficients (channel c, shaft s); ``analytic[c]``: analytic
    signal of the band-passed channel. Both are linear in the signal, so responses can be
    superposed (``a + w * b``) without recomputation; the envelope spectrum (quadratic) is
    computed from the analytic signal when scoring.
    """

    order: list[list[np.ndarray]]
    analytic: list[np.ndarray]
    static: np.ndarray = field(default_factory=lambda: np.zeros(0))  # channel means (order 0)

    def combo(self, other: ModelFeatures, w: float) -> ModelFeatures:
        """``self + w * other``."""
        return ModelFeatures(
            [
                [x + w * y for x, y in zip(xs, ys, strict=True)]
                for xs, ys in zip(self.order, other.order, strict=True)
            ],
            [x + w * y for x, y in zip(self.analytic, other.analytic, strict=True)],
            self.static + w * other.static,
        )

    def scaled(self, w: float) -> ModelFeatures:
        return ModelFeatures(
            [[w * x for x in xs] for xs in self.order], [w * x for x in self.analytic], w * self.static
        )


@dataclass
class Score:
    """Goodness of fit of a model to the measurement."""

    chi2: dict[str, float]
    n: dict[str, int]
    gains: np.ndarray  # per-channel sensor gain at the mesh frequency
    per_channel: dict[str, dict[str, float]]  # family -> channel -> normalised RMS residual
    relative: dict[str, dict[str, float]]  # family -> channel -> relative error
    tau: float = 0.0  # fitted time shift, s
    envelope_r2: list[np.ndarray] = field(default_factory=list)  # per channel (r/sigma)^2 per envelope bin
    slopes: np.ndarray = field(default_factory=lambda: np.zeros(0))  # transfer slope per channel
    static_r: np.ndarray = field(default_factory=lambda: np.zeros(0))  # normalised static residuals

    @property
    def error(self) -> float:
        """Main metric: family-balanced normalised RMS residual (1 = at the noise level)."""
        fams = [f for f in self.chi2 if self.n[f] > 0]
        return float(np.sqrt(np.mean([self.chi2[f] / self.n[f] for f in fams]))) if fams else float("nan")

    @property
    def balanced_chi2(self) -> float:
        """chi^2 with the spectral families weighted to equal total counts (for BIC comparisons).

        The ``static`` family (a handful of channel means) enters with weight 1 per feature: it
        decides only when its residual is large against its own uncertainty (e.g. an axial bearing
        load that reveals a temperature), never by the count weighting.
        """
        fams = [f for f in self.chi2 if self.n[f] > 0 and f != "static"]
        ntot = sum(self.n[f] for f in fams)
        out = float(sum(self.chi2[f] * ntot / (len(fams) * self.n[f]) for f in fams)) if fams else 0.0
        return out + float(self.chi2.get("static", 0.0))

    @property
    def n_total(self) -> int:
        return int(sum(self.n.values()))


@dataclass
class ResidualSettings:
    """Choices of the comparison (documented in docs/calibration.md)."""

    families: tuple[str, ...] = FAMILIES
    tolerance: float = 0.05
    static_tolerance: float = 0.1
    transfer_slope_bounds: tuple[float, float] = (-0.3, 0.3)
    fit_transfer: bool = True
    gain_bounds: tuple[float, float] = (0.8, 1.25)
    fit_gain: bool = True
    low_orders: int = 6
    sidebands: int = 6
    mesh_harmonics: int = 3
    envelope_band_hz: tuple[float, float] | None = None
    envelope_max_hz: float | None = None
    envelope_min_hz: float = 5.0
    envelope_segment_s: float = 0.1
    max_shift_mesh_periods: float = 0.5
    #: envelope of the non-synchronous part only (every shaft's synchronous average removed; needs
    #: the order family, i.e. a speed known to within the order resolution)
    envelope_non_synchronous: bool = True
    #: envelope features only on the channels at a bearing (bearing force, housing acceleration), if any
    envelope_at_bearings: bool = True
    #: largest non-synchronous share of the healthy model's RMS at a bearing channel for the
    #: non-synchronous envelope (above it the gear dynamics is not periodic: whole-signal envelope)
    envelope_periodic_limit: float = 0.01
    #: fewest revolutions of the slowest shaft for the non-synchronous envelope: the synchronous
    #: averages separate periodic from random content only over enough revolutions (their
    #: significance test keeps an order at 3 standard errors of the between-revolution scatter)
    envelope_min_revolutions: float = 10.0
    #: envelope band of a channel without a line 6 dB above its floor: that of the most prominent
    #: channel at the same bearing (``Comparison.set_baseline``; on against a held reference)
    envelope_band_fallback: bool = False
    #: envelope family: the gain of a radial bearing-force channel from its mean (equilibrium load),
    #: not from the mesh carriers (``features_bearing.static_sensor_gains``)
    envelope_static_gain: bool = True
    #: order features far below the mesh band (each shaft's orders 1-6, under half the mesh
    #: frequency) take the channel's sensor gain from its mean (radial bearing forces) or the nominal 1,
    #: never the gain the mesh carriers set (their model-form misfit; docs/history/calibration_sessions.md
    #: Sec. 8.22)
    shaft_order_static_gain: bool = True
    #: the envelope's noise model (``features_envelope_noise``, docs/history/calibration_sessions.md
    #: Secs. 8.15, 8.23): a floor shaped like white noise through the band-pass, and the 3-bin sum counted as
    #: 3 / 1.61 independent bins, so that pure noise scores 1. ``False``: the old flat floor and plain count
    #: (pure noise scores 4.9), kept only to reproduce results before session 11
    envelope_noise_corrected: bool = True
    #: with the reference numerics (a held reference and its fit, where the healthy model stays in
    #: contact): the model runs take the exact modal map instead of the dt rule's choice. Newmark's
    #: period error at the mesh-coupled modes moves the reference's mesh stiffness scale with the step
    #: (x1.309 / 1.199 / 1.121 / 1.107 at 32 / 64 / 128 / 256 steps per mesh on the independent 2000 rpm
    #: record; x1.111 / damping x1.7 with the exact map at 64). With it on, the contact tooth depth against
    #: the reference is read from the DTE comb (``candidates_tooth_dte.dte_depth_applies``). Off by default:
    #: measured on the independent benchmark (docs/history/calibration_sessions.md Sec. 8.27) three rattle
    #: rows that pass against the unconverged reference fail against the converged one (23 of 27 with
    #: ``--baseline``), and the converged reference's mesh damping sits at its grid edge (not identified)
    reference_exact_map: bool = False
    #: order features left out, ``(model channel, shaft name, order)`` each (infinite variance): mains pickup
    #: on a shaft order (``mains_repair.py``, docs/calibration.md Sec. 1); set by the calibration itself
    left_out_orders: tuple[tuple[str, str, int], ...] = ()
