"""Model-vs-measurement residuals: run the model at the declared operating point, align, compare.

Feature families (``docs/calibration.md``), computed identically for the measurement and the model:

``order``
    Per channel and per shaft, the complex Fourier coefficients of the time-synchronous average
    (Braun 1975; McFadden 1987) at shaft orders 1..K_low and at the mesh orders +- K_sb sidebands,
    referenced to the absolute shaft angle (shaft angle 0 at ``time_s = 0``). Noise variance per
    coefficient from the scatter between revolutions divided by the number of revolutions.
``envelope``
    Squared-envelope spectrum (Randall & Antoni 2011) of the channel band-passed in the band where
    the measured residual is most impulsive (largest kurtosis among candidate bands), averaged over
    segments; the expected model spectrum is ``g^4 S_model + N0`` with the noise floor ``N0`` from
    the median of the measured spectrum; variance ``(S_expected)^2 / K`` for ``K`` segments.

Every feature gets ``sigma^2 = sigma_noise^2 + (tolerance * |healthy model feature|)^2``: a relative
model-form tolerance (default 5 %) so that small, unmodelled mismatches of large features (e.g. a
damping ratio a fifth off) do not read as new physics. The normalised residual ``r / sigma`` has
unit variance when the model explains the data to within noise and tolerance.

Alignment: per-channel sensor gain ``g`` (nuisance, bounded least squares on the order features),
time shift ``tau`` within half a mesh period (maximum of the order-domain cross-correlation).

Metrics reported per channel: ``time`` (relative RMS of the aligned time residual), ``spectrum``
(relative error of the amplitude spectra), ``order`` and ``envelope`` (relative error and the
normalised RMS residual). The main metric is the family-balanced normalised RMS residual
``E = sqrt(mean_f chi2_f / N_f)``: 1 means "explained to within the noise level".

Modules (split in session 16, docs/history/calibration_sessions.md Sec. 8.40): this one keeps
:class:`Comparison` (the measured features, their noise and the scoring); its envelope family is the mixin of
``residual_envelope.py``; the model runs and their cache are in ``model_runner.py``, the features of one
signal and the plain metrics in ``signal_features.py``, the settings and feature types in
``residual_types.py``. The names are importable from here as before.
"""

from __future__ import annotations

import math

import numpy as np

from gear_rotor_sim.analysis.signals import analytic_band
from gear_rotor_sim.calibration.mains_repair import leave_out_features
from gear_rotor_sim.calibration.measurement import Measurement
from gear_rotor_sim.calibration.model_runner import (
    _CACHE,
    REFERENCE_STEPS_PER_MESH,
    HousingSensor,
    ModelRunner,
    add_direct_bearing_forces,
    cached_system,
    housing_source,
)
from gear_rotor_sim.calibration.residual_envelope import ENVELOPE_BAND_PROMINENCE, EnvelopeFeatures
from gear_rotor_sim.calibration.residual_types import FAMILIES, ModelFeatures, ResidualSettings, Score
from gear_rotor_sim.calibration.signal_features import (
    ShaftOrders,
    align_time,
    envelope_power_spectrum,
    order_coefficients,
    prominent_envelope_band,
    residual_spectrum,
    shaft_orders,
    time_and_spectrum_errors,
)

#: the names other modules, tests and benchmarks import from here (moved in session 16)
__all__ = [
    "ENVELOPE_BAND_PROMINENCE",
    "FAMILIES",
    "REFERENCE_STEPS_PER_MESH",
    "STATIC_QUANTITIES",
    "_CACHE",
    "Comparison",
    "HousingSensor",
    "ModelFeatures",
    "ModelRunner",
    "ResidualSettings",
    "Score",
    "ShaftOrders",
    "add_direct_bearing_forces",
    "align_time",
    "cached_system",
    "envelope_power_spectrum",
    "housing_source",
    "order_coefficients",
    "prominent_envelope_band",
    "residual_spectrum",
    "shaft_orders",
    "time_and_spectrum_errors",
]


#: Quantities whose mean (order 0) is a physical feature; accelerometers are AC-coupled.
STATIC_QUANTITIES = ("dynamic_transmission_error", "mesh_force", "bearing_force", "displacement")


