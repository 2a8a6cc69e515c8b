"""The axial mesh force of a misaligned gear from the instantaneous mesh force (a fixed-point pass).

A wheel whose tooth lines are tilted by ``gamma(t) = angle cos(theta + phi)`` against the mating
wheel's turns the contact normal out of the transverse plane: the normal tooth force ``F(t)`` gets
the axial component ``F(t) gamma(t)`` on both wheels (opposite). At order 0 of ``F`` (the static
mesh force ``F0 = T / r_b``) that is the wheel's order 1 in the axial bearing forces; the mesh
harmonics of ``F`` add the sidebands ``m z +- 1`` of the wheel's orders (``z`` its teeth), as strong
as those harmonics are relative to ``F0`` (in contact a few percent; where the teeth separate, of the
order of ``F0``).

An effect's force amplitudes are set before each integration step from the kinematics
(``docs/design.md``, "Effects"), not from the state, so ``F(t)`` cannot enter directly. It enters
as the previous run's mesh force: run the model, take the part of the mesh force synchronous with the
tilted wheel (its order coefficients over that wheel's revolution, :func:`wheel_orders`), hand them to
the effect (``GearMisalignment.mesh_force_orders``) and run again. The axial force acts on the axial
degrees of freedom of the two wheels, which the spur mesh (its line of action in the transverse
plane) does not see: the second run's mesh force equals the first's, and the fixed point is reached
in one pass (measured in ``test/test_misalignment_force.py``). Parts of ``F`` not synchronous with the
tilted wheel (the other wheel's orders, at rattle the non-periodic rest) are left out: ``gamma`` is
synchronous with that wheel, so only ``F``'s synchronous part gives lines in its synchronous average.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from collections import OrderedDict
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from gear_rotor_sim.faults.gear import GearMisalignment

#: highest order kept: below this fraction of the output rate (the simulator's decimation passband
#: edge, ``solver/decimate.py``), where the output holds the mesh force without attenuation
PASSBAND_FRACTION = 0.4

#: :func:`wheel_orders` results by the digest of their inputs. The calibration runs a misaligned wheel
#: at several angles and on several candidates against one mesh-force run (``calibration/
#: model_misalignment.py``), and each pass solved the same least squares again: at 1500 rpm 18 solves
#: of 39200 x 641 (pinion) or x 1081 (gear) systems, 173 of the 336 s (profiled) of the held-out healthy
#: 1500 rpm record (docs/history/calibration_sessions.md Sec. 8.39). A hit returns a copy of the stored
#: solution, so the result is the one computed first.
_ORDERS: OrderedDict[bytes, np.ndarray] = OrderedDict()
_ORDERS_MAX = 16

#: the normal equations (:func:`_orders_by_normal_equations`) are used up to this bound on the Gram
#: matrix's condition number (Gershgorin), else the SVD least squares
MAX_GRAM_COND = 4.0

#: largest phase (rad) at the highest order by which the sample times may miss a uniform grid for the
#: normal equations' block sums (:func:`order_sums`)
PHASE_TOL = 1e-9


def mesh_force_channel(cfg: Any, mesh: int) -> str:
    """Simulator channel of the 1-based ``mesh``'s force: ``mesh_force`` on a single-mesh rig, else
    ``mesh<k>_force``."""
    return "mesh_force" if len(cfg.meshes) == 1 else f"mesh{mesh}_force"


def wheel_hz(cfg: Any, effect: GearMisalignment, speed_rpm: float) -> float:
    """Signed rotation frequency (Hz) of the tilted wheel's shaft at the input speed ``speed_rpm``
    (the sign of its shaft angle, ``shaft_speed_ratios``)."""
    from gear_rotor_sim.system import shaft_speed_ratios

    m = cfg.meshes[effect.mesh - 1]
    member = m.pinion if effect.member == "pinion" else m.gear
    shaft = cfg.shaft_of_node(cfg.gear(member).node0)
    return float(shaft_speed_ratios(cfg)[shaft]) * speed_rpm / 60.0


def wheel_orders(t: np.ndarray, force: np.ndarray, shaft_hz: float, max_order: int) -> np.ndarray:
    """Order coefficients ``c_0 .. c_K`` of ``force`` over the revolution of a shaft turning at
    ``shaft_hz`` (signed; angle ``2 pi shaft_hz t``), by least squares on the samples.

    ``force(t) ~ Re c_0 + 2 sum_k Re(c_k e^{i k theta(t)})``: ``|c_k|`` is half the peak amplitude of
    order ``k`` (the convention of ``calibration.residual.order_coefficients``). Over whole hunting
    periods of a mesh the other wheel's orders are orthogonal to these and drop out.

    Parameters
    ----------
    t : numpy.ndarray
        Sample times, s (n,).
    force : numpy.ndarray
        Mesh force, N (n,).
    shaft_hz : float
        Signed rotation frequency of the shaft, Hz (nonzero).
    max_order : int
        Highest order ``K`` (>= 0); at most ``(n - 1) / 2``.

    Returns
    -------
    numpy.ndarray
        Complex (K + 1,).
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(force, dtype=float)
    if t.shape != x.shape or t.ndim != 1:
        raise ValueError(f"t, force: shapes {t.shape} and {x.shape} must be equal and 1-D")
    if not (np.isfinite(shaft_hz) and shaft_hz != 0.0):
        raise ValueError(f"shaft_hz: {shaft_hz!r} must be finite and nonzero")
    if not 0 <= max_order <= (t.size - 1) // 2:
        raise ValueError(f"max_order: {max_order} must be in [0, {(t.size - 1) // 2}] for {t.size} samples")
    h = hashlib.blake2b(f"{t.size},{float(shaft_hz)!r},{int(max_order)}".encode(), digest_size=20)
    h.update(np.ascontiguousarray(t))
    h.update(np.ascontiguousarray(x))
    key = h.digest()
    hit = _ORDERS.get(key)
    if hit is not None:
        _ORDERS.move_to_end(key)
        return hit.copy()
    coef = _orders_by_normal_equations(t, x, shaft_hz, max_order)
    if coef is None:
        coef = _orders_by_least_squares(t, x, shaft_hz, max_order)
    _ORDERS[key] = coef.copy()
    if len(_ORDERS) > _ORDERS_MAX:
        _ORDERS.popitem(last=False)
    return coef


