"""Motion classification per speed: period-n, quasi-periodic or chaotic.

Criterion (documented in ``docs/analysis.md``)
----------------------------------------------
1. Take the Poincare samples (once per mesh period, after transients) of the DTE, optionally with
   the DTE velocity as a second coordinate. Scale each coordinate by the peak-to-peak range of that
   channel over the whole steady-state window (not just the section), and set the tolerance to
   ``rtol`` of it (default 0.2 %).
2. Cluster the scaled points (leader clustering, Chebyshev distance <= tol): ``n_distinct``.
3. The motion is *period-n* when the section sequence repeats with period ``n <= max_period``
   (``|p[k+n] - p[k]| <= tol`` for every k). ``n`` is the smallest such period; it equals
   ``n_distinct`` except when two section points coincide in the chosen coordinates.
4. Otherwise the Gottwald-Melbourne 0-1 test (correlation method, median over random
   frequencies ``c``) is applied to the DTE section: ``K >= k_chaos`` (default 0.5) is *chaotic*,
   ``K < k_chaos`` (the section is not a finite set but does not grow diffusively: points on a
   closed curve) is *quasi-periodic*.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

PERIODIC_PREFIX = "period-"
QUASI_PERIODIC = "quasi-periodic"
CHAOTIC = "chaotic"


def zero_one_test(
    phi: np.ndarray,
    n_c: int = 100,
    n_cut_fraction: float = 0.1,
    seed: int = 0,
) -> float:
    """Gottwald-Melbourne 0-1 test for chaos (correlation method), ``K`` in about [0, 1].

    Parameters
    ----------
    phi : numpy.ndarray
        Scalar observable sampled at a time step that is not much shorter than the system's
        correlation time (e.g. Poincare samples once per forcing period), length ``N`` (>= 100
        recommended; the spread of ``K`` shrinks like ``1/sqrt(N)``).
    n_c : int
        Number of random frequencies ``c`` drawn uniformly in ``(pi/5, 4 pi/5)`` (avoids the
        resonances at 0 and pi).
    n_cut_fraction : float
        Largest lag ``n_cut = n_cut_fraction * N`` of the mean-square displacement.
    seed : int
        Seed of the frequency draw (the result is deterministic).

    Returns
    -------
    float
        Median over ``c`` of the correlation between the lag ``n`` and the modified mean-square
        displacement ``D_c(n)``: near 0 for regular (periodic or quasi-periodic) dynamics, near 1
        for chaotic dynamics.

    References
    ----------
    G. A. Gottwald, I. Melbourne, "On the implementation of the 0-1 test for chaos", SIAM J. Appl.
    Dyn. Syst. 8 (2009) 129-145.
    """
    phi = np.asarray(phi, dtype=float)
    n_total = phi.size
    if phi.ndim != 1 or n_total < 20:
        raise ValueError(f"phi: a 1-D series of at least 20 samples is required, got shape {phi.shape}")
    if not np.all(np.isfinite(phi)):
        raise ValueError("phi: contains non-finite values")
    spread = np.ptp(phi)
    if spread == 0.0:
        return 0.0
    phi = (phi - phi.mean()) / spread
    rng = np.random.default_rng(seed)
    c = rng.uniform(np.pi / 5, 4 * np.pi / 5, n_c)
    j = np.arange(1, n_total + 1)
    arg = np.outer(c, j)
    p = np.cumsum(phi * np.cos(arg), axis=1)
    q = np.cumsum(phi * np.sin(arg), axis=1)
    n_cut = max(int(n_cut_fraction * n_total), 3)
    lags = np.arange(1, n_cut + 1)
    mean_phi = phi.mean()
    d = np.empty((n_c, n_cut))
    for i, n in enumerate(lags):
        dp = p[:, n:] - p[:, :-n]
        dq = q[:, n:] - q[:, :-n]
        m = np.mean(dp * dp + dq * dq, axis=1)
        v_osc = mean_phi**2 * (1.0 - np.cos(n * c)) / (1.0 - np.cos(c))
        d[:, i] = m - v_osc
    xi = lags - lags.mean()
    dd = d - d.mean(axis=1, keepdims=True)
    denom = np.sqrt(np.sum(xi * xi) * np.sum(dd * dd, axis=1))
    k = np.where(denom > 0, dd @ xi / np.where(denom > 0, denom, 1.0), 0.0)
    return float(np.median(k))


def cluster_count(points: np.ndarray, scale: np.ndarray | float, rtol: float) -> int:
    """Number of distinct points after leader clustering with a relative tolerance.

    Parameters
    ----------
    points : numpy.ndarray
        Shape ``(n,)`` or ``(n, d)``.
    scale : numpy.ndarray or float
        Per-coordinate scale (e.g. the signal's peak-to-peak range over the window).
    rtol : float
        Two points are the same when every scaled coordinate differs by at most ``rtol``.
    """
    pts = np.asarray(points, dtype=float)
    if pts.ndim == 1:
        pts = pts[:, None]
    s = np.broadcast_to(np.asarray(scale, dtype=float), (pts.shape[1],)).copy()
    s[s <= 0] = 1.0
    z = pts / s
    leaders: list[np.ndarray] = []
    for row in z:
        if not any(np.max(np.abs(row - ld)) <= rtol for ld in leaders):
            leaders.append(row)
    return len(leaders)


def sequence_period(points: np.ndarray, scale: np.ndarray | float, rtol: float, max_period: int) -> int:
    """Smallest ``n <= max_period`` with ``|p[k+n] - p[k]| <= rtol * scale`` for all k, or 0."""
    pts = np.asarray(points, dtype=float)
    if pts.ndim == 1:
        pts = pts[:, None]
    s = np.broadcast_to(np.asarray(scale, dtype=float), (pts.shape[1],)).copy()
    s[s <= 0] = 1.0
    z = pts / s
    for n in range(1, min(max_period, z.shape[0] - 1) + 1):
        if np.max(np.abs(z[n:] - z[:-n])) <= rtol:
            return n
    return 0


@dataclass(frozen=True)
class Motion:
    """Classification of one steady-state response.

    Attributes
    ----------
    label : str
        ``"period-n"``, ``"quasi-periodic"`` or ``"chaotic"``.
    period : int
        ``n`` for period-n, 0 otherwise.
    n_distinct : int
        Distinct Poincare points after clustering (capped by the number of samples).
    k : float
        0-1 test statistic (NaN when the motion is periodic and the test was not needed).
    """

    label: str
    period: int
    n_distinct: int
    k: float


def classify_motion(
    section: np.ndarray,
    scale: np.ndarray | float | None = None,
    rtol: float = 2e-3,
    max_period: int = 8,
    k_chaos: float = 0.5,
) -> Motion:
    """Classify a steady-state response from its Poincare section.

    Parameters
    ----------
    section : numpy.ndarray
        Poincare samples, shape ``(n,)`` (DTE) or ``(n, d)`` (DTE first, e.g. DTE and its
        velocity). The 0-1 test uses the first coordinate.
    scale : numpy.ndarray or float, optional
        Per-coordinate range of the channel over the whole steady-state window; defaults to the
        range of the section itself (then a constant section is period-1).
    rtol : float
        Tolerance relative to ``scale`` for "the same point".
    max_period : int
        Largest period reported as period-n; longer periods count as non-periodic.
    k_chaos : float
        0-1 test threshold between quasi-periodic and chaotic.
    """
    pts = np.asarray(section, dtype=float)
    if pts.ndim == 1:
        pts = pts[:, None]
    if pts.shape[0] < 2 * max_period + 2:
        raise ValueError(f"section: need at least {2 * max_period + 2} points, got {pts.shape[0]}")
    if not np.all(np.isfinite(pts)):
        raise ValueError("section: contains non-finite values")
    if scale is None:
        scale = np.ptp(pts, axis=0)
    s = np.broadcast_to(np.asarray(scale, dtype=float), (pts.shape[1],)).copy()
    if np.all(s <= 0):
        return Motion(f"{PERIODIC_PREFIX}1", 1, 1, float("nan"))
    n_distinct = cluster_count(pts[: 4 * max_period + 64], s, rtol)
    period = sequence_period(pts, s, rtol, max_period)
    if period:
        return Motion(f"{PERIODIC_PREFIX}{period}", period, n_distinct, float("nan"))
    k = zero_one_test(pts[:, 0]) if pts.shape[0] >= 20 else float("nan")
    label = CHAOTIC if k >= k_chaos else QUASI_PERIODIC
    return Motion(label, 0, n_distinct, k)


def motion_windows(speeds_rpm: np.ndarray, labels: list[str] | np.ndarray) -> list[tuple[str, float, float]]:
    """Contiguous speed windows of one motion label: ``[(label, first_rpm, last_rpm), ...]``."""
    out: list[tuple[str, float, float]] = []
    for s, lab in zip(np.asarray(speeds_rpm, dtype=float), labels, strict=True):
        lab = str(lab)
        if out and out[-1][0] == lab:
            out[-1] = (lab, out[-1][1], float(s))
        else:
            out.append((lab, float(s), float(s)))
    return out


def chaotic_windows(
    speeds_rpm: np.ndarray, labels: list[str] | np.ndarray, min_width_rpm: float = 0.0, merge_gap: int = 1
) -> list[tuple[float, float]]:
    """Speed ranges classified chaotic, merging runs separated by at most ``merge_gap`` other speeds.

    Parameters
    ----------
    speeds_rpm : numpy.ndarray
        Increasing speeds.
    labels : list of str
        Label per speed.
    min_width_rpm : float
        Drop merged windows narrower than this.
    merge_gap : int
        Non-chaotic speeds allowed inside one window (isolated periodic windows of one grid point).
    """
    speeds = np.asarray(speeds_rpm, dtype=float)
    idx = [i for i, lab in enumerate(labels) if str(lab) == CHAOTIC]
    windows: list[list[int]] = []
    for i in idx:
        if windows and i - windows[-1][1] <= merge_gap + 1:
            windows[-1][1] = i
        else:
            windows.append([i, i])
    return [
        (float(speeds[a]), float(speeds[b])) for a, b in windows if speeds[b] - speeds[a] >= min_width_rpm
    ]
