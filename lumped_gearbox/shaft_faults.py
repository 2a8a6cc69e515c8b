"""Faults that the FE effect library does not model: a breathing shaft crack and a Cardan joint at the input.

Both are used by the kernel (``model._rhs``) and by the output channels (``simulate.channels``); they are
off (exactly, by a branch) when their severity is zero, so that every record without them is unchanged
bit for bit.

Breathing transverse crack (switching crack, Gasch 1976, 1993)
-------------------------------------------------------------
A transverse crack in a rotating shaft opens while the bending stress at its mouth is tensile and closes
while it is compressive. The lumped shaft is an equivalent lateral spring ``k`` between the bearings and
the wheel (pinned beam, load at mid-span): the fibres on the side towards which the wheel is deflected
(``d = (x, y)``) are in tension, so a crack whose mouth points along the unit vector ``n`` (rotating with
the shaft, ``n = (cos, sin)(psi + phi)`` for the pinion, the gear turning the other way) is open while
``n . d > 0``. An open crack removes bending stiffness about the axis along the crack front only, so the
shaft's stiffness becomes ``K = k I - dk n n^T`` (``dk = stiffness_loss * k``, the equivalent spring's
drop normal to the crack), and the restoring force ``-K d = -k d + dk (n . d)_+ n``. The force is
continuous at the switching instants (``n . d = 0`` there), so the fixed-step RK4 stays accurate.
Under the static mesh load (fixed in space) the crack breathes once per revolution: the extra force
``dk |d0| max(cos(psi - a), 0) n(psi)`` holds the shaft's orders 0, 1, 2, 3, 5, ... (the half-wave
rectified cosine times a rotating vector), i.e. 1x, 2x and 3x of the cracked shaft with 2x strong (the
classic crack signature, Dimarogonas 1996; Sabnavis et al. 2004). The same force reaches bearing 2's
channels (half the shaft's restoring force) when the crack is on the pinion shaft.

Cardan (Hooke's) joint at the input
----------------------------------
A motor driving the input shaft through a universal joint bent by the angle ``beta`` turns the driven end
non-uniformly: with the motor at ``psi`` the joint's output is at ``atan2(sin psi, cos psi cos beta)``
(Hooke's joint kinematics; e.g. Den Hartog, Mechanical Vibrations, Sec. 5.5; Seherr-Thoss et al. 2006),
``Delta(psi) = atan2(sin psi, cos psi cos beta) - psi ~ (beta^2 / 4) sin(2 psi)``, and its rate
``Delta' = w (cos beta / (1 - sin^2 beta cos^2 psi) - 1)``. The drive-shaft torsion spring acts on the
pinion's angle relative to that end: ``-k_t (theta1 - Delta) - c_t (theta1' - Delta')``. The excitation is
torsional at the even orders of the input shaft (2x, 4x, ..., falling as ``beta^2`` per order pair) and
grows with speed squared through the drive train's inertia; the library's ``shaft_misalignment`` is a
lateral 2x force at a node, not this. (The joint's secondary bending moment is not modelled.)
"""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True, inline="always")
def crack_force(x: float, y: float, psi: float, sign: float, loss_k: float) -> tuple[float, float]:
    """Extra restoring force ``dk (n . d)_+ n`` of an open crack (zero while it is closed).

    Parameters
    ----------
    x, y : float
        The wheel's lateral displacement from the bearing line, m.
    psi : float
        The crack mouth's angle (shaft angle plus the crack's phase), rad.
    sign : float
        +1 for the pinion's rotation sense, -1 for the gear's (it turns the other way).
    loss_k : float
        ``dk``, the equivalent lateral spring's drop normal to the open crack, N/m.
    """
    nx = math.cos(psi)
    ny = sign * math.sin(psi)
    proj = nx * x + ny * y
    if proj <= 0.0:
        return 0.0, 0.0
    return loss_k * proj * nx, loss_k * proj * ny


@njit(cache=True, inline="always")
def cardan_lag(psi: float, beta: float, w: float) -> tuple[float, float]:
    """Angle and rate of the driven end ahead of the motor, ``Delta`` and ``Delta'`` (Hooke's joint).

    Parameters
    ----------
    psi : float
        The motor's (input) angle plus the joint's phase, rad.
    beta : float
        The joint's bend angle, rad.
    w : float
        The motor's speed, rad/s.
    """
    cb = math.cos(beta)
    s, c = math.sin(psi), math.cos(psi)
    out = math.atan2(s, c * cb) - psi
    # keep the branch continuous: atan2 and psi differ by whole turns
    out -= 2.0 * math.pi * math.floor((out + math.pi) / (2.0 * math.pi))
    sb = math.sin(beta)
    rate = w * (cb / (1.0 - sb * sb * c * c) - 1.0)
    return out, rate
