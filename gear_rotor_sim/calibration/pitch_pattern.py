"""Each wheel's pitch deviations read from the DTE's synchronous average (issue 11;
docs/history/calibration_sessions.md Sec. 8.68).

A flank ``p_j`` ahead of nominal lowers the transmission error by ``p_j`` times its pair's share of the
mesh stiffness while tooth ``j`` is engaged (``faults/pitch.py``): below the mesh-coupled modes the DTE's
synchronous average over one revolution of a wheel with ``z`` teeth holds

    a(theta) = -sum_j p_j lambda(z theta / 2 pi - j),      A(k) = -S(k) sum_j p_j exp(-2 pi i k j / z)

at its order ``k`` (``S`` the Fourier coefficient of one pair's share over its engagement,
:func:`share_spectrum`; theta the wheel's absolute angle). The other wheel's deviations are periodic in
its own revolution and leave this average except at the mesh carriers (``z_p``, ``z_g`` coprime): the
non-carrier orders of each wheel's average carry that wheel's pattern alone. :func:`fit_wheel_pattern`
solves for the flank positions by least squares over the orders ``1 .. ORDER_SPAN z`` that are not mesh
carriers (each per-tooth harmonic ``m`` is seen at the orders ``m``, ``z - m``, ``z + m``, ...).

What is not read: a common offset of the wheel's flanks (the carriers: the DTE's mean). The pattern's
harmonics ``m = 1 .. LONG_WAVE`` (the orders 1-2 and their mesh sidebands) are what an eccentricity and a
misalignment put there too, which the library fits as effects: the statistics that decide whether a wheel
has a pattern are taken without them (``long_wave=False``), and they are read only where no such effect of
that wheel was found (``pitch_baseline.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gear_rotor_sim.calibration.order_dft import revolution_coefficients

#: orders used, up to ``ORDER_SPAN`` times the wheel's teeth (the first carrier's sidebands both sides).
#: Measured on the independent gearbox's healthy quality-7 record (3000 rpm, 2 s): the flank positions read
#: within 25 % RMS of the truth at 2.0 (pinion / gear 0.249 / 0.249 of its RMS, scale 1.10 / 1.11), 0.355 /
#: 0.326 at 1.0, 0.22 / 0.23 at 3.0
ORDER_SPAN = 2.0
#: per-tooth harmonics ``1 .. LONG_WAVE`` left to the eccentricity and misalignment effects
LONG_WAVE = 2


def share_spectrum(orders: np.ndarray, teeth: int, contact_ratio: float) -> np.ndarray:
    """Fourier coefficient at the wheel's ``orders`` of one pair's share of the mesh stiffness over one
    revolution, the pair entering at angle 0: ``S(k) = (1/z) int_0^eps lambda(s) exp(-2 pi i k s / z) ds``
    with the share ``lambda`` of :func:`~gear_rotor_sim.faults.gear.tooth_share` (1/2, 1, 1/2)."""
    eps = float(np.clip(contact_ratio, 1.0, 2.0))
    k = np.asarray(orders, dtype=float)
    w = 2.0 * math.pi * k / teeth
    out = np.zeros(k.shape, dtype=complex)
    for a, b, h in ((0.0, eps - 1.0, 0.5), (eps - 1.0, 1.0, 1.0), (1.0, eps, 0.5)):
        with np.errstate(invalid="ignore", divide="ignore"):
            seg = (np.exp(-1j * w * a) - np.exp(-1j * w * b)) / (1j * w)
        out += h * np.where(w == 0.0, b - a, seg)
    return out / teeth


def wheel_orders(
    x: np.ndarray, fs: float, shaft_hz: float, t_first: float, orders: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Synchronous-average coefficients of ``x`` at ``orders`` of a shaft, referenced to its absolute angle
    ``2 pi shaft_hz t`` (``t_first`` the time of the first sample), and each one's noise variance
    (between-revolution scatter over the number of revolutions)."""
    xs = np.asarray(x, dtype=float)
    per = revolution_coefficients(xs - np.mean(xs), fs, shaft_hz, orders)
    per = per * np.exp(-2j * math.pi * np.asarray(orders, dtype=float) * shaft_hz * t_first)[None, :]
    n_rev = per.shape[0]
    var = np.sum(np.abs(per - per.mean(axis=0)) ** 2, axis=0) / max(n_rev - 1, 1) / max(n_rev, 1)
    return per.mean(axis=0), var


@dataclass
class WheelPattern:
    """One wheel's flank positions read from an average (:func:`fit_wheel_pattern`).

    Attributes
    ----------
    positions_m : numpy.ndarray
        Flank positions of the ``z`` teeth (0-based), m, mean zero, without the long-wave part.
    se_m : float
        Standard error of one tooth's position from the coefficients' noise, m.
    significance : float
        The fitted pattern's energy at the orders used over the energy its noise alone would give there
        plus ``floor_energy`` (1: noise; chi^2 of the fit's improvement over its degrees of freedom).
    explained : float
        Share of the average's energy at the orders used (noise removed) that the pattern reproduces.
    """

    positions_m: np.ndarray
    se_m: float
    significance: float
    explained: float
    energy: float = 0.0


