"""The envelope family of :class:`~gear_rotor_sim.calibration.residual.Comparison`: the analysed
signal (non-synchronous part or whole), the band of each channel, the measured spectra and
their noise floor, the family's sensor gains and the model's spectrum. A mixin of
``Comparison`` (moved from ``residual.py`` in session 16, unchanged).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gear_rotor_sim.analysis.signals import analytic_band
from gear_rotor_sim.calibration.envelope_hunting import MIN_SHARE, hunting_part, hunting_share
from gear_rotor_sim.calibration.envelope_periodic import non_synchronous_share
from gear_rotor_sim.calibration.features_bearing import static_sensor_gains
from gear_rotor_sim.calibration.features_envelope_noise import bin_sum_variance_factor, envelope_noise_shape
from gear_rotor_sim.calibration.features_orders import remove_synchronous
from gear_rotor_sim.calibration.model_window import hunting_period_s
from gear_rotor_sim.calibration.residual_types import ModelFeatures
from gear_rotor_sim.calibration.signal_features import envelope_power_spectrum, prominent_envelope_band
from gear_rotor_sim.calibration.speed_modulation import remove_speed_modulated

#: envelope-band choice: a residual envelope line this many times its floor (6 dB, the detection
#: threshold of a bearing line, ``FitSettings.line_prominence``) makes a channel's own band; below
#: it a channel takes the band of the most prominent channel at the same bearing
ENVELOPE_BAND_PROMINENCE = 4.0


class EnvelopeFeatures:
    """Envelope features of the comparison (mixin of ``Comparison``)."""

    def set_baseline(self, model: np.ndarray) -> None:
        """Fix the time shift and the envelope bands from the healthy model."""
        if "envelope" in self.families:
            self._choose_envelope_input(model)
            y = self.y[: model.shape[0]]  # the model may cover whole hunting periods only
            resid = y - model * self._quick_gains(model)
            self.bands = []
            scores: dict[int, float] = {}
            self._y_env = [
                self._envelope_input(self.y[:, c]) if self.env_use[c] else self.y[:, c]
                for c in range(self.nc)
            ]
            # the measured content periodic in the hunting period (tooth pairs: pitch errors) out of the
            # measured envelope input (envelope_hunting.py); the model holds none where this input is used
            hunt = self._hunting_parts()
            self._y_env = [v - h for v, h in zip(self._y_env, hunt, strict=True)]
            for c in range(self.nc):
                if not self.env_use[c]:
                    band = self.bands[-1] if self.bands else (0.25 * self.fs, 0.45 * self.fs)
                elif self.s.envelope_band_hz is not None:
                    band = self.s.envelope_band_hz
                else:
                    band, score = prominent_envelope_band(
                        self._envelope_input(resid[:, c]) - hunt[c][: resid.shape[0]],
                        self.fs,
                        self.s.envelope_min_hz,
                        self.env_hi,
                        self.s.envelope_segment_s,
                        min_hz=max(500.0, 2.0 * self.env_hi),
                        with_score=True,
                    )
                    scores[c] = score
                self.bands.append(band)
            # a channel whose residual envelope has no line 6 dB above its floor in any band (the
            # detection threshold of a bearing line) takes the band of the channel where the line is
            # most prominent: its own choice would be made on noise (Sec. 8.18: bearing2_fx of the
            # 3000 rpm outer-race record, prominence 1.4-1.9 in every band against 115-147 on
            # bearing2_fy, drew 1.2-2.4 kHz at 64 steps per mesh period and 2.4-4.8 kHz at 32, and the
            # fitted force moved from 278 N to 194 N for 300)
            for c, sc in scores.items() if self.band_fallback else ():
                site = self.names[c].split("_")[0]  # bearing<k>: the channels at the same bearing
                peers = {k: v for k, v in scores.items() if self.names[k].split("_")[0] == site}
                best = max(peers, key=lambda k: peers[k])
                if sc < ENVELOPE_BAND_PROMINENCE <= peers[best]:
                    self.bands[c] = self.bands[best]
            self.d_env = []
            self.env_shape = []
            for c in range(self.nc):
                a = analytic_band(self._y_env[c], self.fs, self.bands[c])
                args = (self.fs, self.s.envelope_min_hz, self.env_hi, self.s.envelope_segment_s)
                f, p, k = envelope_power_spectrum(a, *args)
                self.d_env.append(p if self.env_use[c] else np.zeros_like(p))
                corrected = self.s.envelope_noise_corrected
                self.env_f, self.env_k = f, (k / bin_sum_variance_factor(3) if corrected else k)
                shaped = self.env_use[c] and corrected
                shape = envelope_noise_shape(self.bands[c], self.fs, a.size, *args[1:]) if shaped else None
                self.env_shape.append(np.ones(p.shape) if shape is None else shape)
            self.env_floor = [float(np.median(p)) for p in self.d_env]
            #: level of the (shaped) noise floor of the measured spectrum: median of d / shape
            self.env_floor_level = [
                float(np.median(p / sh)) for p, sh in zip(self.d_env, self.env_shape, strict=True)
            ]
            self._set_envelope_gains(model)
            for c, fl in enumerate(self.env_floor):
                if not fl > 0 and self.env_use[c]:
                    self.m.issues.append(
                        f"{self.names[c]}: no envelope content (zero spectrum): left out of the envelope "
                        "features"
                    )

    def _set_envelope_gains(self, model: np.ndarray) -> None:
        """Sensor gains of the radial bearing-force channels from their means (``features_bearing``),
        used for the envelope family in place of the order gain, which the mesh carriers' model-form
        misfit sets; NaN (order gain kept) elsewhere."""
        self.envelope_gains = np.full(self.nc, np.nan)
        if not (self.s.fit_gain and self.s.envelope_static_gain) or "static" not in self.families:
            return
        chans = getattr(self.m, "channels", None)
        if not chans or len(chans) != self.nc:
            return
        self.envelope_gains = static_sensor_gains(
            self.d_static,
            np.where(self.static_mask, self.v_static, np.inf),
            model.mean(axis=0),
            [c.quantity for c in chans],
            [c.direction for c in chans],
            self.s.gain_bounds,
        )

    def envelope_gain(self, c: int, g: np.ndarray) -> float:
        """Gain of channel ``c`` in the envelope family: its static sensor gain where the channel
        identifies one, else the order gain ``g[c]`` (1 without the order family)."""
        gs = getattr(self, "envelope_gains", None)
        if gs is not None and np.isfinite(gs[c]):
            return float(gs[c])
        return float(g[c]) if "order" in self.families else 1.0

    def _choose_envelope_input(self, model: np.ndarray) -> None:
        """Envelope of the non-synchronous part at the bearings' channels, or of the whole signal at
        every channel.

        The non-synchronous part is a clean bearing channel only where the gear dynamics is periodic:
        the healthy model's own non-synchronous content at the bearings' channels must stay below
        ``envelope_periodic_limit`` of its RMS. Where the model predicts non-periodic gear dynamics
        (teeth separating, quasi-periodic response), that content changes with every gear or thermal
        parameter in a way superposed basis runs cannot follow, and the whole-signal envelope on
        every channel is used instead (as without a precise speed).

        The share is taken of the larger of the model's and the measured channel's fluctuation: a
        channel whose model fluctuation is round-off (the axial bearing force of a spur gearbox above
        the reference temperature: a static thermal load of 1846 N with a fluctuation of 5e-13 N at
        125 C) has no dynamics to be periodic or not, and its round-off is invisible under the
        measured noise; judged on its own RMS it read as 100 % non-synchronous and switched every
        healthy record above 25 C to the whole-signal envelope. The non-synchronous part is taken below
        the synchronous average's top frequency (0.45 fs): a mesh harmonic above it is periodic but
        stays in that part (``envelope_periodic.py``, docs/history/calibration_sessions.md Sec. 8.76).
        """
        self.env_non_sync = bool(self.s.envelope_non_synchronous and "order" in self.families and self.shafts)
        if self.env_non_sync:
            revs = self.y.shape[0] / self.fs * min(abs(sh.ratio) for sh in self.shafts) * self.speed_hz
            if revs < self.s.envelope_min_revolutions:
                self.env_non_sync = False
                self.m.issues.append(
                    f"envelope: the record holds {revs:.3g} revolutions of the slowest shaft (< "
                    f"{self.s.envelope_min_revolutions:g}, too few to separate periodic from random "
                    "content): whole-signal envelope on every channel"
                )
        if self.env_non_sync:
            idx = np.flatnonzero(self.env_use)
            ratios = []
            for c in idx:
                share = non_synchronous_share(model[:, c], self.y[:, c], self.fs, self._envelope_input)
                if share is not None:
                    ratios.append(share)
            worst = max(ratios, default=0.0)
            if worst > self.s.envelope_periodic_limit:
                self.env_non_sync = False
                self.m.issues.append(
                    f"envelope: the healthy model's response is not periodic at this operating point "
                    f"(non-synchronous part {100 * worst:.2g} % of the RMS at a bearing channel > "
                    f"{100 * self.s.envelope_periodic_limit:.2g} %): whole-signal envelope on every channel"
                )
        if not self.env_non_sync:
            self.env_use = np.ones(self.nc, dtype=bool)

    def _hunting_parts(self) -> list[np.ndarray]:
        """Each channel's measured part periodic in the hunting period (``envelope_hunting.hunting_part``
        of its non-synchronous envelope input) where, at some bearing channel, it carries at least
        ``envelope_hunting.MIN_SHARE`` of that input's power; zeros elsewhere (and the record unchanged).
        ``issues`` names the channels and shares."""
        zeros = [np.zeros(self.y.shape[0]) for _ in range(self.nc)]
        th = hunting_period_s(self.runner.cfg, self.speed_hz * 60.0) if self.env_non_sync else None
        if th is None:
            return zeros
        idx = [c for c in np.flatnonzero(self.env_use) if np.any(self._y_env[c])]
        parts = {c: hunting_part(self._y_env[c], self.fs, 1.0 / th) for c in idx}
        shares = {c: hunting_share(self._y_env[c], parts[c]) for c in idx}
        if not shares or max(shares.values()) < MIN_SHARE:
            return zeros
        issue = (
            "envelope: content periodic in the hunting period (tooth pairs meeting at their own flank "
            "positions: pitch errors) carries "
            + ", ".join(f"{100 * v:.2g} % at {self.names[c]}" for c, v in shares.items())
            + " of the non-synchronous power: removed from the measured envelope input (no bearing makes it)"
        )
        if issue not in self.m.issues:  # the bands may be chosen again (a new baseline)
            self.m.issues.append(issue)
        return [parts.get(c, z) for c, z in enumerate(zeros)]

    def _envelope_input(self, x: np.ndarray) -> np.ndarray:
        """Signal whose envelope is analysed: without every shaft's synchronous part when the speed is
        known precisely (order family active; ``features_orders.remove_synchronous``), else as is. On a
        record resampled to uniform angle (its speed varied) also without the synchronous response's
        part that follows the speed change (``speed_modulation.py``, Sec. 8.49)."""
        if not self.env_non_sync:
            return x
        shafts_hz = [sh.ratio * self.speed_hz for sh in self.shafts]
        out = remove_synchronous(x, self.fs, shafts_hz)
        u = getattr(self.m, "speed_change", None)
        return out if u is None else remove_speed_modulated(out, self.fs, shafts_hz, u)

    def envelope_noise_floor(self, c: int) -> np.ndarray:
        """Noise floor of the measured envelope spectrum of channel ``c`` per bin: the level (median
        of ``d / shape``) times the Gaussian floor's shape (``features_envelope_noise``)."""
        shape = self.env_shape[c] if getattr(self, "env_shape", None) else np.ones(self.d_env[c].shape)
        level = self.env_floor_level[c] if getattr(self, "env_floor_level", None) else self.env_floor[c]
        return level * shape

    def envelope_expected(self, c: int, p_model: np.ndarray, gain: float) -> np.ndarray:
        """Expected measured envelope power: ``g^4 S_model + N0 shape`` (the noise floor's level from
        the medians, its shape that of Gaussian content with the measured band's spectrum)."""
        model = gain**4 * p_model
        shape = self.env_shape[c] if getattr(self, "env_shape", None) else np.ones(model.shape)
        dmed = self.env_floor_level[c] if getattr(self, "env_floor_level", None) else self.env_floor[c]
        floor = max(dmed - float(np.median(model / shape)), 1e-3 * dmed, 1e-300)
        return model + floor * shape

    def line_mask(self, freqs_hz: Sequence[float], rel_width: float = 0.0075) -> np.ndarray:
        """Envelope bins within +-max(1.5 bins, rel_width f) of the given line frequencies."""
        mask = np.zeros(self.env_f.size, dtype=bool)
        if self.env_f.size < 2:
            return mask
        df = float(self.env_f[1] - self.env_f[0])
        for f in freqs_hz:
            mask |= np.abs(self.env_f - f) <= max(1.5 * df, rel_width * f)
        return mask

    def envelope_model(self, feats: ModelFeatures, c: int) -> np.ndarray:
        _, p, _ = envelope_power_spectrum(
            feats.analytic[c], self.fs, self.s.envelope_min_hz, self.env_hi, self.s.envelope_segment_s
        )
        return p
