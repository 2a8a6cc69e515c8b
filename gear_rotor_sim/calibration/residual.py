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
"""

from __future__ import annotations

import hashlib
import math
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import signal as _sig

from gear_rotor_sim.analysis.signals import amplitude_spectrum, analytic_band, resample_to_angle
from gear_rotor_sim.calibration.features_bearing import anti_aliased_impacts, static_sensor_gains
from gear_rotor_sim.calibration.features_envelope_noise import bin_sum_variance_factor, envelope_noise_shape
from gear_rotor_sim.calibration.features_orders import remove_synchronous
from gear_rotor_sim.calibration.measurement import Measurement, OperatingPoint
from gear_rotor_sim.calibration.model_accel import MARGIN, differentiate, velocity_of
from gear_rotor_sim.calibration.model_misalignment import mesh_force_run
from gear_rotor_sim.calibration.model_settle import grown_start_samples, run_settled, whole_period_samples
from gear_rotor_sim.calibration.model_window import hunting_period_s
from gear_rotor_sim.calibration.order_dft import revolution_coefficients
from gear_rotor_sim.faults.misalignment_force import needs_mesh_force, with_mesh_force

FAMILIES = ("order", "envelope", "static")

#: Quantities whose mean (order 0) is a physical feature; accelerometers are AC-coupled.
STATIC_QUANTITIES = ("dynamic_transmission_error", "mesh_force", "bearing_force", "displacement")


# ---------------------------------------------------------------------------------------------------
# Sensor model: housing mode seen by an accelerometer
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class HousingSensor:
    """Single-DOF housing/sensor mode driven by a bearing force (the accelerometer's view).

    ``m a_h'' ... : m x'' + 2 zeta omega_n m x' + omega_n^2 m x = F_bearing``; the sensor reads the
    housing acceleration ``a_h = x''``, i.e. ``H(s) = s^2 / (m (s^2 + 2 zeta omega_n s + omega_n^2))``
    (discretised by the bilinear transform pre-warped at ``f_n``). The housing resonance is what
    makes bearing impacts ring in the kHz band seen in real recordings (McFadden & Smith 1984).

    Attributes
    ----------
    frequency_hz : float
        Housing/sensor natural frequency f_n (a fitted nuisance in the CWRU rig).
    damping_ratio : float
        zeta.
    mass_kg : float
        Effective housing mass m.
    """

    frequency_hz: float = 3000.0
    damping_ratio: float = 0.05
    mass_kg: float = 1.0

    def apply(self, force: np.ndarray, sample_rate_hz: float) -> np.ndarray:
        """Housing acceleration (m/s^2) for a bearing force history (N)."""
        wn = 2.0 * math.pi * min(self.frequency_hz, 0.45 * sample_rate_hz)
        b, a = _sig.bilinear(
            [1.0, 0.0, 0.0],
            [self.mass_kg, 2 * self.damping_ratio * wn * self.mass_kg, wn * wn * self.mass_kg],
            fs=sample_rate_hz,
        )
        return _sig.lfilter(b, a, force - np.mean(force))


# ---------------------------------------------------------------------------------------------------
# Model runner (cached)
# ---------------------------------------------------------------------------------------------------
_CACHE: OrderedDict[str, np.ndarray] = OrderedDict()
#: contact-loss fraction of each cached run (same keys)
_LOSS: dict[str, float] = {}
_CACHE_MAX = 400


_SYSTEMS: OrderedDict[tuple[str, float], object] = OrderedDict()


def _cfg_key(cfg: object) -> str:
    return hashlib.sha1(repr(cfg).encode()).hexdigest()


def cached_system(cfg: object, temperature_c: float) -> object:
    """``GearRotorSystem.from_config`` memoised on (config content, temperature): the calibration
    simulates one rig many times with effects that do not change the assembly."""
    from gear_rotor_sim.system import GearRotorSystem

    key = (_cfg_key(cfg), float(temperature_c))
    hit = _SYSTEMS.get(key)
    if hit is None:
        hit = GearRotorSystem.from_config(cfg, temperature_c)
        _SYSTEMS[key] = hit
        if len(_SYSTEMS) > 32:
            _SYSTEMS.popitem(last=False)
    return hit


#: integration steps per mesh period of the calibration's model runs against a held reference
#: baseline (``--baseline``; where the teeth separate the simulator's dt rule takes more anyway). From
#: 48 on the dt rule locates the mesh-table jumps inside the steps (``solver/dt_rule.py``); at 32 they
#: are taken at the step instants and the timing error repeats with the step grid's beat against the
#: tooth count, which puts numerical lines at every shaft order between the mesh harmonics
#: (docs/calibration.md Sec. 8.18: ``bearing2_fx`` 1.35 N RMS over the non-carrier pinion orders at
#: 3000 rpm, 0.015 N at 64 located). Without a reference the count starts at 32. Either is the first
#: count of the convergence rule of the diagnosis (``model_steps.py``, Sec. 8.24), which doubles it
#: where the healthy model's non-synchronous part is not converged (4500 rpm / 75 C: 64 from 32).
REFERENCE_STEPS_PER_MESH = 64

#: envelope-band choice: a residual envelope line this many times its floor (6 dB, the detection
#: threshold of a bearing line, ``FitSettings.line_prominence``) makes a channel's own band; below
#: it a channel takes the band of the most prominent channel at the same bearing
ENVELOPE_BAND_PROMINENCE = 4.0


@dataclass
class ModelRunner:
    """Runs the simulator at the declared operating point and returns the measured channels.

    Attributes
    ----------
    cfg : RigConfig
        Model of the measured machine.
    operating_point : OperatingPoint
        Declared speed, temperature (and output torque, applied to the config's load).
    sample_rate_hz : float
        Output rate (= the measurement's).
    n_samples : int
        Samples per channel.
    t0 : float
        Measurement time of the first sample; the model is sampled at the same absolute times when
        ``t0 >= warmup_s``, otherwise at ``warmup_s + (t - t0)`` (order features are phase-referenced
        to the absolute shaft angle, so the offset does not matter there).
    channels : list of str
        Model channel names; ``bearing<k>_housing_a<d>`` is the housing sensor of bearing k.
    sensors : dict
        ``channel -> HousingSensor`` for housing channels.
    n_model : int
        Samples simulated and returned per run (0: ``n_samples``). The calibration simulates whole
        hunting periods of the mesh instead of the record length (``model_window.py``): every
        feature is an average over the record and the response is periodic in that period.
    """

    cfg: object
    operating_point: OperatingPoint
    sample_rate_hz: float
    n_samples: int
    t0: float
    channels: list[str]
    warmup_s: float = 0.15
    steps_per_mesh: int = 32
    sensors: dict[str, HousingSensor] = field(default_factory=dict)
    n_runs: int = 0
    n_model: int = 0
    #: contact-loss fraction (time share of separated teeth) of the last run returned
    last_contact_loss: float = float("nan")
    n_moved: int = 0  # runs whose window was moved on past a step-rule switch (model_settle.py)
    #: node accelerations as the derivative of the simulated velocities (``model_accel.py``)
    accel_from_velocity: bool = True
    #: effect types that a run switches on after whole hunting periods of the run without them,
    #: instead of starting from the static equilibrium with them (``candidates_wear_rattle.py``:
    #: worn teeth where the teeth separate stay on the healthy machine's rattle branch)
    grown_effects: tuple[type, ...] = ()
    #: a misaligned gear's axial force from the instantaneous mesh force (one fixed-point pass through
    #: a mesh-force run, ``model_misalignment.py``); False: the effects as given
    instantaneous_misalignment: bool = True
    #: the simulator's integration map (``Simulator(exact_modal_map=...)``): None the dt rule's choice,
    #: True the exact modal propagator (no period error at the resolved modes; docs/calibration.md
    #: Sec. 8.21: with Newmark's map at 64 steps per mesh the 2000 rpm reference's mesh scale is x1.199,
    #: x1.107 at 256 steps, x1.111 with the exact map at 64)
    exact_modal_map: bool | None = None
    #: bearing-defect impacts' direct path through the simulator's anti-aliasing decimation like the
    #: rest of the stream (``add_direct_bearing_forces``, Sec. 8.30); False (the default): averaged
    #: over each sample interval. Opt-in: on the CWRU outer-race file it doubled the envelope's
    #: relative error (0.28 -> 0.57), whose band reaches into the filter's transition band
    direct_path_anti_alias: bool = False

    def __post_init__(self) -> None:
        cfg = self.cfg
        if self.operating_point.output_torque_nm is not None and getattr(cfg, "load", None) is not None:
            import dataclasses

            cfg = cfg.replace(
                load=dataclasses.replace(cfg.load, torque_nm=float(self.operating_point.output_torque_nm))
            )
        self.cfg = cfg
        self._key = _cfg_key(cfg)
        if not 0 < self.n_model <= self.n_samples:
            self.n_model = int(self.n_samples)

    @property
    def start_time(self) -> float:
        """Model time of the first returned sample."""
        return self.t0 if self.t0 >= self.warmup_s else self.warmup_s

    def sim_channels(self) -> list[str]:
        out = []
        for c in self.channels:
            src = housing_source(c)
            out.append(src if src else c)
        return list(dict.fromkeys(out))

    def force_signals(self, effects: Sequence[object] = ()) -> np.ndarray:
        """Simulated raw channels (bearing forces for housing channels), shape (n_model, n_sim_channels)."""
        grown = [e for e in effects if self.grown_effects and isinstance(e, self.grown_effects)]
        key = "|".join(
            [
                self._key,
                repr(self.operating_point),
                str(self.sample_rate_hz),
                str(self.n_model),
                f"{self.start_time:.9f}",
                ",".join(self.sim_channels()),
                str(self.steps_per_mesh),
                str(self.accel_from_velocity),
                str(self.exact_modal_map),
                str(self.direct_path_anti_alias),
                repr(tuple(effects)),
                *(["grown"] if grown else []),
            ]
        )
        hit = _CACHE.get(key)
        if hit is not None:
            _CACHE.move_to_end(key)
            self.last_contact_loss = _LOSS.get(key, float("nan"))
            return hit
        from gear_rotor_sim.simulator import Simulator

        speed, temp = self.operating_point.speed_rpm, self.operating_point.temperature_c
        for e in effects:
            fn = getattr(e, "operating_point", None)
            if fn is not None:
                speed, temp = fn(speed, temp)
        if self.instantaneous_misalignment and needs_mesh_force(effects):
            # the axial force of a tilted wheel follows the mesh force (model_misalignment.py)
            run = mesh_force_run(self, speed, cached_system(self.cfg, temp))
            effects = with_mesh_force(self.cfg, effects, speed, self.sample_rate_hz, run)
            grown = [e for e in effects if self.grown_effects and isinstance(e, self.grown_effects)]
        names = self.sim_channels()
        # accelerations as the derivative of the simulated velocities (model_accel.py): the window is
        # simulated MARGIN samples longer at each end for the differentiator
        vel = [velocity_of(c) if self.accel_from_velocity else None for c in names]
        pad = MARGIN if any(vel) else 0
        period = whole_period_samples(hunting_period_s(self.cfg, speed), self.sample_rate_hz)
        pre = grown_start_samples(period, self.sample_rate_hz) if grown else 0
        sim = Simulator(
            self.cfg,
            speed_rpm=speed,
            temperature_c=temp,
            output_rate_hz=self.sample_rate_hz,
            channels=[v or c for v, c in zip(vel, names, strict=True)],
            steps_per_mesh=self.steps_per_mesh,
            effects=tuple(e for e in effects if not any(e is g for g in grown)) if pre else tuple(effects),
            system_builder=cached_system,
            event_average=False,  # the setting the calibration tables were measured with
            exact_modal_map=self.exact_modal_map,
            streamed_misalignment=False,  # the orders come from the fixed-point pass (or F0)
        )
        i0 = round(self.start_time * self.sample_rate_hz)
        n = self.n_model
        if pre:
            # grown effects: whole hunting periods without them, then switched on (the output's phase
            # is unchanged; candidates_wear_rattle.py)
            sim.advance(pre / self.sample_rate_hz)
            sim.set_effects(tuple(effects))
        # the window holds no switch of the simulator's step rule (a start-up separation would put the
        # rule's contact-loss setting into it: model_settle.py); else it moves on by hunting periods
        run = run_settled(sim, i0 - pad, n + 2 * pad, self.sample_rate_hz, period)
        data = run.data
        if data.shape[0] != n + 2 * pad:
            raise RuntimeError(f"simulator returned {data.shape[0]} samples, expected {n + 2 * pad}")
        for k, v in enumerate(vel):
            if v:
                data[:, k] = differentiate(data[:, k], self.sample_rate_hz)
        data = np.ascontiguousarray(data[pad : pad + n])
        first = pre + run.first_index + pad
        add_direct_bearing_forces(
            data,
            names,
            effects,
            self.cfg,
            temp,
            speed,
            self.sample_rate_hz,
            first,
            anti_alias=self.direct_path_anti_alias,
        )
        self.n_runs += 1
        self.n_moved += run.shifts > 0
        _CACHE[key] = data
        self.last_contact_loss = _LOSS[key] = float(sim.last_chunk_stats.get("contact_loss_fraction", 0.0))
        if len(_CACHE) > _CACHE_MAX:
            _LOSS.pop(_CACHE.popitem(last=False)[0], None)
        return data

    def signals(
        self, effects: Sequence[object] = (), sensors: dict[str, HousingSensor] | None = None
    ) -> np.ndarray:
        """Model channels in the measurement's order, shape (n, n_channels), SI."""
        raw = self.force_signals(effects)
        return self.outputs(raw, sensors)

    def outputs(self, raw: np.ndarray, sensors: dict[str, HousingSensor] | None = None) -> np.ndarray:
        """Apply the sensor models to raw simulated channels."""
        sensors = self.sensors if sensors is None else sensors
        names = self.sim_channels()
        out = np.empty((raw.shape[0], len(self.channels)))
        for k, c in enumerate(self.channels):
            src = housing_source(c)
            if src:
                out[:, k] = sensors.get(c, HousingSensor()).apply(
                    raw[:, names.index(src)], self.sample_rate_hz
                )
            else:
                out[:, k] = raw[:, names.index(c)]
        return out


def add_direct_bearing_forces(
    data: np.ndarray,
    channels: Sequence[str],
    effects: Sequence[object],
    cfg: object,
    temperature_c: float,
    speed_rpm: float,
    sample_rate_hz: float,
    first_index: int,
    sub_samples: int = 10,
    anti_alias: bool = False,
) -> None:
    """Add the direct path of bearing-defect impacts to the bearing-force channels, in place.

    A defect's impact is an internal force pair: the simulator applies the shaft's share at the
    bearing node (``BearingDefect.force_amplitudes``); the race's share goes through the outer ring
    straight into the housing (``BearingDefect.impact_force``), which is what a force sensor under the
    bearing (and the housing behind it) feels first. The pulse (about 0.1 ms, shorter than two
    samples at 20 kHz) is averaged over each sample interval (``sub_samples`` points) so that its
    impulse is kept whatever its phase against the sampling; ``anti_alias=True`` passes it through
    the simulator's anti-aliasing decimation like the rest of the stream instead
    (``features_bearing.anti_aliased_impacts``; opt-in, docs/calibration.md Sec. 8.30). Constant
    speed; shaft angle 0 at model time 0 (the measured-data contract).
    """
    from types import SimpleNamespace

    from gear_rotor_sim.faults import BearingDefect
    from gear_rotor_sim.system import shaft_speed_ratios

    defects = [e for e in effects if isinstance(e, BearingDefect) and e.force_n]
    if not defects:
        return
    system = cached_system(cfg, temperature_c)
    ratios = np.asarray(shaft_speed_ratios(cfg), dtype=float)
    n = data.shape[0]
    omega = speed_rpm * 2.0 * math.pi / 60.0

    def ctx_at(t: np.ndarray) -> SimpleNamespace:
        return SimpleNamespace(
            system=system,
            shaft_angle=np.outer(omega * t, ratios),
            shaft_speed=np.tile(omega * ratios, (t.size, 1)),
        )

    sub = (np.arange(sub_samples) + 0.5) / sub_samples - 0.5
    t_avg = ((first_index + np.arange(n))[:, None] + sub[None, :]).ravel() / sample_rate_hz
    for d in defects:
        cols = [f"bearing{d.bearing}_f{a}" for a in "xy"]
        if not any(c in channels for c in cols):
            continue
        if anti_alias:
            f = anti_aliased_impacts(lambda t, d=d: d.impact_force(ctx_at(t)), first_index, n, sample_rate_hz)
        else:
            f = d.impact_force(ctx_at(t_avg)).reshape(n, sub_samples, 2).mean(axis=1)
        for k, c in enumerate(cols):
            if c in channels:
                data[:, list(channels).index(c)] += f[:, k]


def housing_source(channel: str) -> str | None:
    """``bearing<k>_housing_a<d>`` -> ``bearing<k>_f<d>`` (the force driving the housing), else None."""
    if "_housing_a" in channel:
        b, d = channel.split("_housing_a")
        return f"{b}_f{d}"
    return None


# ---------------------------------------------------------------------------------------------------
# Features
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ShaftOrders:
    """A shaft for order analysis: name, |speed ratio| to the input shaft, orders analysed."""

    name: str
    ratio: float
    orders: np.ndarray  # int orders
    teeth: int = 0  # teeth of the shaft's (first) gear: orders k * teeth are the mesh carriers
    #: teeth of every gear on the shaft (a shaft of a multi-stage train carries one gear per stage):
    #: the multiples of each are mesh carriers
    carrier_teeth: tuple[int, ...] = ()


def shaft_orders(
    cfg: object,
    speed_rpm: float,
    sample_rate_hz: float,
    low_orders: int = 6,
    sidebands: int = 6,
    mesh_harmonics: int = 3,
) -> list[ShaftOrders]:
    """Shafts and their analysed orders: 1..low_orders and m z +- sidebands (m = 1..mesh_harmonics)."""
    from gear_rotor_sim.system import shaft_speed_ratios

    ratios = np.abs(shaft_speed_ratios(cfg))
    out = []
    for s, shaft in enumerate(cfg.shafts):
        f = ratios[s] * speed_rpm / 60.0
        kmax = int(0.42 * sample_rate_hz / f)
        orders = set(range(1, low_orders + 1))
        teeth = 0
        all_teeth: list[int] = []
        for m in cfg.meshes:
            z = (
                m.pinion_teeth
                if cfg.gear(m.pinion).node0 in _shaft_nodes(cfg, s)
                else (m.gear_teeth if cfg.gear(m.gear).node0 in _shaft_nodes(cfg, s) else None)
            )
            if z is None:
                continue
            teeth = teeth or int(z)
            all_teeth.append(int(z))
            for h in range(1, mesh_harmonics + 1):
                orders.update(range(h * z - sidebands, h * z + sidebands + 1))
        arr = np.array(sorted(o for o in orders if 1 <= o <= kmax), dtype=int)
        if arr.size:
            out.append(ShaftOrders(shaft.name, float(ratios[s]), arr, teeth, tuple(dict.fromkeys(all_teeth))))
    return out


def _shaft_nodes(cfg: object, s: int) -> range:
    off = cfg.node_offsets[s]
    return range(off, off + cfg.shafts[s].n_nodes)


def order_coefficients(
    x: np.ndarray, fs: float, shaft_hz: float, orders: np.ndarray, angle0_rev: float, exact: bool = True
) -> tuple[np.ndarray, np.ndarray, int]:
    """Synchronous-average Fourier coefficients and their noise variance.

    Parameters
    ----------
    x : numpy.ndarray
        Signal (n,).
    fs : float
        Sample rate, Hz.
    shaft_hz : float
        Shaft rotation frequency, Hz.
    orders : numpy.ndarray
        Integer orders.
    angle0_rev : float
        Absolute shaft angle of the first sample, revolutions (the phase reference).
    exact : bool
        Each revolution's Fourier integral from the samples (``order_dft.py``, no images); False:
        the record resampled to ``2^k`` points per revolution by linear interpolation (computed
        order tracking as before session 9, kept where the teeth separate: docs/calibration.md
        Sec. 8.18).

    Returns
    -------
    coef : complex ndarray
        ``c_k`` such that the synchronous part is ``sum_k 2 Re(c_k e^{i k theta})``... (peak/2 scaling:
        ``|c_k|`` is half the peak amplitude of order k).
    var : ndarray
        Noise variance of each coefficient (between-revolution scatter / number of revolutions).
    n_rev : int
    """
    # at the constant declared speed: each revolution's Fourier integral directly, no resampling (a
    # linear interpolation onto an angle grid folds images of the mesh harmonics onto shaft orders:
    # order_dft.py)
    if exact:
        per = revolution_coefficients(np.asarray(x, dtype=float) - np.mean(x), fs, shaft_hz, orders)
    else:
        spr = int(2 ** math.ceil(math.log2(max(fs / shaft_hz, 2 * (orders.max() + 2)))))
        _, xa = resample_to_angle(x - np.mean(x), fs, shaft_hz * 60.0, spr)
        n_res = (xa.size - 1) // spr
        per = np.fft.rfft(xa[: n_res * spr].reshape(n_res, spr), axis=1)[:, orders] / spr
    n_rev = per.shape[0]
    if n_rev < 2:
        raise ValueError(f"record shorter than 2 revolutions of a {shaft_hz:.3g} Hz shaft")
    coef = per.mean(axis=0)
    var = np.sum(np.abs(per - coef) ** 2, axis=0) / max(n_rev - 1, 1) / n_rev
    rot = np.exp(-2j * np.pi * orders * (angle0_rev % 1.0))
    return coef * rot, var, n_rev


def envelope_power_spectrum(
    analytic: np.ndarray, fs: float, f_lo: float, f_hi: float, segment_s: float
) -> tuple[np.ndarray, np.ndarray, float]:
    """Welch-averaged power spectrum of the squared envelope ``|analytic|^2``.

    Hann segments of ``segment_s`` (shortened to an eighth of the record if needed) with 50 %
    overlap, mean removed per segment, 3-bin moving sum. Returns the frequencies in ``[f_lo, f_hi]``,
    the averaged power per bin and the number of averages (Welch 1967: about ``1.9 N / L - 0.9``
    segments for 50 %-overlapped Hann segments, times the 3 summed bins; the correlation of adjacent
    Hann bins makes the equivalent number 1.61 times smaller: ``features_envelope_noise``).
    """
    env = np.abs(analytic) ** 2
    n = len(env)
    L = int(min(segment_s * fs, n))
    step = max(L // 2, 1)
    starts = np.arange(0, n - L + 1, step)
    w = np.hanning(L)
    segs = np.stack([env[s0 : s0 + L] for s0 in starts])
    segs = segs - segs.mean(axis=1, keepdims=True)
    spec = np.abs(np.fft.rfft(segs * w, axis=1)) ** 2 / (w.sum() ** 2) * 4.0
    f = np.fft.rfftfreq(L, 1.0 / fs)
    sel = (f >= f_lo) & (f <= f_hi)
    k_eff = max(1.0, 1.9 * n / L - 0.9) if starts.size > 1 else 1.0
    # 3-bin moving sum: a line smeared by random slip keeps its power (McFadden & Smith 1984); counted
    # as 3 independent bins (adjacent Hann bins are correlated: 3 / 1.61 would be exact, applied by
    # ``Comparison`` with ``ResidualSettings.envelope_noise_corrected``)
    avg = spec.mean(axis=0)
    avg = np.convolve(avg, np.ones(3), mode="same")
    return f[sel], avg[sel], 3.0 * k_eff


def prominent_envelope_band(
    x: np.ndarray,
    fs: float,
    f_lo: float,
    f_hi: float,
    segment_s: float,
    min_hz: float = 500.0,
    with_score: bool = False,
) -> Any:
    """One-octave band whose squared-envelope spectrum has the most prominent line.

    Candidate bands ``[lo, 2 lo]`` with ``lo`` from ``min_hz`` in steps of sqrt(2) up to ``0.45 fs``;
    the score is the largest envelope-spectrum bin in ``[f_lo, f_hi]`` over the median bin (the
    criterion of the protrugram, Barszcz & Jablonski 2011: periodic impacts give lines, random
    impulsiveness does not). Applied to the residual measurement - healthy model. Returns the band,
    or ``(band, score)`` with ``with_score``.
    """
    best = (-np.inf, (0.25 * fs, 0.45 * fs))
    lo = min_hz
    while lo * 1.5 <= 0.45 * fs:
        band = (lo, min(2 * lo, 0.45 * fs))
        _, p, _ = envelope_power_spectrum(analytic_band(x, fs, band), fs, f_lo, f_hi, segment_s)
        med = float(np.median(p))
        score = float(np.max(p)) / med if med > 0 else 0.0
        if score > best[0]:
            best = (score, band)
        lo *= math.sqrt(2.0)
    return (best[1], best[0]) if with_score else best[1]


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
    #: never the gain the mesh carriers set (their model-form misfit; docs/calibration.md Sec. 8.22)
    shaft_order_static_gain: bool = True
    #: the envelope's noise model (``features_envelope_noise``, docs/calibration.md Secs. 8.15, 8.23):
    #: a floor shaped like white noise through the band-pass, and the 3-bin sum counted as 3 / 1.61
    #: independent bins, so that pure noise scores 1. ``False``: the old flat floor and plain count
    #: (pure noise scores 4.9), kept only to reproduce results before session 11
    envelope_noise_corrected: bool = True
    #: with the reference numerics (a held reference and its fit, where the healthy model stays in
    #: contact): the model runs take the exact modal map instead of the dt rule's choice. Newmark's
    #: period error at the mesh-coupled modes moves the reference's mesh stiffness scale with the step
    #: (x1.309 / 1.199 / 1.121 / 1.107 at 32 / 64 / 128 / 256 steps per mesh on the independent 2000 rpm
    #: record; x1.111 / damping x1.7 with the exact map at 64). With it on, the contact tooth depth against
    #: the reference is read from the DTE comb (``candidates_tooth_dte.dte_depth_applies``). Off by default:
    #: measured on the independent benchmark (docs/calibration.md Sec. 8.27) three rattle rows that pass
    #: against the unconverged reference fail against the converged one (23 of 27 with ``--baseline``),
    #: and the converged reference's mesh damping sits at its grid edge (not identified)
    reference_exact_map: bool = False


class Comparison:
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
            for c in range(self.nc):
                if not self.env_use[c]:
                    band = self.bands[-1] if self.bands else (0.25 * self.fs, 0.45 * self.fs)
                elif self.s.envelope_band_hz is not None:
                    band = self.s.envelope_band_hz
                else:
                    band, score = prominent_envelope_band(
                        self._envelope_input(resid[:, c]),
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
        healthy record above 25 C to the whole-signal envelope.
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
                x = model[:, c] - model[:, c].mean()
                sd = max(float(np.std(x)), float(np.std(self.y[:, c])))
                if sd > 0:
                    ratios.append(float(np.std(self._envelope_input(x))) / sd)
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

    def _envelope_input(self, x: np.ndarray) -> np.ndarray:
        """Signal whose envelope is analysed: without every shaft's synchronous part when the speed is
        known precisely (order family active; ``features_orders.remove_synchronous``), else as is."""
        if not self.env_non_sync:
            return x
        return remove_synchronous(x, self.fs, [sh.ratio * self.speed_hz for sh in self.shafts])

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
        order = []
        for cs in feats.order:
            order.append(
                [
                    co * np.exp(-2j * np.pi * sh.orders * sh.ratio * self.speed_hz * dt)
                    for co, sh in zip(cs, self.shafts, strict=True)
                ]
            )
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
        on the shaft (one per stage on the intermediate shaft of a multi-stage train)."""
        sh = self.shafts[s]
        teeth = sh.carrier_teeth or ((sh.teeth,) if sh.teeth else ())
        mask = np.zeros(sh.orders.size, dtype=bool)
        for z in teeth:
            mask |= sh.orders % z == 0
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
        unbalance +22 %; docs/calibration.md Sec. 8.22). A shaft order tens of Hz to a few hundred Hz is
        off the carriers' transfer path; what it shares with them is the sensor. So it takes the sensor
        gain where the channel's mean identifies one (a radial bearing force: ``measured mean / model
        mean`` of an equilibrium load, ``features_bearing.static_sensor_gains``), else the nominal 1 (a
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
                A += [[mm.sum(), (mm * x).sum()], [(mm * x).sum(), (mm * x * x).sum()]]
                rhs += [dm.sum(), (dm * x).sum()]
                k = self.carriers(s)
                mk, dk, xk = mm[k], dm[k], x[k]
                Ac += [[mk.sum(), (mk * xk).sum()], [(mk * xk).sum(), (mk * xk * xk).sum()]]
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


# ---------------------------------------------------------------------------------------------------
# Plain metrics for the report
# ---------------------------------------------------------------------------------------------------
def align_time(y: np.ndarray, m: np.ndarray, max_lag: int) -> tuple[int, float]:
    """Integer lag (samples) and gain that best map ``m`` onto ``y`` (cross-correlation, LS gain)."""
    y0 = y - y.mean()
    m0 = m - m.mean()
    if not np.any(m0):
        return 0, 1.0
    n = len(y0)
    nfft = 1 << math.ceil(math.log2(2 * n))
    xc = np.fft.irfft(np.fft.rfft(y0, nfft) * np.conj(np.fft.rfft(m0, nfft)), nfft)
    lags = np.concatenate([np.arange(0, max_lag + 1), np.arange(-max_lag, 0)])
    vals = np.concatenate([xc[: max_lag + 1], xc[nfft - max_lag :]])
    lag = int(lags[int(np.argmax(vals))])
    ms = np.roll(m0, lag)
    g = float(np.dot(y0, ms) / np.dot(ms, ms))
    return lag, g


def time_and_spectrum_errors(y: np.ndarray, m: np.ndarray, fs: float, max_lag: int) -> dict[str, float]:
    """Relative RMS of the aligned time residual and relative amplitude-spectrum error."""
    lag, g = align_time(y, m, max_lag)
    y0 = y - y.mean()
    r = y0 - g * np.roll(m - m.mean(), lag)
    sy = amplitude_spectrum(y0, fs).amplitude
    sm = amplitude_spectrum(m - m.mean(), fs).amplitude
    ny = float(np.sqrt(np.sum(y0**2)))
    return {
        "time": float(np.sqrt(np.sum(r**2)) / ny) if ny > 0 else float("nan"),
        "spectrum": float(np.linalg.norm(sy - abs(g) * sm) / np.linalg.norm(sy))
        if np.any(sy)
        else float("nan"),
    }


def residual_spectrum(
    y: np.ndarray, m: np.ndarray, fs: float, gain: float, max_lag: int
) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude spectrum of the aligned time residual ``y - g m``."""
    lag, _ = align_time(y, m, max_lag)
    r = (y - y.mean()) - gain * np.roll(m - m.mean(), lag)
    s = amplitude_spectrum(r, fs)
    return s.axis, s.amplitude
