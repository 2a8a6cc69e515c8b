"""A damaged tooth's index where the whole record and the transmission error's low orders disagree (issue
11; docs/history/calibration_sessions.md Sec. 8.80).

The tooth search (``Calibrator._fit_tooth``) shifts the tooth-1 signature by whole mesh periods and takes
the shift of least balanced chi^2 over every channel. In contact, the bearing forces and the shaft-node
accelerations see the tooth through the shafts' and bearings' transfer, which the FE model and a real
gearbox place differently (``candidates_tooth_path.py``, Sec. 8.35: the independent record's tooth comb at
the bearing forces is 0.09-0.97 of the FE model's, band by band); the transmission error sees the mesh
itself, and below the first mesh-coupled resonance its low orders of the damaged wheel's shaft (1-6) carry
the pulse's angular position, which the two models agree on within 0.04 rad. A shift by one tooth turns
order ``k`` by ``2 pi k / z``. Measured on blind2_16 (pinion tooth 13 of 29, depth 0.615, 2771 rpm /
143 C, no reference; full runs at depth 0.6 on the calibration's final machine, mesh x1.963): the whole
record's chi^2 is least at tooth 15 (1.818e5; tooth 13: 1.924e5), the DTE's low orders at tooth 13 (1300;
teeth 12 / 14: 5905 / 6067, tooth 15: 15272); on the nominal mesh the same (75 at tooth 13, 10324 at 15).

Rule, where the teeth stay in contact, the order family is used and a channel measures the mesh (the
DTE): the search also ranks every tooth by the low-order chi^2 at the mesh
(:func:`~.candidates_tooth_path.low_order_mesh_chi2`) on the same shifted signatures (no extra run). Where
that ranking names another tooth ``j`` than the whole record's ``i`` and is decisive (:func:`decisive`:
the low-order chi^2 at ``i`` at least :data:`DECISIVE_RATIO` times the one at ``j``, and the tooth at
``j`` explains the low orders beyond the healthy model by more than the BIC threshold), the refinement
(``Calibrator._verify_tooth``) compares ``i``, ``j`` and ``j``'s two neighbours on full runs at the fitted
depth by the low-order chi^2 at the mesh, and the depth is then refined at the tooth it names, as for
every tooth. Where the two rankings agree nothing changes (the opt-in ``FitSettings.tooth_index_at_mesh``
compares the neighbours by the low orders always).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from gear_rotor_sim.calibration.fault_path import mesh_channels

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator

#: the low-order chi^2 at the whole record's tooth over that at the DTE's tooth for the DTE to decide
#: (blind2_16: 138 on the search's shifted signatures at mesh x1, 11.7 on full runs at mesh x1.963; a
#: neighbour one tooth off reads 2-5 times the true tooth's there)
DECISIVE_RATIO = 2.0


@dataclass(frozen=True)
class LowOrderIndex:
    """The tooth search's two rankings of one wheel (1-based teeth)."""

    whole_tooth: int  # least balanced chi^2 over every channel
    low_tooth: int  # least low-order chi^2 at the mesh
    low_at_whole: float  # low-order chi^2 at ``whole_tooth``
    low_at_low: float  # low-order chi^2 at ``low_tooth``
    low_healthy: float  # low-order chi^2 of the current model without the tooth


def low_order_index_applies(cal: Calibrator, e: Any) -> int | None:
    """Index (in ``cal.cmp.shafts``) of the damaged wheel's shaft where the low-order ranking is read: teeth
    in contact, the order family used, a channel at the mesh and the wheel's shaft order-analysed; else
    None."""
    from gear_rotor_sim.calibration.candidates_tooth import ratio_depth_in_contact, wheel_shaft_name

    cmp = cal.cmp
    if "order" not in cmp.families or not ratio_depth_in_contact(cal) or not mesh_channels(cmp.names).any():
        return None
    names = [sh.name for sh in cmp.shafts]
    own = wheel_shaft_name(cal, e)
    return names.index(own) if own in names else None


def decisive(r: LowOrderIndex, bic_threshold: float) -> bool:
    """Whether the low orders name another tooth than the whole record, decisively (module docstring).

    Parameters
    ----------
    r : LowOrderIndex
        The two rankings.
    bic_threshold : float
        ``FitSettings.bic_threshold``: the low-order gain of the DTE's tooth over the healthy model must
        exceed it (the low orders hold the tooth's pulse at all).
    """
    if r.low_tooth == r.whole_tooth or not np.isfinite(r.low_at_whole) or not np.isfinite(r.low_at_low):
        return False
    if r.low_healthy - r.low_at_low <= bic_threshold:
        return False
    return bool(r.low_at_whole >= DECISIVE_RATIO * max(r.low_at_low, 1e-300))


def rank_low_orders(low_chi2: np.ndarray, whole_chi2: np.ndarray, low_healthy: float) -> LowOrderIndex:
    """The two rankings from the per-tooth chi^2 arrays (index 0 = tooth 1)."""
    i = int(np.argmin(whole_chi2))
    j = int(np.argmin(low_chi2))
    return LowOrderIndex(i + 1, j + 1, float(low_chi2[i]), float(low_chi2[j]), float(low_healthy))


def teeth_to_compare(r: LowOrderIndex, z: int) -> tuple[int, ...]:
    """The whole record's tooth, the DTE's tooth and the latter's two neighbours (1-based, wheel of ``z``
    teeth), each once."""
    j = r.low_tooth
    return tuple(dict.fromkeys((r.whole_tooth, j, (j - 2) % z + 1, j % z + 1)))


def index_note(label: str, r: LowOrderIndex) -> str:
    """The note a decisive disagreement leaves."""
    return (
        f"{label}: the shifted-signature search names tooth {r.whole_tooth} on the whole record and "
        f"tooth {r.low_tooth} on the DTE's low orders of its wheel (chi2 {r.low_at_whole:.4g} -> "
        f"{r.low_at_low:.4g}, "
        f"healthy {r.low_healthy:.4g}; ratio {r.low_at_whole / max(r.low_at_low, 1e-300):.3g} >= "
        f"{DECISIVE_RATIO:g}): the teeth compared on full runs by the low orders at the mesh "
        "(candidates_tooth_index.py)"
    )
