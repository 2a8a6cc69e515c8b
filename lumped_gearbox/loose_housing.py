"""A loose bearing housing (mounting foot) at bearing 2: a support that lifts off, outside the FE library.

The kernel (``model._rhs``) and the output channels (``simulate.channels``) use it; it is off (exactly, by a
branch on ``F_LOOSE``) when the fault is absent, so that every record without it is unchanged bit for bit.

Support with a clearance and a bilinear stiffness (piecewise-linear looseness)
-----------------------------------------------------------------------------
The lumped pinion sits on an equivalent lateral spring, the shaft's bending ``k_s = 48 E I / L^3`` in series
with its two bearings in parallel: ``k_0 = (1/k_s + 1/(2 k_b))^-1`` (``params.springs``). Bearing 2's housing
stands on a foot whose bolts have worked loose (Muszynska and Goldman 1995, "Chaotic responses of unbalanced
rotor/bearing/stator systems with looseness or rubs"; Goldman and Muszynska 1991). Along the foot's lift
direction ``n`` (a fixed unit vector in the x-y plane) the housing is pressed onto its base as long as the
force bearing 2 pushes into it along ``n``, ``k_0 u / 2`` with ``u = n . d`` (``d``: the pinion's lateral
displacement; bearing 2 carries half the shaft's force), stays below the hold-down force ``P`` (``preload_n``:
the housing's weight and what is left of the bolt preload). Beyond the lift-off displacement
``u_l = 2 P / k_0`` the housing floats through the bolt clearance ``g`` (``clearance_m``): bearing 2 carries
no more of the increment along ``n`` and the pinion's stiffness there is ``k_f = (1/k_s + 1/k_b)^-1``;
beyond ``u_l + g`` the loose bolts catch it with ``(1 - loss) k_b`` (``stiffness_loss``), and the pinion's
stiffness is ``k_c = (1/k_s + 1/((2 - loss) k_b))^-1``. The restoring force along ``n`` is

    R(u) = k_0 u - D(u),
    D(u) = 0                                            u <= u_l
         = (k_0 - k_f) (u - u_l)                        u_l < u <= u_l + g
         = (k_0 - k_f) g + (k_0 - k_c) (u - u_l - g)    u > u_l + g,

continuous (so the fixed-step RK4 stays accurate) and unchanged across ``n``. The kernel adds ``D(u) n`` to
the pinion's lateral force. Bearing 2's force on the housing along ``n`` follows the changed load path: the
increment of ``R`` splits between the bearings by their stiffnesses, ``(1 - loss) / (2 - loss)`` to bearing 2
while the bolts hold it, nothing while it floats, so that it is ``k_0 u / 2 - H(u)`` with

    H(u) = 0                                            u <= u_l
         = k_0 (u - u_l) / 2                            u_l < u <= u_l + g
         = k_0 (u - u_l) / 2 - k_c s_2 (u - u_l - g)    u > u_l + g,    s_2 = (1 - loss) / (2 - loss).

A support that lifts off moves only under a load that lifts it: the static mesh load presses bearing 2
along the line of action and the mesh force stays on that line, so a foot is loosened by a rotating load.
The fault therefore carries the machine's residual unbalance on the pinion (``unbalance_kg_m``, the rotating
force ``U w^2``, as ``mass_unbalance`` at node 5) that drives it: the signature is the 1x of that force with
the harmonics of a response truncated on one side (2x, 4x, 6x: a half-wave bilinear response; Bently and Hatch
2002, Ch. 15) and, where the bolts catch it after the clearance, the odd orders too. The 1/2 x of a rattling
support did not appear at 3000 or 8000 rpm in this model (docs/independent_data.md).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def loose_relief(u: float, lift: float, gap: float, dk_free: float, dk_bolt: float) -> float:
    """The stiffness deficit ``D(u)`` along the lift direction (zero while the foot is down), N.

    Parameters
    ----------
    u : float
        The pinion's displacement along the lift direction ``n``, m.
    lift : float
        ``u_l = 2 P / k_0``, the displacement at which the foot lifts off, m.
    gap : float
        The bolt clearance ``g``, m.
    dk_free, dk_bolt : float
        ``k_0 - k_f`` and ``k_0 - k_c``, N/m.
    """
    w = u - lift
    if w <= 0.0:
        return 0.0
    if w <= gap:
        return dk_free * w
    return dk_free * gap + dk_bolt * (w - gap)


def stiffnesses(bending: float, k_bearing: float, loss: float) -> tuple[float, float, float]:
    """``k_0``, ``k_f`` and ``k_c`` of the module docstring, N/m.

    Parameters
    ----------
    bending : float
        The shaft's mid-span bending stiffness ``k_s``, N/m.
    k_bearing : float
        One bearing's radial stiffness ``k_b``, N/m.
    loss : float
        The loose bolts' stiffness loss (0: they hold the housing like the foot, 1: not at all).
    """
    k0 = 1.0 / (1.0 / bending + 1.0 / (2.0 * k_bearing))
    kf = 1.0 / (1.0 / bending + 1.0 / k_bearing)
    kc = 1.0 / (1.0 / bending + 1.0 / ((2.0 - loss) * k_bearing))
    return k0, kf, kc


def fault_terms(
    loss: float,
    clearance_m: float,
    preload_n: float,
    direction_rad: float,
    bending: float,
    k_bearing: float,
    sa: float,
    ca: float,
) -> tuple[float, float, float, float, float, float, float]:
    """The kernel's fault entries ``F_LOOSE .. F_LOOSE_SHARE`` (``model.py``).

    Parameters
    ----------
    loss, clearance_m, preload_n, direction_rad : float
        The fault's fields (``faults.LooseHousing``).
    bending, k_bearing : float
        ``k_s`` and ``k_b`` at the record's temperature and bearing stiffness, N/m.
    sa, ca : float
        ``sin`` and ``cos`` of the pressure angle: the line of action is ``(sa, ca)`` in the x-y plane.

    Returns
    -------
    tuple
        ``k_0 - k_f``, ``k_0 - k_c``, ``u_l``, ``g``, ``n_x``, ``n_y``, ``k_c s_2``.
    """
    k0, kf, kc = stiffnesses(bending, k_bearing, loss)
    c, s = math.cos(direction_rad), math.sin(direction_rad)
    nx, ny = c * ca + s * sa, -c * sa + s * ca  # cos * normal (ca, -sa) + sin * line of action (sa, ca)
    share = (1.0 - loss) / (2.0 - loss)
    return k0 - kf, k0 - kc, 2.0 * preload_n / k0, clearance_m, nx, ny, kc * share


def bearing_relief(u: np.ndarray, lift: float, gap: float, k0: float, kc_share: float) -> np.ndarray:
    """``H(u)``: what bearing 2 no longer passes into the housing along the lift direction, N (vectorised).

    Parameters
    ----------
    u : ndarray
        The pinion's displacement along the lift direction, m.
    lift, gap : float
        ``u_l`` and ``g``, m.
    k0, kc_share : float
        ``k_0`` and ``k_c s_2``, N/m.
    """
    w = np.maximum(u - lift, 0.0)
    return 0.5 * k0 * w - kc_share * np.maximum(w - gap, 0.0)