class Comparison(EnvelopeFeatures):
    """Measured features, their noise, and scoring of model signals against them.

    Parameters
    ----------
    measurement : Measurement
    runner : ModelRunner
    settings : ResidualSettings
    envelope_max_hz : float
        Upper frequency of the envelope features.
    """

    def __init__(
        self,
        measurement: Measurement,
        runner: ModelRunner,
        settings: ResidualSettings,
        envelope_max_hz: float,
    ) -> None:
        self.m = measurement
        self.runner = runner
        self.s = settings
        self.v_model_form: list[list[np.ndarray]] | None = None
        #: model-form variance of the channel means (``features_rattle.py`` rule 1 where the teeth separate)
        self.v_static_model_form: np.ndarray | None = None
        #: per-channel model-form tolerance of the order features (replaces ``tolerance`` if larger)
        self.channel_tolerance: np.ndarray | None = None
        #: orders (per channel and shaft) that ``channel_tolerance`` applies to (None: all)
        self.channel_tolerance_where: list[list[np.ndarray]] | None = None
        #: sensor gains held at 1 and transfer slopes at 0 (not separable from model-form error)
        self.gains_held = False
        #: time shift held at 0 (the time origin is the shaft-angle reference of the contract)
        self.shift_held = False
        self.fs = measurement.sample_rate_hz
        self.y = measurement.data
        self.nc = self.y.shape[1]
        self.names = measurement.model_channels
        op = measurement.operating_point
        self.speed_hz = op.speed_rpm / 60.0
        cfg = runner.cfg
        self.shafts = (
            shaft_orders(
                cfg, op.speed_rpm, self.fs, settings.low_orders, settings.sidebands, settings.mesh_harmonics
            )
            if "order" in settings.families
            else []
        )
        self.mesh_hz = (cfg.meshes[0].pinion_teeth * self.speed_hz) if cfg.meshes else 0.0
        self.families = tuple(f for f in settings.families if f != "order" or self.shafts)
        self.env_hi = float(min(envelope_max_hz, 0.2 * self.fs))
        self.bands: list[tuple[float, float]] = []
        # data order features
        self.d_order: list[list[np.ndarray]] = []
        self.v_order: list[list[np.ndarray]] = []
        #: order coefficients by the exact per-revolution integral (order_dft.py); set_exact_orders
        self.exact_orders = True
        #: envelope-band fallback of a line-less channel (``ResidualSettings.envelope_band_fallback``;
        #: the calibrator turns it off where the healthy model's teeth separate)
        self.band_fallback = self.s.envelope_band_fallback
        self._data_orders()
        # transfer-slope abscissa: log10 of the frequency over the mesh frequency, held at the edges of
        # the mesh-carrier band (harmonics 1..M) where the slope is fitted: a slope seen over half a
        # decade of carriers is not extrapolated a decade down to the shaft orders
        x_hi = float(np.log10(max(settings.mesh_harmonics, 1)))
        self._xf = [
            np.clip(np.log10(sh.orders * sh.ratio * self.speed_hz / self.mesh_hz), 0.0, x_hi)
            if self.mesh_hz
            else np.zeros(sh.orders.size)
            for sh in self.shafts
        ]
        #: order features below half the mesh frequency (each shaft's low orders): off the carriers'
        #: transfer path, they take the sensor gain alone (``shaft_order_gain``)
        self._low = [
            (np.abs(sh.orders * sh.ratio) * self.speed_hz < 0.5 * self.mesh_hz)
            if self.mesh_hz and settings.shaft_order_static_gain
            else np.zeros(sh.orders.size, dtype=bool)
            for sh in self.shafts
        ]
        self._static_features(measurement)
        # envelope (bearing) features on the channels measured at a bearing (force under it, housing
        # accelerometer on it) when there are any: the model's path from a bearing defect to a remote
        # sensor (DTE, a shaft's acceleration) runs through the shaft-side impedance at several kHz, the
        # least certain part of any model (docs/calibration.md Sec. 8.2); else every channel
        at_bearing = np.array([n.startswith("bearing") for n in self.names], dtype=bool)
        use_bearings = settings.envelope_at_bearings and bool(at_bearing.any())
        self.env_use = at_bearing if use_bearings else np.ones(self.nc, dtype=bool)
        self.env_non_sync = False
        self.d_env: list[np.ndarray] = []
        self.env_f: np.ndarray = np.zeros(0)
        self.env_k = 1.0

    def _data_orders(self) -> None:
        """The measured order features and their noise variances."""
        self.d_order, self.v_order = [], []
        if "order" not in self.families:
            return
        for c in range(self.nc):
            cs, vs = [], []
            for sh in self.shafts:
                f = sh.ratio * self.speed_hz
                co, var, _ = order_coefficients(
                    self.y[:, c], self.fs, f, sh.orders, f * self.m.t0, self.exact_orders
                )
                med = np.median(var)
                cs.append(co)
                vs.append(np.maximum(var, med))
            self.d_order.append(cs)
            self.v_order.append(vs)
        self._guard_zero_variance(self.m)
        leave_out_features(self)  # mains pickup on a shaft order (mains_repair.py)

    def set_exact_orders(self, exact: bool) -> None:
        """Order features by the exact per-revolution integral (True) or by linear resampling to an
        angle grid (False); the measured features are recomputed (before any model is scored)."""
        if bool(exact) != self.exact_orders:
            self.exact_orders = bool(exact)
            self._data_orders()

    def _units(self, measurement: Measurement) -> list[str]:
        chans = getattr(measurement, "channels", None)
        if chans and len(chans) == self.nc:
            return [c.si_unit for c in chans]
        return ["?"] * self.nc

    def _guard_zero_variance(self, measurement: Measurement) -> None:
        """A channel without dynamic content (e.g. the axial bearing forces of a spur gearbox at the
        reference temperature: exactly zero) has zero noise variance: 0/0 in the normalisation. Its
        variance is floored by the smallest noise level of the channels with the same unit; without
        such a channel it is left out of the order family. Both are reported in ``issues``."""
        units = self._units(measurement)
        med = [float(np.median(np.concatenate(v))) if v else 0.0 for v in self.v_order]
        for c in range(self.nc):
            if med[c] > 0 and np.isfinite(med[c]):
                continue
            peers = [med[k] for k in range(self.nc) if k != c and units[k] == units[c] and med[k] > 0]
            if peers:
                floor = float(min(peers))
                self.v_order[c] = [np.maximum(v, floor) for v in self.v_order[c]]
                how = f"floored by the noise level of the other {units[c]} channels"
            else:
                self.v_order[c] = [np.full(v.shape, np.inf) for v in self.v_order[c]]
                how = "left out of the order features (no channel of the same unit to take a floor from)"
            issue = (
                f"{self.names[c]}: no dynamic content (zero variance between revolutions); its "
                f"uncertainty is {how}"
            )
            if issue not in measurement.issues:  # the features may be recomputed (set_exact_orders)
                measurement.issues.append(issue)

    def _static_features(self, measurement: Measurement) -> None:
        """Channel means (order 0) and their noise variance (scatter of per-revolution means)."""
        chans = getattr(measurement, "channels", None)
        qty = [c.quantity for c in chans] if chans and len(chans) == self.nc else [""] * self.nc
        self.static_mask = np.array(
            [q in STATIC_QUANTITIES and not housing_source(n) for q, n in zip(qty, self.names, strict=True)],
            dtype=bool,
        )
        if "static" not in self.s.families or not self.static_mask.any():
            self.families = tuple(f for f in self.families if f != "static")
            self.d_static = np.zeros(self.nc)
            self.v_static = np.full(self.nc, np.inf)
            self.static_fluct = np.zeros(self.nc)
            return
        if "static" not in self.families:
            self.families = (*self.families, "static")
        # order 0 over whole hunting periods (the model's window, model_window.py): a partial cycle
        # at the record's end biases the mean by its share of the once-per-cycle content
        from gear_rotor_sim.calibration.model_window import whole_periods_samples

        n_whole = whole_periods_samples(self.runner.cfg, self.speed_hz * 60.0, self.fs, self.y.shape[0])
        self.d_static = self.y[:n_whole].mean(axis=0)
        # where the teeth separate the mean of a channel is set by the dynamics (the share of the time
        # in free flight and on either flank), not by a static deflection: its model-form uncertainty
        # scales with the fluctuation, tolerance x the channel's standard deviation (negligible in
        # continuous contact, where the fluctuation is a small part of the mean)
        self.static_fluct = self.y[:n_whole].std(axis=0)
        n_per = max(round(self.fs / self.speed_hz), 1) if self.speed_hz else int(0.1 * self.fs)
        n_blk = max(self.y.shape[0] // n_per, 1)
        if n_blk >= 2:
            blocks = self.y[: n_blk * n_per].reshape(n_blk, n_per, self.nc).mean(axis=1)
            var = blocks.var(axis=0, ddof=1) / n_blk
        else:
            var = self.y.var(axis=0) / self.y.shape[0]
        units = self._units(measurement)
        v = np.where(self.static_mask, var, np.inf)
        for c in np.flatnonzero(self.static_mask):
            same = [k for k in np.flatnonzero(self.static_mask) if units[k] == units[c]]
            peers = [v[k] for k in same if 0 < v[k] < np.inf]
            floor = float(np.median(peers)) if peers else 0.0
            if v[c] <= 0 and floor <= 0:
                v[c] = np.inf
                measurement.issues.append(
                    f"{self.names[c]}: constant signal and no channel of the same unit: its mean is not "
                    "used as a feature"
                )
            else:
                v[c] = max(v[c], floor)
        self.v_static = v
        self.static_mask &= np.isfinite(v)
        if not self.static_mask.any():
            self.families = tuple(f for f in self.families if f != "static")

    # -------------------------------------------------------------------------------- features
    def _quick_gains(self, model: np.ndarray) -> np.ndarray:
        num = np.sum(self.y[: model.shape[0]] * model, axis=0)
        den = np.sum(model * model, axis=0)
        g = np.where(den > 0, num / np.where(den > 0, den, 1.0), 1.0)
        return np.clip(g, *self.s.gain_bounds) if self.s.fit_gain else np.ones(self.nc)

    def _order(self, model: np.ndarray) -> list[list[np.ndarray]]:
        t_start = self.runner.start_time
        out = []
        for c in range(self.nc):
            cs = []
            for sh in self.shafts:
                f = sh.ratio * self.speed_hz
                co, _, _ = order_coefficients(
                    model[:, c], self.fs, f, sh.orders, f * t_start, self.exact_orders
                )
                cs.append(co)
            out.append(cs)
        return out

    def best_shift(self, feats: ModelFeatures) -> float:
        """Time shift within +-``max_shift_mesh_periods`` mesh periods maximising the weighted
        order-domain cross-correlation of model and data (0 without orders or mesh)."""
        if (
            not self.mesh_hz
            or self.s.max_shift_mesh_periods <= 0
            or "order" not in self.families
            or self.shift_held
        ):
            return 0.0
        if not hasattr(self, "_shift_grid"):
            span = self.s.max_shift_mesh_periods / self.mesh_hz
            self._shift_grid = np.linspace(-span, span, 97)
            self._shift_ph = [
                np.exp(-2j * np.pi * np.outer(self._shift_grid, sh.orders) * sh.ratio * self.speed_hz)
                for sh in self.shafts
            ]
        taus = self._shift_grid
        best = np.zeros_like(taus)
        for s in range(len(self.shafts)):
            cross = sum(
                np.conj(self.d_order[c][s]) * feats.order[c][s] / self.order_sigma2(c, s)
                for c in range(self.nc)
            )
            # elementwise product and sum: small matrix products through a threaded BLAS are slow
            # on a loaded machine
            best += np.real(np.sum(self._shift_ph[s] * cross[None, :], axis=1))
        i = int(np.argmax(best))
        if 0 < i < taus.size - 1:
            a, b, c_ = best[i - 1], best[i], best[i + 1]
            den = a - 2 * b + c_
            off = 0.5 * (a - c_) / den if den < 0 else 0.0
            return float(taus[i] + off * (taus[1] - taus[0]))
        return float(taus[i])

    def apply_shift(self, feats: ModelFeatures, tau: float) -> ModelFeatures:
        """Order features of the model delayed by ``tau`` (analytic signals unchanged)."""
        if not tau:
            return feats
        order = [
            [
                co * np.exp(-2j * np.pi * sh.orders * sh.ratio * self.speed_hz * tau)
                for co, sh in zip(cs, self.shafts, strict=True)
            ]
            for cs in feats.order
        ]
        return ModelFeatures(order, feats.analytic, feats.static)

    def features(self, model: np.ndarray) -> ModelFeatures:
        """Linear features (order coefficients, analytic band signals) of model outputs (n, c)."""
        order = self._order(model) if "order" in self.families else []
        analytic = (
            [
                analytic_band(self._envelope_input(model[:, c]), self.fs, self.bands[c])
                if self.env_use[c]
                else np.zeros(model.shape[0], dtype=complex)
                for c in range(self.nc)
            ]
            if ("envelope" in self.families)
            else []
        )
        return ModelFeatures(order, analytic, np.asarray(model.mean(axis=0), dtype=float))

    def shifted(self, feats: ModelFeatures, dt: float, analytic: bool = True) -> ModelFeatures:
        """Features of the signal delayed by ``dt`` (order phases; analytic signal by FFT shift).

        ``analytic=False`` keeps the analytic signals: a damaged tooth's envelope change (of the
        non-synchronous part) does not depend on which tooth it is, while a circular shift of a
        non-periodic response difference would misplace it against the unshifted model.
        """
        # the same phasors for every channel
        turn = [np.exp(-2j * np.pi * sh.orders * sh.ratio * self.speed_hz * dt) for sh in self.shafts]
        order = [[co * e for co, e in zip(cs, turn, strict=True)] for cs in feats.order]
        if not analytic:
            return ModelFeatures(order, feats.analytic, feats.static)
        out = []
        for a in feats.analytic:
            f = np.fft.fftfreq(a.size, 1.0 / self.fs)
            out.append(np.fft.ifft(np.fft.fft(a) * np.exp(-2j * np.pi * f * dt)))
        return ModelFeatures(order, out, feats.static)

    # ---------------------------------------------------------------------------------- scoring
    def carriers(self, s: int) -> np.ndarray:
        """Mask of the mesh-carrier orders of shaft ``s``: multiples of the tooth count of any gear
        on the shaft (one per stage on the intermediate shaft of a multi-stage train). Kept per shaft
        object (read-only: the scores ask for it about a hundred thousand times per record)."""
        sh = self.shafts[s]
        memo = self.__dict__.setdefault("_carrier_masks", {})
        hit = memo.get(s)
        if hit is not None and hit[0] is sh:
            return hit[1]
        teeth = sh.carrier_teeth or ((sh.teeth,) if sh.teeth else ())
        mask = np.zeros(sh.orders.size, dtype=bool)
        for z in teeth:
            mask |= sh.orders % z == 0
        mask.flags.writeable = False
        memo[s] = (sh, mask)
        return mask

    def set_carrier_tolerance(self, tol: float) -> None:
        """Model-form tolerance of the mesh carriers (estimated from the baseline fit)."""
        self.carrier_tolerance = float(max(tol, self.s.tolerance))

    def order_sigma2(self, c: int, s: int, model: np.ndarray | None = None) -> np.ndarray:
        """Noise variance plus the model-form tolerance on features present in both data and model.

        The mesh carriers get ``carrier_tolerance`` (model-form floor estimated after the baseline
        fit), every other order the settings' ``tolerance``.
        """
        v = self.v_order[c][s]
        if self.v_model_form is not None:
            v = v + self.v_model_form[c][s]
        if model is None:
            return v
        common = np.minimum(np.abs(model), np.abs(self.d_order[c][s]))
        tol: float | np.ndarray = self.s.tolerance
        ct = getattr(self, "carrier_tolerance", tol)
        if self.channel_tolerance is not None:  # measured per channel where the teeth separate
            ch = max(float(tol), float(self.channel_tolerance[c]))
            ct = max(ct, ch)
            # on the orders where the healthy model's rattle stands out of the noise (features_rattle.py)
            where = None if self.channel_tolerance_where is None else self.channel_tolerance_where[c][s]
            tol = ch if where is None else np.where(where, ch, float(tol))
        if np.any(ct != tol):
            tol = np.where(self.carriers(s), ct, tol)
        return v + (tol * common) ** 2

    def set_model_form_variance(self, var: list[list[np.ndarray]] | None) -> None:
        """Model-form variance added to every order coefficient's uncertainty (``features_rattle.py``:
        the spread of the healthy model over its uncertain baseline where the teeth separate)."""
        self.v_model_form = None if var is None else [[np.asarray(v, float) for v in vs] for vs in var]

    def leave_out_orders(self, s: int, mask: np.ndarray) -> None:
        """Leave the orders ``mask`` of shaft ``s`` out of the order features on every channel (infinite
        variance: no weight, not counted)."""
        for c in range(self.nc):
            v = self.v_order[c][s].copy()
            v[np.asarray(mask, dtype=bool)] = np.inf
            self.v_order[c][s] = v

    def comb_chi2(self, feats: ModelFeatures, score: Score) -> np.ndarray:
        """chi^2 of the non-carrier orders (order comb and sidebands) per shaft, all channels, with the
        score's gains and time shift."""
        out = np.zeros(len(self.shafts))
        G = np.column_stack([score.gains, score.slopes]) if score.slopes.size else score.gains
        feats = self.apply_shift(feats, score.tau)
        for c in range(self.nc):
            for s in range(len(self.shafts)):
                k = ~self.carriers(s)
                mg = self.order_gain(G, c, s) * feats.order[c][s]
                r = self.d_order[c][s] - mg
                out[s] += 2.0 * float(np.sum((np.abs(r) ** 2 / self.order_sigma2(c, s, mg))[k]))
        return out

    def comb_count(self) -> int:
        """Number of real comb features (non-carrier orders, 2 per complex coefficient)."""
        n = sum(int(np.count_nonzero(~self.carriers(s))) for s in range(len(self.shafts)))
        return 2 * n * self.nc

    def carrier_mismatch(self, feats: ModelFeatures, score: Score) -> float:
        """Median relative misfit ``|d - g m| / |g m|`` of the significant mesh carriers (``nan`` if none)."""
        rel: list[np.ndarray] = []
        G = np.column_stack([score.gains, score.slopes]) if score.slopes.size else score.gains
        feats = self.apply_shift(feats, score.tau)
        for c in range(self.nc):
            for s in range(len(self.shafts)):
                mask = self.carriers(s)
                if not mask.any():
                    continue
                gm = (
                    (self.order_gain(G, c, s) * feats.order[c][s])[mask]
                    if G.ndim == 2
                    else (G[c] * feats.order[c][s][mask])
                )
                d = self.d_order[c][s][mask]
                sig = np.abs(gm) ** 2 > 9.0 * self.v_order[c][s][mask]
                if sig.any():
                    rel.append(np.abs(d - gm)[sig] / np.abs(gm)[sig])
        return float(np.median(np.concatenate(rel))) if rel else float("nan")

    def fix_transfer(self, slopes: np.ndarray | None) -> None:
        """Hold the transfer slopes (fitted on the healthy/baseline model) while candidates are scored:
        a slope refitted per candidate would trade with the amplitude of a low- or high-order effect."""
        self.fixed_slopes = None if slopes is None else np.asarray(slopes, dtype=float).copy()

    def shaft_order_gain(self, c: int) -> float:
        """Gain of channel ``c`` at the order features far below the mesh band (``_low``).

        The gain ``g0`` fitted on the order features is set by the mesh carriers, and on a model that
        is a few percent off there the carriers' misfit is not a sensor's: on every 3000 rpm record of
        the independent benchmark all gains sat at their 0.8 bound (the sensors' true gains 0.97-1.03),
        and an order-1 effect fitted through them read ``1 / 0.8`` too large (gear eccentricity +24 %,
        unbalance +22 %; docs/history/calibration_sessions.md Sec. 8.22). A shaft order tens of Hz to a few
        hundred Hz is off the carriers' transfer path; what it shares with them is the sensor. So it takes
        the sensor gain where the channel's mean identifies one (a radial bearing force: ``measured mean /
        model mean`` of an equilibrium load, ``features_bearing.static_sensor_gains``), else the nominal 1 (a
        calibrated sensor; an encoder angle difference has no gain). Held gains (the rattle rules) are 1.
        """
        if self.gains_held or not self.s.fit_gain:
            return 1.0
        gs = getattr(self, "envelope_gains", None)
        if gs is not None and np.isfinite(gs[c]):
            return float(gs[c])
        return 1.0

    def order_gain(self, g: np.ndarray, c: int, s: int) -> np.ndarray | float:
        """Per-feature gain of channel ``c`` on shaft ``s``: ``g0 (1 + b x)``, ``x = log10(f / f_mesh)``
        held within the mesh-carrier band ``[0, log10 M]`` where ``b`` is fitted (the smooth transfer
        correction; ``g`` is (nc,) or (nc, 2)); the shaft's low orders (below half the mesh frequency)
        take ``shaft_order_gain`` (``ResidualSettings.shaft_order_static_gain``)."""
        out = g[c] if g.ndim == 1 else g[c, 0] * (1.0 + g[c, 1] * self._xf[s])
        low = self._low[s]
        if low.any():
            out = np.where(low, self.shaft_order_gain(c), out)
        return out

    def fit_gains(self, feats: ModelFeatures) -> np.ndarray:
        """Per-channel gain and transfer slope by weighted least squares on the order features.

        Returns (nc, 2): gain at the mesh frequency (bounded by ``gain_bounds``) and the relative
        slope ``b`` per decade of frequency (bounded by ``transfer_slope_bounds``; 0 unless
        ``fit_transfer``). Both are sensor/transfer-path nuisances, never effects.
        """
        g = np.zeros((self.nc, 2))
        g[:, 0] = 1.0
        if not self.s.fit_gain or self.gains_held or "order" not in self.families:
            return g
        for c in range(self.nc):
            A = np.zeros((2, 2))
            rhs = np.zeros(2)
            Ac = np.zeros((2, 2))  # mesh carriers only: the slope is fitted where the transfer path
            rc = np.zeros(2)  # dominates and no library fault lives (eccentricity is order 1, ...)
            for s in range(len(self.shafts)):
                m = feats.order[c][s]
                # the low orders take the sensor gain (``shaft_order_gain``): not fitted here
                w = np.where(self._low[s], 0.0, 1.0 / self.order_sigma2(c, s, m))
                x = self._xf[s]
                mm = w * np.abs(m) ** 2
                dm = w * np.real(np.conj(m) * self.d_order[c][s])
                mx = mm * x  # each sum once (the same floats as forming it twice)
                A += [[mm.sum(), mx.sum()], [mx.sum(), (mx * x).sum()]]
                rhs += [dm.sum(), (dm * x).sum()]
                k = self.carriers(s)
                mk, dk, xk = mm[k], dm[k], x[k]
                mxk = mk * xk
                Ac += [[mk.sum(), mxk.sum()], [mxk.sum(), (mxk * xk).sum()]]
                rc += [dk.sum(), (dk * xk).sum()]
            # a gain is only fitted where the model's order content stands out of the noise (summed
            # SNR^2 >= 100): a channel of pure noise (e.g. an axial force in a spur gearbox) keeps 1
            if not (A[0, 0] >= 100.0 and np.all(np.isfinite(A)) and np.all(np.isfinite(rhs))):
                continue
            g0 = rhs[0] / A[0, 0]
            b = 0.0
            fixed = getattr(self, "fixed_slopes", None)
            if fixed is not None:
                b = float(fixed[c])
                col = np.array([1.0, b])
                g0 = float(col @ rhs) / float(col @ A @ col)
            elif self.s.fit_transfer and Ac[0, 0] > 0 and np.linalg.det(Ac) > 1e-6 * Ac[0, 0] * Ac[1, 1]:
                a_, b_ = np.linalg.solve(Ac, rc)
                if a_ > 0:
                    lo, hi = self.s.transfer_slope_bounds
                    b = float(np.clip(b_ / a_, lo, hi))
                    # gain given the (clipped) slope
                    col = np.array([1.0, b])
                    g0 = float(col @ rhs) / float(col @ A @ col)
            g[c, 0] = np.clip(g0, *self.s.gain_bounds)
            g[c, 1] = b
        return g

    def score(self, feats: ModelFeatures, gains: np.ndarray | None = None, tau: float | None = None) -> Score:
        """chi^2 per family with the time shift and per-channel gains fitted (unless given)."""
        tau = self.best_shift(feats) if tau is None else tau
        feats = self.apply_shift(feats, tau)
        G = self.fit_gains(feats) if gains is None else np.asarray(gains, dtype=float)
        g = G[:, 0] if G.ndim == 2 else G
        chi2: dict[str, float] = {}
        n: dict[str, int] = {}
        per: dict[str, dict[str, float]] = {}
        rel: dict[str, dict[str, float]] = {}
        if "order" in self.families:
            chi2["order"], n["order"], per["order"], rel["order"] = 0.0, 0, {}, {}
            for c in range(self.nc):
                cc = nn = 0.0
                rr = dd = 0.0
                for s in range(len(self.shafts)):
                    mg = self.order_gain(G, c, s) * feats.order[c][s]
                    r = self.d_order[c][s] - mg
                    s2 = self.order_sigma2(c, s, mg)
                    cc += float(np.sum(np.abs(r) ** 2 / s2))
                    nn += 2 * int(np.count_nonzero(np.isfinite(s2)))  # left-out features do not count
                    rr += float(np.sum(np.abs(r) ** 2))
                    dd += float(np.sum(np.abs(self.d_order[c][s]) ** 2))
                chi2["order"] += 2 * cc  # complex: 2 real dof, each of variance s2/2
                n["order"] += int(nn)
                per["order"][self.names[c]] = math.sqrt(2 * cc / nn) if nn else float("nan")
                rel["order"][self.names[c]] = math.sqrt(rr / dd) if dd > 0 else float("nan")
        env_r2: list[np.ndarray] = []
        if "envelope" in self.families:
            chi2["envelope"], n["envelope"], per["envelope"], rel["envelope"] = 0.0, 0, {}, {}
            for c in range(self.nc):
                if not self.env_floor[c] > 0:
                    env_r2.append(np.zeros(self.d_env[c].size))
                    continue
                expect = self.envelope_expected(c, self.envelope_model(feats, c), self.envelope_gain(c, g))
                r = self.d_env[c] - expect
                # variance of an averaged periodogram bin, taken at the smaller of the expected and the
                # measured level (never below the noise floor) so that neither over- nor under-predicting
                # a line inflates its own uncertainty
                base = np.maximum(np.minimum(expect, self.d_env[c]), self.envelope_noise_floor(c))
                s2 = base**2 / self.env_k + (self.s.tolerance * base) ** 2
                r2 = r * r / s2
                env_r2.append(r2)
                cc = float(np.sum(r2))
                chi2["envelope"] += cc
                n["envelope"] += r.size
                per["envelope"][self.names[c]] = math.sqrt(cc / max(r.size, 1))
                floor = np.median(self.d_env[c])
                dd = float(np.sum((self.d_env[c] - floor) ** 2))
                rel["envelope"][self.names[c]] = (
                    math.sqrt(float(np.sum(r * r)) / dd) if dd > 0 else float("nan")
                )
        static_r = np.zeros(0)
        if "static" in self.families and feats.static.size == self.nc:
            idx = np.flatnonzero(self.static_mask)
            mg = g[idx] * feats.static[idx]
            d = self.d_static[idx]
            s2 = (
                self.v_static[idx]
                + (self.s.static_tolerance * np.minimum(np.abs(mg), np.abs(d))) ** 2
                + (self.s.tolerance * self.static_fluct[idx]) ** 2
            )
            if self.v_static_model_form is not None:
                s2 = s2 + self.v_static_model_form[idx]
            static_r = (d - mg) / np.sqrt(s2)
            chi2["static"] = float(np.sum(static_r**2))
            n["static"] = int(idx.size)
            per["static"] = {self.names[c]: float(abs(v)) for c, v in zip(idx, static_r, strict=True)}
            rel["static"] = {
                self.names[c]: float(abs(dd - mm) / abs(dd)) if dd else float("nan")
                for c, dd, mm in zip(idx, d, mg, strict=True)
            }
        slopes = G[:, 1] if G.ndim == 2 else np.zeros(self.nc)
        return Score(chi2, n, g, per, rel, tau, env_r2, slopes, static_r)
