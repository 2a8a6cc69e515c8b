"""A damaged tooth's higher mesh-harmonic sidebands as a shape nuisance (issue 11; history Sec. 8.63).

The library's damaged tooth lowers the mesh stiffness by ``depth`` times the tooth's share, a step
function of the mesh phase (1/2 in double contact, 1 in single; ``faults.gear.tooth_share``). Its
pulse per revolution of the damaged wheel has the right area (the compliance-time the tooth adds: the
low orders and the first mesh harmonic's sidebands of the DTE, from which the depth is read, Sec. 8.25),
but how a pair picks up and sheds its load (tip relief, the pair's stiffness along the path, the
profile's own errors) shapes the sidebands of the higher mesh harmonics, and a mode near them
(the mesh mode) amplifies them by an amount the model places a few percent off. Measured on the
held-out x1.6 pinion tooth (0.64) at the DTE depth 0.612: the FE signature's DTE sidebands are 1.04,
2.51 and 4.82 times the record's around the first, second and third mesh harmonics (quasi-static,
from the two models' stiffness laws alone: x2.3 at the second, the step against a smooth pair entry);
at the table's depth 0.4 the same ratios leave a compromise depth that halves the error, at 0.64 they
do not (the misfit grows with the signature, the noise does not).

Rule (``FitSettings.tooth_band_shape``): a damaged tooth's change of the order features from the
current model, in the sidebands ``h z +- j`` (``1 <= |j| <= sidebands``) of each mesh harmonic
``h >= 2`` on the damaged wheel's shaft, is multiplied by one real factor per harmonic ``b_h`` in
``[0, 1]``, common to every channel (a property of the pulse, not of a path), fitted on the whole
record's balanced chi^2. The bound: a step in the share is the most abrupt a pair can take its load, so a
real tooth's pulse has no more higher-harmonic content than the step law's. The low orders, the first
harmonic's sidebands, the carriers, the envelope and the channel means keep the full run's. The factors
are a nuisance of the verified tooth (reported in the notes; not counted in its BIC parameters: 2 ln N = 14
against the Delta BIC of 1e4-1e5 of the rows it moves), never a finding.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.optimize import minimize

from gear_rotor_sim.calibration.residual_types import ModelFeatures
from gear_rotor_sim.faults import Effect, ToothDamage

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator

#: lowest mesh harmonic whose sidebands take a fitted factor
FIRST_SHAPED_HARMONIC = 2


@dataclass(frozen=True)
class BandShape:
    """Fitted factors of the higher mesh harmonics' sidebands of a damaged tooth's signature."""

    harmonics: tuple[int, ...]
    factors: tuple[float, ...]
    chi2_before: float  # balanced chi^2 at factors 1 (the full run)
    chi2_after: float


def band_masks(orders: np.ndarray, teeth: int, sidebands: int) -> list[tuple[int, np.ndarray]]:
    """Masks of the sidebands ``h z +- j`` (``1 <= |j| <= sidebands``) of each mesh harmonic ``h >= 2``
    among ``orders``; harmonics with no sideband among them are left out.

    Parameters
    ----------
    orders : numpy.ndarray
        The shaft's analysed orders (integers).
    teeth : int
        Teeth ``z`` of the damaged wheel on that shaft.
    sidebands : int
        Sidebands on each side of a mesh harmonic.
    """
    k = np.asarray(orders, dtype=int)
    out = []
    if teeth <= 0:
        return out
    h_max = int((k.max(initial=0) + sidebands) // teeth)
    for h in range(FIRST_SHAPED_HARMONIC, h_max + 1):
        j = k - h * teeth
        m = (np.abs(j) >= 1) & (np.abs(j) <= sidebands)
        if m.any():
            out.append((h, m))
    return out


def shaped(
    base: ModelFeatures, feats: ModelFeatures, s: int, masks: Sequence[np.ndarray], factors: Sequence[float]
) -> ModelFeatures:
    """``feats`` with its change from ``base`` in each band of shaft ``s`` times that band's factor."""
    order = [list(row) for row in feats.order]
    for c in range(len(order)):
        d = feats.order[c][s] - base.order[c][s]
        w = np.ones(d.size)
        for m, b in zip(masks, factors, strict=True):
            w[m] = b
        order[c][s] = base.order[c][s] + w * d
    return ModelFeatures(order, feats.analytic, feats.static)