def pattern_basis(teeth: int, long_wave: bool = False) -> np.ndarray:
    """Real basis (z, n) of the per-tooth patterns read: the harmonics ``LONG_WAVE + 1 .. z / 2`` of the
    tooth index (from 1 with ``long_wave``; cos and sin, the sin of ``z / 2`` is zero for even ``z`` and left
    out)."""
    j = np.arange(teeth)
    cols = []
    for m in range(1 if long_wave else LONG_WAVE + 1, teeth // 2 + 1):
        cols.append(np.cos(2.0 * math.pi * m * j / teeth))
        if 2 * m != teeth:
            cols.append(np.sin(2.0 * math.pi * m * j / teeth))
    return np.column_stack(cols)


def pattern_orders(teeth: int) -> np.ndarray:
    """The wheel's orders read: ``1 .. ORDER_SPAN z`` without the mesh carriers."""
    k = np.arange(1, int(ORDER_SPAN * teeth) + 1)
    return k[k % teeth != 0]


def pattern_response(orders: np.ndarray, teeth: int, contact_ratio: float) -> np.ndarray:
    """``(n_orders, z)`` complex: the average's coefficient at each order per metre of each tooth's flank
    (``-S(k) exp(-2 pi i k j / z)``)."""
    j = np.arange(teeth)
    s = share_spectrum(orders, teeth, contact_ratio)
    return -s[:, None] * np.exp(-2j * math.pi * np.outer(orders, j) / teeth)


def fit_wheel_pattern(
    coef: np.ndarray,
    var: np.ndarray,
    teeth: int,
    contact_ratio: float,
    fixed: tuple[int, ...] = (),
    long_wave: bool = False,
    floor_energy: float = 0.0,
) -> WheelPattern:
    """Least-squares flank positions from the average's coefficients at :func:`pattern_orders`.

    Parameters
    ----------
    coef, var : numpy.ndarray
        Coefficients (absolute angle) and their noise variances at ``pattern_orders(teeth)``
        (:func:`wheel_orders`); model minus record or record alone.
    teeth : int
        The wheel's teeth.
    contact_ratio : float
        The mesh's contact ratio (the share's shape).
    fixed : tuple of int
        0-based teeth whose position is held at the pattern's mean (zero): a damaged tooth named by the
        diagnosis owns its own slot (``pitch_baseline.py``).
    long_wave : bool
        Also the harmonics ``1 .. LONG_WAVE`` of the tooth index (:func:`pattern_basis`).
    floor_energy : float
        Energy added to the noise's in the significance (the healthy model's own content there: the
        integration's numerical lines at the shaft orders, ``pitch_baseline.read_wheels``).
    """
    orders = pattern_orders(teeth)
    basis = pattern_basis(teeth, long_wave)
    if fixed:
        # the patterns of the basis that are zero at the fixed teeth (null space of those rows)
        rows = basis[list(fixed)]
        _, sv, vt = np.linalg.svd(rows)
        rank = int(np.sum(sv > 1e-9 * sv.max()))
        basis = basis @ vt[rank:].T
    g = pattern_response(orders, teeth, contact_ratio) @ basis  # (n_orders, n_basis) complex
    a = np.vstack([g.real, g.imag])
    y = np.concatenate([coef.real, coef.imag])
    c, *_ = np.linalg.lstsq(a, y, rcond=None)
    fitted = a @ c
    noise = float(np.sum(var))  # expected |noise|^2 summed over the orders (real + imaginary)
    n_par = basis.shape[1]
    # the fit's energy against the energy the noise alone puts into n_par of the 2 n_orders directions
    energy = float(np.sum(fitted**2))
    significance = energy / max(noise * n_par / (2 * orders.size) + floor_energy, 1e-300)
    total = max(float(np.sum(y**2)) - noise, 1e-300)
    left = max(float(np.sum((y - fitted) ** 2)) - noise * (1.0 - n_par / (2 * orders.size)), 0.0)
    explained = max(0.0, 1.0 - left / total)
    gram = np.linalg.inv(a.T @ a)
    per_coef = noise / (2 * orders.size)
    cov = basis @ gram @ basis.T * per_coef
    se = float(math.sqrt(max(np.mean(np.diag(cov)), 0.0)))
    return WheelPattern(basis @ c, se, significance, explained, energy)


#: teeth either side of the largest flank counted as its neighbourhood in :func:`spread`
SPREAD_NEIGHBOURS = 2


def spread(positions: np.ndarray) -> float:
    """Share of a pattern's energy (sum of squared positions) away from its largest flank (more than
    ``SPREAD_NEIGHBOURS`` teeth from it): a single damaged tooth read as flank positions leaves its pulse's
    shape on its neighbours and little beyond (0.08 for a depth-0.4 pinion tooth of the independent gearbox
    with exact teeth), random pitch deviations about ``1 - 5 / z`` of it."""
    p = np.asarray(positions, dtype=float)
    z = p.size
    total = float(np.sum(p**2))
    if z == 0 or total <= 0.0:
        return 0.0
    j = int(np.argmax(np.abs(p)))
    dist = np.abs((np.arange(z) - j + z // 2) % z - z // 2)
    return float(np.sum(p[dist > SPREAD_NEIGHBOURS] ** 2)) / total


def high_harmonic_share(positions: np.ndarray) -> float:
    """Share of a pattern's energy (per-tooth harmonics from ``LONG_WAVE + 1``) in the harmonics above a
    quarter of the teeth: random flank positions spread their energy evenly over the harmonics (about 0.6 of
    it lies there for 29 or 49 teeth), a misaligned wheel's even orders and a crack's shaft harmonics lie
    low."""
    p = np.asarray(positions, dtype=float)
    z = p.size
    power = np.abs(np.fft.rfft(p)) ** 2
    m = np.arange(power.size)
    used = m > LONG_WAVE
    total = float(np.sum(power[used]))
    return float(np.sum(power[used & (m > z / 4.0)])) / total if total > 0 else 0.0
