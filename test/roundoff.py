"""Round-off bounds for the tests: tolerances scaled to the magnitude of what they compare.

A floating-point result carries an error of a few units in the last place of the *largest* quantity
that went into it, not of the result itself: the smallest eigenvalue of a positive semi-definite
stiffness matrix whose entries reach 1e10 is only known to about ``n eps ||K||``, and a force that
sums to zero from terms of 1e3 N is zero only to about ``eps 1e3``. The helpers below turn that into
tolerances, so that a test passes on any CPU, BLAS, thread count or instruction set (the order of the
floating-point operations differs between them) and still fails on a real error, which is many
orders of magnitude larger than round-off.

``SAFETY`` covers the constant of the standard error bounds (Higham, *Accuracy and Stability of
Numerical Algorithms*, 2nd ed., 2002: ``|fl(x^T y) - x^T y| <= n u |x|^T |y|``, Thm 3.1/3.5; the
eigenvalues of a symmetric matrix from a backward-stable solver within ``p(n) u ||A||_2``, Sec 7.7).
"""

from __future__ import annotations

import numpy as np

#: Unit round-off of float64 (2.2e-16).
EPS = float(np.finfo(np.float64).eps)
#: Margin over the leading-order bound (the growth constants of the bounds are not sharp).
SAFETY = 100.0


def roundoff(scale: float, n: int = 1) -> float:
    """Round-off of a result built from ``n`` operations on quantities of magnitude ``scale``.

    Returns ``SAFETY * n * EPS * |scale|`` (>= the smallest normal number, so a zero scale still
    admits an exact zero compared with ``<=``).
    """
    return max(SAFETY * max(int(n), 1) * EPS * abs(float(scale)), float(np.finfo(np.float64).tiny))


def matrix_roundoff(a: np.ndarray) -> float:
    """Round-off of an eigenvalue, or of a matrix product entry, of the square matrix ``a``.

    ``SAFETY n eps ||a||_2`` (``||a||_2`` bounded by the Frobenius norm), the backward error of a
    stable symmetric eigensolver (Higham 2002, Sec 7.7).
    """
    a = np.asarray(a, dtype=float)
    return roundoff(float(np.linalg.norm(a)), a.shape[0])


def assert_psd(a: np.ndarray, what: str = "matrix") -> None:
    """Assert that the symmetric ``a`` is positive semi-definite up to its own round-off."""
    a = np.asarray(a, dtype=float)
    low = float(np.linalg.eigvalsh(a).min())
    tol = matrix_roundoff(a)
    assert low >= -tol, f"{what}: smallest eigenvalue {low:.3e} < -{tol:.3e} (round-off bound)"


def assert_symmetric(a: np.ndarray, what: str = "matrix") -> None:
    """Assert ``a == a.T`` up to the round-off of its largest entry."""
    a = np.asarray(a, dtype=float)
    err = float(np.abs(a - a.T).max())
    tol = roundoff(float(np.abs(a).max()), a.shape[0])
    assert err <= tol, f"{what}: asymmetry {err:.3e} > {tol:.3e} (round-off bound)"


def assert_zero(value: np.ndarray | float, scale: float, n: int = 1, what: str = "value") -> None:
    """Assert ``|value| <= roundoff(scale, n)``: a quantity that cancels from terms of size ``scale``."""
    err = float(np.max(np.abs(np.asarray(value, dtype=float))))
    tol = roundoff(scale, n)
    assert err <= tol, f"{what}: {err:.3e} exceeds the round-off {tol:.3e} of terms of size {scale:.3e}"
