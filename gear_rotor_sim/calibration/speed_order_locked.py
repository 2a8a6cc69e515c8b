"""An input-shaft angle modulated at a shaft's own order, read from the mesh lines' sidebands (issue 11;
docs/calibration.md Sec. 2 "Speed check", varying speed; history Sec. 8.55).

A speed fluctuation at a shaft's rate (a coupling, a Cardan joint, a torsional response to a shaft's
own fault) is periodic with that shaft: no tracking kernel that keeps a fault's shaft-order sidebands
out of the angle can follow it, and it is synchronous content. What tells it from a fault is its form.
An angle modulation ``delta(theta) = 2 Re(d_j exp(i j r theta))`` at order ``j`` of a shaft turning at
``r`` times the input modulates every mesh line ``K`` in phase by ``K delta``: its sidebands at
``K +- j r`` over the carrier ``C_K`` are ``U / C = i K d_j`` and ``L / C = i K conj(d_j)`` (to first
order), so ``d_j = (U / C - conj(L / C)) / (2 i K)`` is the same for every line and channel, while an
amplitude modulation (a load, a resonance the speed sweeps) has ``U / C = conj(L / C)`` and drops out.
:func:`angle_modulation` reads ``d_j`` per line, weights the lines by their noise (the sideband
coefficients' noise from eight off-order coefficients next to the carrier) and combines them.

Measured on the independent records (``benchmarks/speed_track_error.py``): 0.3 % at the gear's rate
(29.6 Hz at 3000 rpm) reads ``2 |d_1| = 5.1e-3 rad`` at gear order 1 (the profile's ``5.07e-3``), its
orders 2-3 below 5e-5; a gear eccentricity reads nothing (below 1e-5: the generator's eccentricity moves
the line of action, not the mesh timing); a damaged gear tooth reads 4.2-4.4e-4 rad at every gear order
alike (a local event: a flat comb, not one order); a damaged pinion tooth 7e-4 at every pinion order.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from gear_rotor_sim.calibration.speed_tracking import SpeedTrack, _line_orders, speed_of_angle

#: shaft orders read (the others of the same shaft are the dominance test's reference)
SHAFT_ORDERS = (1, 2, 3)
#: the orders that may read as a speed fluctuation. A misaligned wheel modulates the mesh timing at its own
#: order 2 alone (1.1e-3 to 4.4e-3 rad, 126-197 times its orders 1 and 3 on the three misalignment records of
#: the 71), so order 2 is read only where every mesh harmonic reads the same modulation
#: (:data:`KINEMATIC_ORDERS`, ``speed_order_harmonics.kinematic``; Sec. 8.60)
FLUCTUATION_ORDERS = (1, 2)
#: orders read only where the harmonics agree
KINEMATIC_ORDERS = (2,)
#: how many times the same shaft's other orders a harmonics-tested reading must be: a damaged tooth's flat
#: comb (x1.0-1.02 over the orders) and a crack (x2-2.5) stay below it, and their readings are not kinematic
#: (the pinion tooth's per-harmonic readings at its orders 1 and 3 differ 10-20 fold); 5 lost a 1 %
#: input ripple over a pinion tooth's comb (x4.18)
DOMINANCE_KINEMATIC = 3.0
#: noise sigmas the modulation must stand out
MIN_Z = 10.0
#: how many times the same shaft's other orders it must be
DOMINANCE = 5.0
#: off-order offsets (orders of the input) next to a carrier whose coefficients give the noise level
NOISE_OFFSETS = np.array([-0.43, -0.37, -0.21, -0.13, 0.13, 0.21, 0.37, 0.43])
#: a carrier is used when its power stands this far above the noise
MIN_CARRIER_SNR = 100.0


@dataclass(frozen=True)
class AngleModulation:
    """The input angle's modulation at order ``order`` of a shaft (module docstring).

    Attributes
    ----------
    shaft_ratio : float
        The shaft's speed over the input's.
    order : int
        Order of that shaft.
    amplitude_rad : float
        ``2 |d|``: the angle modulation's amplitude, rad of the input shaft.
    phase_rad : float
        ``arg d``: ``delta = amplitude cos(order r theta + phase)``.
    z : float
        ``|d|`` over its noise sigma.
    chi2_per_line : float
        The lines' disagreement about ``d`` over their noise (complex: two degrees of freedom a line).
    n_lines : int
        Lines (carrier x channel) combined.
    """

    shaft_ratio: float
    order: int
    amplitude_rad: float
    phase_rad: float
    z: float
    chi2_per_line: float
    n_lines: int


@dataclass(frozen=True)
class LineReadings:
    """Per line (carrier x channel) readings of an angle modulation (:func:`line_readings`).

    Attributes
    ----------
    harmonic : numpy.ndarray
        The line's order of the input (a mesh harmonic).
    channel : numpy.ndarray
        Its channel's column index.
    d : numpy.ndarray
        ``(U / C - conj(L / C)) / (2 i K)``: the line's reading of the angle modulation (complex).
    a : numpy.ndarray
        ``(U / C + conj(L / C)) / 2``: its relative amplitude modulation (complex).
    weight : numpy.ndarray
        ``1 / var(d)`` from the noise next to the carrier.
    """

    harmonic: np.ndarray
    channel: np.ndarray
    d: np.ndarray
    a: np.ndarray
    weight: np.ndarray


def line_readings(
    data: np.ndarray, theta: np.ndarray, lines: list[float], shaft_ratio: float, order: int
) -> LineReadings:
    """Each carrier's (mesh harmonic ``lines`` x channel) reading of the angle modulation at ``order`` of
    the shaft turning ``shaft_ratio`` times the input along the input angle ``theta`` (module
    docstring); carriers standing less than :data:`MIN_CARRIER_SNR` above their noise are left out.

    Parameters
    ----------
    data : numpy.ndarray
        ``(n_samples, n_channels)`` record.
    theta : numpy.ndarray
        Input-shaft angle at each sample (the tracked one), rad.
    lines : list of float
        Mesh harmonics, orders of the input.
    shaft_ratio : float
    order : int

    Returns
    -------
    LineReadings
    """
    x = np.asarray(data, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    xc = x - x.mean(axis=0)
    rows: list[tuple[float, int, complex, complex, float]] = []
    s = order * shaft_ratio
    # exp(-i q theta) for q = k, k + s, k - s, k + the noise offsets: the carrier's phasor times shared ones
    shifts = np.exp(-1j * np.outer(np.concatenate(([0.0, s, -s], NOISE_OFFSETS)), theta))
    for k in lines:
        c = (shifts * np.exp(-1j * k * theta)) @ xc / xc.shape[0]  # orders x channels
        noise = np.median(np.abs(c[3:]) ** 2, axis=0) / math.log(2.0)
        for ch in range(xc.shape[1]):
            carrier, up, low = c[0, ch], c[1, ch], c[2, ch]
            if not abs(carrier) ** 2 > MIN_CARRIER_SNR * noise[ch]:
                continue
            d = (up / carrier - np.conj(low / carrier)) / (2j * k)
            a = (up / carrier + np.conj(low / carrier)) / 2.0
            rows.append((k, ch, d, a, 2.0 * k * k * abs(carrier) ** 2 / noise[ch]))  # 1 / var(d)
    cols = list(zip(*rows, strict=True)) if rows else [(), (), (), (), ()]
    return LineReadings(
        np.array(cols[0], dtype=float),
        np.array(cols[1], dtype=int),
        np.array(cols[2], dtype=complex),
        np.array(cols[3], dtype=complex),
        np.array(cols[4], dtype=float),
    )


def combine(
    rd: LineReadings, shaft_ratio: float, order: int, keep: np.ndarray | None = None
) -> AngleModulation | None:
    """The readings' (those where ``keep``) noise-weighted mean angle modulation, None without any."""
    d, w = (rd.d, rd.weight) if keep is None else (rd.d[keep], rd.weight[keep])
    if d.size == 0:
        return None
    mean = complex(np.sum(w * d) / w.sum())
    chi2 = float(np.sum(w * np.abs(d - mean) ** 2)) / 2.0
    return AngleModulation(
        shaft_ratio,
        order,
        2.0 * abs(mean),
        math.atan2(mean.imag, mean.real),
        abs(mean) * math.sqrt(float(w.sum())),
        chi2 / max(d.size - 1, 1),
        int(d.size),
    )