def fit_band_shape(
    cmp: Any, base: ModelFeatures, feats: ModelFeatures, s: int, teeth: int
) -> tuple[ModelFeatures, BandShape] | None:
    """Fit the factors of :func:`shaped` in ``[0, 1]`` on the balanced chi^2 of ``cmp.score``.

    Parameters
    ----------
    cmp : Comparison
        The record's comparison (its shafts, sidebands and score).
    base : ModelFeatures
        The current model without the tooth.
    feats : ModelFeatures
        The current model with the tooth (a full run).
    s : int
        Index of the damaged wheel's shaft in ``cmp.shafts``.
    teeth : int
        Teeth of the damaged wheel.

    Returns
    -------
    (ModelFeatures, BandShape) or None
        The shaped features and the factors, or None where the shaft has no band to shape.
    """
    bands = band_masks(cmp.shafts[s].orders, teeth, int(cmp.s.sidebands))
    if not bands:
        return None
    masks = [m for _, m in bands]

    def chi2(p: np.ndarray) -> float:
        return float(cmp.score(shaped(base, feats, s, masks, np.clip(p, 0.0, 1.0))).balanced_chi2)

    x0 = np.ones(len(masks))
    c0 = chi2(x0)
    res = minimize(chi2, x0, method="L-BFGS-B", bounds=[(0.0, 1.0)] * len(masks), options={"maxiter": 30})
    p = np.clip(res.x, 0.0, 1.0)
    c1 = chi2(p)
    if not c1 < c0:
        p, c1 = x0, c0
    shape = BandShape(tuple(h for h, _ in bands), tuple(float(v) for v in p), c0, c1)
    return shaped(base, feats, s, masks, p), shape


def band_shape_applies(cal: Calibrator) -> bool:
    """The rule is on, the order family is used and the healthy model's teeth stay in contact (where
    they separate, ``fault_path.py`` and ``features_rattle.py`` hold a tooth's response)."""
    from gear_rotor_sim.calibration.candidates_tooth import ratio_depth_in_contact

    return bool(cal.fit.tooth_band_shape and "order" in cal.cmp.families and ratio_depth_in_contact(cal))


def shape_tooth(
    cal: Calibrator, feats: ModelFeatures, e: ToothDamage, pre: Sequence[Effect]
) -> ModelFeatures:
    """``feats`` (a full run of the damaged tooth ``e`` on the machine with ``pre``) with its higher
    mesh-harmonic sidebands shaped (:func:`fit_band_shape`) where :func:`band_shape_applies`; the factors
    are kept in ``cal._band_shape`` for the notes (:func:`band_shape_note`)."""
    from gear_rotor_sim.calibration.candidates_tooth import wheel_shaft_name

    cal._band_shape = None
    if not band_shape_applies(cal):
        return feats
    name = wheel_shaft_name(cal, e)
    idx = [i for i, sh in enumerate(cal.cmp.shafts) if sh.name == name]
    if not idx:
        return feats
    mesh = cal.runner.cfg.meshes[e.mesh - 1]
    teeth = int(mesh.pinion_teeth if e.wheel == "pinion" else mesh.gear_teeth)
    base = cal._full_features(cal._raw(tuple(pre)))
    fitted = fit_band_shape(cal.cmp, base, feats, idx[0], teeth)
    if fitted is None:
        return feats
    cal._band_shape = fitted[1]
    return fitted[0]


def band_shape_note(label: str, at: str, shape: BandShape | None) -> str | None:
    """The note on the fitted factors of the last :func:`shape_tooth`, or None."""
    if shape is None:
        return None
    bands = ", ".join(f"{h} z: {b:.2f}" for h, b in zip(shape.harmonics, shape.factors, strict=True))
    return (
        f"{label} at {at}: its sidebands of the higher mesh harmonics taken as the model's times a fitted "
        f"shape factor in [0, 1] ({bands}; balanced chi2 {shape.chi2_before:.4g} -> {shape.chi2_after:.4g}; "
        "tooth_band_shape.py): how a pair takes its load, not the depth"
    )