def _orders_by_least_squares(t: np.ndarray, x: np.ndarray, shaft_hz: float, max_order: int) -> np.ndarray:
    """:func:`wheel_orders` by ``numpy.linalg.lstsq`` (SVD) on the real design matrix ``[1, cos k theta,
    -sin k theta]`` (n, 2 K + 1): any sample times, any conditioning."""
    theta = 2.0 * np.pi * shaft_hz * t
    k = np.arange(1, max_order + 1)
    a = np.empty((t.size, 1 + 2 * max_order))
    a[:, 0] = 1.0
    a[:, 1::2] = np.cos(np.outer(theta, k))
    a[:, 2::2] = -np.sin(np.outer(theta, k))
    sol, *_ = np.linalg.lstsq(a, x, rcond=None)
    coef = np.empty(max_order + 1, dtype=complex)
    coef[0] = sol[0]
    coef[1:] = 0.5 * (sol[1::2] + 1j * sol[2::2])
    return coef


def order_sums(x: np.ndarray, theta0: float, step: float, orders: np.ndarray) -> np.ndarray:
    """``sum_n x_n exp(-i k (theta0 + n step))`` for each ``k`` of ``orders``: the DTFT of uniform samples
    at the orders of an angle that advances ``step`` per sample.

    Summed in blocks ``n = p L + q`` (``L ~ sqrt(n)``): ``e^{-i k (theta0 + p L step)} sum_q x_{pL+q}
    e^{-i k q step}``, one matrix product of ``(K, L)`` phasors with the ``(L, P)`` samples; ``K (L + P)``
    complex exponentials instead of the ``K n`` of the direct sum (the same sum, to rounding).

    Parameters
    ----------
    x : numpy.ndarray
        Real samples (n,).
    theta0 : float
        Angle at the first sample, rad.
    step : float
        Angle per sample, rad.
    orders : numpy.ndarray
        Orders ``k`` (K,).

    Returns
    -------
    numpy.ndarray
        Complex (K,).
    """
    x = np.asarray(x, dtype=float)
    k = np.asarray(orders, dtype=float)
    n = x.size
    blk = max(1, math.isqrt(max(n - 1, 0)) + 1)
    n_blk = -(-n // blk)
    xs = np.zeros(n_blk * blk)
    xs[:n] = x
    xs = xs.reshape(n_blk, blk).T  # (L, P): xs[q, p] = x[p L + q]
    inner = np.outer(k, step * np.arange(blk))
    part = np.cos(inner) @ xs - 1j * (np.sin(inner) @ xs)  # (K, P)
    outer = np.exp(-1j * np.outer(k, theta0 + step * blk * np.arange(n_blk)))
    return np.sum(outer * part, axis=1)


def _orders_by_normal_equations(
    t: np.ndarray, x: np.ndarray, shaft_hz: float, max_order: int
) -> np.ndarray | None:
    """:func:`wheel_orders` by the normal equations in the complex basis ``e^{i k theta}``, ``|k| <= K``,
    where they are safe; ``None`` where not (the caller solves by least squares).

    For real samples the least-squares coefficients ``c_k`` of ``sum_k c_k e^{i k theta}`` are conjugate
    symmetric and equal those of the real basis (``c_k`` for ``k >= 0`` is :func:`wheel_orders`' result).
    The Gram matrix ``G_jk = sum_n e^{i (k - j) theta_n}`` is Hermitian Toeplitz: ``4 K + 1`` sums
    (:func:`order_sums` of ones), the right-hand side ``K + 1`` more (of the samples, the other half by
    symmetry). Used where the times are uniform (the phase of order ``K`` within ``PHASE_TOL`` rad of the
    uniform grid's) and Gershgorin's bound on the Gram matrix's condition number, ``(1 + r) / (1 - r)`` with
    ``r`` the largest off-diagonal row sum over the diagonal ``n``, is at most ``MAX_GRAM_COND``: over whole
    revolutions of the wheel the basis is orthogonal but for the window's rounding to a sample (the
    calibration's mesh-force runs, ``r`` a few percent). Normal equations lose ``cond(G) eps`` relative to
    the coefficients' norm, an SVD ``cond(A) eps``; both are rounding at these bounds.
    """
    import scipy.linalg

    n, kk = t.size, max_order
    if n < 2:
        return None
    dt = (t[-1] - t[0]) / (n - 1)
    w = 2.0 * np.pi * shaft_hz
    dev = float(np.max(np.abs(t - (t[0] + dt * np.arange(n)))))
    # the Gram matrix holds the orders up to 2 K
    if not dt > 0.0 or abs(w) * 2 * max(kk, 1) * dev > PHASE_TOL:
        return None
    theta0, step = w * t[0], w * dt
    s_neg = order_sums(np.ones(n), theta0, step, np.arange(2 * kk + 1))  # sum e^{-i m theta}, m = 0..2K
    lags = np.arange(-2 * kk, 2 * kk + 1)
    s_pos = np.where(lags >= 0, np.conj(s_neg[np.abs(lags)]), s_neg[np.abs(lags)])  # sum e^{+i m theta}
    idx = np.arange(-kk, kk + 1)
    # row j of G holds the lags k - j, k = -K..K: its off-diagonal sum from a running sum of |G| by lag
    run = np.concatenate([[0.0], np.cumsum(np.abs(s_pos))])
    rows = run[idx[::-1] + 3 * kk + 1] - run[idx[::-1] + kk] - n
    r = float(np.max(rows)) / n
    if r >= 1.0 or (1.0 + r) / (1.0 - r) > MAX_GRAM_COND:
        return None
    gram = s_pos[(idx[None, :] - idx[:, None]) + 2 * kk]  # G_jk = sum e^{i (k - j) theta}
    b_half = order_sums(x, theta0, step, np.arange(kk + 1))  # sum x e^{-i k theta}, k = 0..K
    rhs = np.concatenate([np.conj(b_half[:0:-1]), b_half])  # k = -K..K
    c = scipy.linalg.cho_solve(scipy.linalg.cho_factor(gram), rhs)
    coef = 0.5 * (c[kk:] + np.conj(c[kk::-1]))
    return coef


def max_wheel_order(shaft_hz: float, output_rate_hz: float) -> int:
    """Highest order of a shaft at ``|shaft_hz|`` inside the output's passband
    (``PASSBAND_FRACTION`` of the output rate)."""
    return max(0, int(np.floor(PASSBAND_FRACTION * output_rate_hz / abs(shaft_hz))))


def needs_mesh_force(effects: Sequence[object]) -> bool:
    """Whether any effect is a gear misalignment with a tilt and no mesh-force orders yet."""
    return any(
        isinstance(e, GearMisalignment) and e.angle_rad > 0 and not e.mesh_force_orders for e in effects
    )


def with_mesh_force(
    cfg: Any,
    effects: Sequence[object],
    speed_rpm: float,
    output_rate_hz: float,
    mesh_force: Callable[[Sequence[object], list[str]], tuple[np.ndarray, np.ndarray]],
) -> tuple[object, ...]:
    """``effects`` with every tilted gear misalignment's axial force following the mesh force.

    Parameters
    ----------
    cfg : RigConfig
        The rig.
    effects : sequence
        Effects of the run (others are returned unchanged).
    speed_rpm : float
        Input speed of the run (constant).
    output_rate_hz : float
        Output rate of ``mesh_force``'s samples.
    mesh_force : callable
        ``(effects, channels) -> (t, forces)``: runs the model with ``effects`` and returns the sample
        times (n,) in s of the model clock (shaft angles zero at time 0) and the ``channels``' mesh
        forces (n, len(channels)) in N, over whole hunting periods of the mesh in its steady state.

    Returns
    -------
    tuple
        The effects, each tilted ``GearMisalignment`` with ``mesh_force_orders`` from the run.
    """
    effects = tuple(effects)
    if not needs_mesh_force(effects):
        return effects
    mis = [i for i, e in enumerate(effects) if isinstance(e, GearMisalignment) and e.angle_rad > 0]
    channels = list(dict.fromkeys(mesh_force_channel(cfg, effects[i].mesh) for i in mis))  # type: ignore[attr-defined]
    t, forces = mesh_force(effects, channels)
    forces = np.asarray(forces, dtype=float).reshape(t.size, len(channels))
    out = list(effects)
    for i in mis:
        e = effects[i]
        assert isinstance(e, GearMisalignment)
        f_s = wheel_hz(cfg, e, speed_rpm)
        kmax = min(max_wheel_order(f_s, output_rate_hz), (t.size - 1) // 2)
        col = channels.index(mesh_force_channel(cfg, e.mesh))
        coef = wheel_orders(t, forces[:, col], f_s, kmax)
        out[i] = dataclasses.replace(e, mesh_force_orders=tuple(complex(c) for c in coef))
    return tuple(out)


def simulate_mesh_force(
    cfg: Any,
    speed_rpm: float,
    temperature_c: float,
    output_rate_hz: float = 20000.0,
    steps_per_mesh: int = 32,
    settle_s: float = 0.2,
    min_window_s: float = 0.3,
    system_builder: Callable[..., Any] | None = None,
) -> Callable[[Sequence[object], list[str]], tuple[np.ndarray, np.ndarray]]:
    """A ``mesh_force`` runner for :func:`with_mesh_force` on a plain :class:`Simulator`: ``settle_s``
    from static equilibrium discarded, then whole hunting periods of the mesh lasting at least
    ``min_window_s`` (whole revolutions of the slowest shaft on a rig with several meshes)."""
    from gear_rotor_sim.simulator import Simulator
    from gear_rotor_sim.system import shaft_rates_hz

    def run(effects: Sequence[object], channels: list[str]) -> tuple[np.ndarray, np.ndarray]:
        slowest = min(f for f in shaft_rates_hz(cfg, speed_rpm) if f != 0)
        period = 1.0 / slowest
        if len(cfg.meshes) == 1:
            m = cfg.meshes[0]
            zp, zg = int(m.pinion_teeth), int(m.gear_teeth)
            period = math.lcm(zp, zg) / zp / abs(wheel_hz(cfg, GearMisalignment(member="pinion"), speed_rpm))
        n_per = max(1, int(np.ceil(min_window_s / period - 1e-9)))
        n = round(n_per * period * output_rate_hz)
        kwargs = {"system_builder": system_builder} if system_builder is not None else {}
        sim = Simulator(
            cfg,
            speed_rpm=speed_rpm,
            temperature_c=temperature_c,
            output_rate_hz=output_rate_hz,
            channels=channels,
            steps_per_mesh=steps_per_mesh,
            effects=tuple(effects),  # type: ignore[arg-type]
            event_average=False,  # as the calibration's model runs (residual.ModelRunner)
            streamed_misalignment=False,  # the mesh force alone is read
            **kwargs,
        )
        i0 = round(settle_s * output_rate_hz)
        sim.advance(i0 / output_rate_hz)
        blk = sim.advance(n / output_rate_hz)
        data = np.asarray(blk.data)[:n]
        t = (blk.first_index + np.arange(data.shape[0])) / output_rate_hz
        return t, data

    return run