def angle_modulation(
    data: np.ndarray, theta: np.ndarray, lines: list[float], shaft_ratio: float, order: int
) -> AngleModulation | None:
    """The angle modulation at ``order`` of the shaft turning ``shaft_ratio`` times the input, read from
    the mesh lines ``lines`` (orders of the input) along the input angle ``theta`` (module docstring):
    :func:`line_readings` combined (:func:`combine`).

    Returns
    -------
    AngleModulation or None
        None when no carrier stands :data:`MIN_CARRIER_SNR` above its noise.
    """
    return combine(line_readings(data, theta, lines, shaft_ratio, order), shaft_ratio, order)


def order_locked_fluctuation(
    data: np.ndarray,
    sample_rate_hz: float,
    tr: SpeedTrack,
    mesh_orders: list[float],
    shaft_ratios: list[float],
    tolerance_rad: float,
) -> AngleModulation | None:
    """The strongest angle modulation at orders :data:`FLUCTUATION_ORDERS` of any shaft that reads as a speed
    fluctuation at that shaft's own rate, else None.

    It reads as one when its rms ``amplitude / sqrt(2)`` exceeds ``tolerance_rad`` (it moves the highest
    synchronous order by more than the features allow, ``order_tracking.angle_tolerance_rad``), it stands
    :data:`MIN_Z` noise sigmas out, and it is :data:`DOMINANCE` times the same shaft's other orders: a
    sinusoidal speed fluctuation stands at one order, a damaged tooth's local event reads alike at every
    order (module docstring).

    Parameters
    ----------
    data : numpy.ndarray
        ``(n_samples, n_channels)`` record.
    sample_rate_hz : float
    tr : SpeedTrack
        The tracked angle.
    mesh_orders : list of float
        Mesh frequency of each mesh per unit input rate.
    shaft_ratios : list of float
        Every shaft's speed over the input's.
    tolerance_rad : float

    Returns
    -------
    AngleModulation or None
    """
    from gear_rotor_sim.calibration.speed_order_harmonics import kinematic

    lines = _line_orders(mesh_orders, tr.mean_rpm / 60.0, float(sample_rate_hz))
    best: AngleModulation | None = None
    for r in sorted({round(abs(float(v)), 12) for v in shaft_ratios}):
        rds = [line_readings(data, tr.angle_rad, lines, r, j) for j in SHAFT_ORDERS]
        mods = [combine(rd, r, j) for rd, j in zip(rds, SHAFT_ORDERS, strict=True)]
        amps = [m.amplitude_rad if m is not None else 0.0 for m in mods]
        for i, m in enumerate(mods):
            if m is None or m.order not in FLUCTUATION_ORDERS:
                continue
            others = max((a for k, a in enumerate(amps) if k != i), default=0.0)
            tested = m.order in KINEMATIC_ORDERS
            if (
                m.amplitude_rad / math.sqrt(2.0) > tolerance_rad
                and m.z >= MIN_Z
                and m.amplitude_rad >= (DOMINANCE_KINEMATIC if tested else DOMINANCE) * others
                and (best is None or m.amplitude_rad > best.amplitude_rad)
                and (not tested or kinematic(rds[i], m, mesh_orders))
            ):
                best = m
    return best


