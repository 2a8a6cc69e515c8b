"""The gear pair's inertia as a baseline set: the mesh mode apart from ``F / k``
(history/calibration_sessions.md Sec. 8.41).

The mesh stiffness set (``mesh_stiffness_damping``) moves the mesh mode ``sqrt(k / m_e)`` and the static
mesh compliance ``F / k`` together. Where the two models' mesh modes differ, the set places the mode and
leaves ``F / k`` wrong (Sec. 8.35: x1.5-1.9 at 4500 rpm / 75 C for a mean-stiffness ratio of 1.342), and a
tooth's depth read from the DTE comb (about ``s^0.6``, Sec. 8.27) follows it. The ``mesh_inertia`` set
(``faults.mesh_inertia.MeshInertia``: gear discs' mass and inertia and mesh stiffness both times ``s``)
holds the mode where the mesh set put it and moves ``F / k`` by ``1 / s``. Two ways to choose ``s``:

* fitted on the whole record right after the mesh set (``benchmarks/mesh_inertia_diagnosis.py calibrate
  --variants on``; the fit lives there, not in the calibration). Measured: the healthy model's chi^2 is flat
  along the mode-held line (within 2 % over ``s`` 0.6-1.2 on the 4500 rpm gear record), so the fit lands on
  the channels' model-form misfit (x1.32 / x0.82 on the two 4500 rpm tooth records): not hooked in;
* :func:`inertia_for_dte_depth` (``FitSettings.mesh_inertia_from_comb``, default on since Sec. 8.66): where a
  named tooth's DTE comb (which reads ``F / k``) and its scale-free sideband energy ratios give one depth
  (:func:`comb_readings`, :func:`consistent_scale`); the DTE depth is then read with that set, which goes
  with the tooth into ``baseline_updates`` (``candidates_tooth_dte.refine_depth_by_dte``).

Either way it is a baseline update of the machine, never an effect.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from gear_rotor_sim.faults.mesh_inertia import MeshInertia

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.faults import Effect, ToothDamage

#: inertia scales at which the named tooth's depth is read two ways (:func:`comb_readings`)
SCALES: tuple[float, ...] = (1.0, 0.8, 0.65, 0.5)


@dataclass
class CombReading:
    """The named tooth's depth read two ways on the machine with ``MeshInertia(scale)`` added."""

    scale: float
    ratio_depth: float  # from the scale-free sideband energy ratios (NaN: not read)
    dte_depth: float  # from the DTE comb, which reads F / k (NaN: not read)


def comb_readings(
    cal: Calibrator, e: ToothDamage, accepted: list[Effect], scales: Sequence[float] = SCALES
) -> list[CombReading]:
    """The named tooth's ratio depth and DTE-comb depth at each inertia scale of ``scales`` (the mode held
    where the mesh set put it, ``F / k`` times ``1 / s``).

    The sideband energy ratios of the damaged wheel's synchronous average are scale-free (``F / k``, the
    sensor gains and most of the path cancel, :mod:`.features_sidebands`); the DTE comb's size is ``F / k``
    times a function of the depth (:mod:`.features_dte_depth`). Where the two readings agree, the model's
    static compliance is the record's at the mode the mesh set placed (Sec. 8.41). One full run per grid
    depth and scale (``DEPTH_GRID``), no ensemble.
    """
    from gear_rotor_sim.calibration.candidates_tooth import wheel_shaft
    from gear_rotor_sim.calibration.candidates_tooth_dte import dte_channel
    from gear_rotor_sim.calibration.features_dte_depth import depth_from_dte, dte_tooth_signature
    from gear_rotor_sim.calibration.features_sidebands import (
        DEPTH_GRID,
        fit_depth_from_ratios,
        sideband_energy_ratios,
    )

    c, shaft = dte_channel(cal), wheel_shaft(cal, e)
    if c is None or shaft is None:
        return []
    f_shaft, teeth = shaft
    fs = cal.m.sample_rate_hz
    h, k = cal.settings.mesh_harmonics, cal.settings.sidebands
    ser_m, ser_se = sideband_energy_ratios(cal.m.data, fs, f_shaft, teeth, h, k)
    dte_m, dte_se = dte_tooth_signature(cal.m.data[:, c], fs, f_shaft, teeth)
    out = []
    for s in scales:
        pre = (MeshInertia(inertia_scale=float(s)),) if s != 1.0 else ()
        ser, dte = {}, {}
        for d in DEPTH_GRID:
            effects = (*pre, *accepted, dataclasses.replace(e, depth=d)) if d > 0 else (*pre, *accepted)
            x = cal.runner.outputs(cal._raw(effects))
            ser[d] = sideband_energy_ratios(x, fs, f_shaft, teeth, h, k, debias=False)[0]
            dte[d] = dte_tooth_signature(x[:, c], fs, f_shaft, teeth, debias=False)[0]
        fr = fit_depth_from_ratios(ser_m, ser_se, ser, None, cal.settings.tolerance)
        fd = depth_from_dte(dte_m, dte_se, dte)
        out.append(
            CombReading(
                float(s),
                float(fr.depth) if fr is not None and not fr.at_edge else math.nan,
                float(fd.depth) if fd is not None else math.nan,
            )
        )
    return out


def consistent_scale(readings: Sequence[CombReading]) -> float | None:
    """The inertia scale where the DTE-comb depth equals the ratio depth: the sign change of
    ``log(dte / ratio)`` over the readings (log-linear in the scale), or None without one."""
    pts = sorted(
        (r.scale, math.log(r.dte_depth / r.ratio_depth))
        for r in readings
        if r.ratio_depth > 0 and r.dte_depth > 0
    )
    exact = [sc for sc, g in pts if g == 0.0]
    if exact:
        return exact[-1]
    for (s0, g0), (s1, g1) in itertools.pairwise(pts):
        if g0 * g1 < 0.0:
            w = g0 / (g0 - g1)
            return float(math.exp(math.log(s0) + w * (math.log(s1) - math.log(s0))))
    return None


def inertia_for_dte_depth(cal: Calibrator, e: ToothDamage, accepted: list[Effect]) -> MeshInertia | None:
    """The ``mesh_inertia`` set at which the named tooth's DTE comb and its scale-free sideband ratios
    read one depth (:func:`comb_readings`, :func:`consistent_scale`), for the DTE depth to be read with
    (``candidates_tooth_dte.refine_depth_by_dte``; ``FitSettings.mesh_inertia_from_comb``, default on).

    Only where the record's own mesh set is in the baseline (it placed the mode) and no inertia set yet;
    None when the readings do not cross within :data:`SCALES` (a note gives them).
    """
    if not cal.fit_baseline or any(isinstance(b, MeshInertia) for b in cal.baseline):
        return None
    if not any(type(b).__name__ == "MeshStiffnessDamping" for b in cal.baseline):
        return None
    rows = comb_readings(cal, e, accepted)
    s = consistent_scale(rows)
    text = "; ".join(f"x{r.scale:g}: {r.ratio_depth:.3g} / {r.dte_depth:.3g}" for r in rows)
    if s is None:
        cal.notes.append(
            f"{e.label}: mesh_inertia: the ratio and DTE-comb depths do not meet within the scales ({text})"
        )
        return None
    cal.notes.append(
        f"{e.label}: mesh_inertia x{s:.3g}: the ratio and DTE-comb depths meet there (ratio / DTE depth by "
        f"inertia scale, the mesh mode held: {text})"
    )
    return MeshInertia(inertia_scale=round(s, 3))
