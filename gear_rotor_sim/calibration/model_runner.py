"""The calibration's model runs: the simulator at the declared operating point with the given
effects, cached per run (``ModelRunner``), the assembled system cached per config and
temperature, the direct path of bearing-defect impacts and the housing sensor model of an
accelerometer channel (the streamed sensor's mode with the calibration's defaults).
"""

from __future__ import annotations

import hashlib
import math
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from gear_rotor_sim.calibration.features_bearing import anti_aliased_impacts
from gear_rotor_sim.calibration.measurement import OperatingPoint
from gear_rotor_sim.calibration.model_accel import MARGIN, differentiate, velocity_of
from gear_rotor_sim.calibration.model_misalignment import mesh_force_run
from gear_rotor_sim.calibration.model_settle import (
    grown_start_samples,
    run_settled,
    whole_period_samples,
    window_period_samples,
)
from gear_rotor_sim.calibration.model_window import hunting_period_s
from gear_rotor_sim.faults.misalignment_force import needs_mesh_force, with_mesh_force
from gear_rotor_sim.sensors.housing import HousingSensor as _StreamedHousingSensor


@dataclass(frozen=True)
class HousingSensor(_StreamedHousingSensor):
    """The calibration's housing/sensor mode driven by a bearing force (the accelerometer's view).

    The single-DOF mode of :class:`gear_rotor_sim.sensors.housing.HousingSensor`
    (``H(s) = s^2 / (m (s^2 + 2 zeta omega_n s + omega_n^2))``) with the calibration's defaults: a unit
    mass and the bilinear transform not pre-warped, so its resonance lands slightly below ``f_n``, a
    fitted nuisance on measured rigs (the CWRU reports were fitted this way). The housing resonance is
    what makes bearing impacts ring in the kHz band seen in real recordings (McFadden & Smith 1984).
    """

    mass_kg: float = 1.0
    prewarp: bool = False


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
#: (docs/history/calibration_sessions.md Sec. 8.18: ``bearing2_fx`` 1.35 N RMS over the non-carrier pinion
#: orders at 3000 rpm, 0.015 N at 64 located). Without a reference the count starts at 32. Either is the first
#: count of the convergence rule of the diagnosis (``model_steps.py``, Sec. 8.24), which doubles it
#: where the healthy model's non-synchronous part is not converged (4500 rpm / 75 C: 64 from 32).
REFERENCE_STEPS_PER_MESH = 64


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
    #: True the exact modal propagator (no period error at the resolved modes;
    #: docs/history/calibration_sessions.md Sec. 8.21: with Newmark's map at 64 steps per mesh the 2000 rpm
    #: reference's mesh scale is x1.199, x1.107 at 256 steps, x1.111 with the exact map at 64)
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
        # a fractional period moves the window too, read at its original instants (model_settle.py)
        move = window_period_samples(hunting_period_s(self.cfg, speed), self.sample_rate_hz)
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
        run = run_settled(sim, i0 - pad, n + 2 * pad, self.sample_rate_hz, move)
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
    (``features_bearing.anti_aliased_impacts``; opt-in, docs/history/calibration_sessions.md Sec. 8.30).
    Constant speed; shaft angle 0 at model time 0 (the measured-data contract).
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