def with_angle_modulation(tr: SpeedTrack, mod: AngleModulation, delays: bool = True) -> SpeedTrack:
    """``tr`` with the order-locked modulation added: the angle ``theta + A cos(j r theta + phi)`` (0 at
    the first sample) and its derivative added to the speed (the track's own kernel cannot hold it);
    without ``delays`` the channels' path delays are set to zero (not identified where the speed the kernel
    follows does not vary: ``order_tracking.check_speed_variation``)."""
    arg = mod.order * mod.shaft_ratio * tr.angle_rad + mod.phase_rad
    delta = mod.amplitude_rad * np.cos(arg)
    w = tr.speed_rpm * math.pi / 30.0
    dw = -mod.amplitude_rad * mod.order * mod.shaft_ratio * np.sin(arg) * w
    return dataclasses.replace(
        tr,
        angle_rad=tr.angle_rad + delta - delta[0],
        speed_rpm=tr.speed_rpm + dw * 30.0 / math.pi,
        order_locked=mod,
        channel_delay_s=tr.channel_delay_s if delays else None,
    )


def without_angle_modulation(tr: SpeedTrack, mod: AngleModulation) -> SpeedTrack:
    """``tr`` (refined along an angle that holds ``mod``) less the modulation: the angle less
    ``A cos(j r theta + phi)`` and the speed of that angle (:func:`speed_of_angle`), so that the kernel's
    partial hold of the modulation leaves the speed too."""
    delta = mod.amplitude_rad * np.cos(mod.order * mod.shaft_ratio * tr.angle_rad + mod.phase_rad)
    theta = tr.angle_rad - delta + delta[0]
    fs = 1.0 / float(tr.t[1] - tr.t[0])
    return dataclasses.replace(
        tr, angle_rad=theta, speed_rpm=speed_of_angle(theta, fs, tr.kernel_s * fs), order_locked=None
    )
