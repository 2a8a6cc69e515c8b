"""Readings of the residual trace: which effects, in the library and outside it, leave a residual like this.

``residual_trace.py`` says where the final residual is (channel, family, order or frequency). This module
reads the largest components (docs/calibration.md Sec. 5, "Residual trace"):

- a shaft's **low orders** (1-6) and a shaft's **mesh sidebands** (spacing ``|k - m z|`` = 1-6) are read as a
  profile over 1x-6x, summed over every channel (the shaft's pattern, not one sensor's), and classified by
  :data:`PATTERN_TESTS`; each pattern has the library effects whose signature it is (Sec. 3) and physical
  effects outside the library that produce it (:data:`ORDER_PATTERNS`, :data:`SIDEBAND_PATTERNS`);
- the other families (mesh harmonics, the envelope's lines and broadband, channel means) by
  :data:`FAMILY_SIGNATURES`.

Each library entry is ``(label key, text)``: the key finds the candidates of that kind in the record's
``candidates_by_round`` (their best Delta BIC and whether they were claimed), so that a reading can say
"no library effect has this signature", "the library's were fitted and not claimed", or "one was claimed
and its own family still holds the residual".

The physical associations are the textbook ones of machinery diagnostics: a breathing crack 1x-3x with 2x
strong (Dimarogonas 1996; Sabnavis et al. 2004), angular or Cardan misalignment 2x and even orders (Den
Hartog, Mechanical Vibrations, Sec. 5.5), looseness harmonics and 0.5x (Muszynska & Goldman 1995), pitch
errors a broad comb (Randall 2011, Ch. 2).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

#: the patterns of a 1x-6x profile (shares ``q`` of its sum) and the test each is
PATTERN_TESTS: dict[str, str] = {
    "1x": "1x holds >= 60 %",
    "2x": "2x the largest and >= 30 %",
    "1x-3x": "1x, 2x and 3x each >= 10 % and together >= 70 %",
    "even": "2x, 4x and 6x together >= 70 %",
    "broad": "four or more of 1x-6x each >= 5 %",
}

Lib = list[tuple[str, str]]

#: a shaft's low orders: library effects (label key, text) and effects outside the library per pattern
ORDER_PATTERNS: dict[str, dict[str, Any]] = {
    "1x": {
        "library": [
            ("eccentricity", "eccentricity of the shaft's wheel"),
            ("mass_unbalance", "mass_unbalance at a node of the shaft"),
        ],
        "outside": ["bent or thermally bowed shaft", "coupling offset", "rub (1x)"],
    },
    "2x": {
        "library": [
            ("shaft_misalignment", "shaft_misalignment (an order-2 force at a node)"),
            ("_misalignment@", "gear_misalignment beyond rho = 1 (2x)"),
            ("shaft_crack", "shaft_crack (1x + 2x + 3x, 2x strong)"),
        ],
        "outside": [
            "angular (Cardan / coupling) misalignment (2x, even orders, torsional)",
            "loose support (harmonics, 0.5x)",
        ],
    },
    "1x-3x": {
        "library": [
            ("shaft_crack", "shaft_crack (a breathing crack: 1x, 2x, 3x of its shaft)"),
            ("tooth_damage", "tooth_damage (a broad comb with sidebands, not 1x-3x alone)"),
        ],
        "outside": ["looseness", "rub", "coupling misalignment"],
    },
    "even": {
        "library": [("shaft_misalignment", "shaft_misalignment (order 2 only)")],
        "outside": ["Cardan (Hooke's) joint or angular coupling misalignment (2x, 4x, torsional)"],
    },
    "broad": {
        "library": [("tooth_damage", "tooth_damage of the shaft's wheel (with sidebands at the mesh)")],
        "outside": ["looseness", "rub", "pitch errors on several teeth"],
    },
}

#: a shaft's mesh sidebands by their spacing (1x = +-1 shaft order about the mesh harmonics)
SIDEBAND_PATTERNS: dict[str, dict[str, Any]] = {
    "1x": {
        "library": [("eccentricity", "eccentricity of the shaft's wheel (+-1)")],
        "outside": ["run-out of the wheel (any cause)", "shaft crack (1x modulation)"],
    },
    "2x": {
        "library": [
            ("_misalignment@", "gear_misalignment beyond rho = 1 (+-2)"),
            ("shaft_crack", "shaft_crack (its dynamic share: +-1 to +-3, +-2 strong)"),
        ],
        "outside": ["speed fluctuation at 2x (Cardan joint)"],
    },
    "1x-3x": {
        "library": [
            ("shaft_crack", "shaft_crack modulating the mesh (its dynamic share: +-1 to +-3)"),
            ("tooth_damage", "tooth_damage (a broad comb, not +-1 to +-3 alone)"),
        ],
        "outside": ["looseness"],
    },
    "even": {
        "library": [("_misalignment@", "gear_misalignment beyond rho = 1 (+-2)")],
        "outside": ["Cardan (Hooke's) joint: speed and torque fluctuating at 2x, 4x"],
    },
    "broad": {
        "library": [("tooth_damage", "tooth_damage of the shaft's wheel")],
        "outside": ["pitch errors on several teeth", "looseness"],
    },
}

#: the other families' readings
FAMILY_SIGNATURES: dict[str, dict[str, Any]] = {
    "mesh harmonics": {
        "library": [
            ("temperature_offset", "temperature_offset"),
            ("tooth_wear", "tooth_wear"),
            ("mesh_stiffness", "mesh_stiffness_damping (baseline)"),
        ],
        "outside": ["output torque not the declared one", "profile modification / tip relief error"],
    },
    "envelope: bearing-defect lines": {
        "library": [("_defect@", "outer_race_defect, inner_race_defect, ball_defect")],
        "outside": ["a bearing of another geometry than the default"],
    },
    "envelope: shaft-rate lines": {
        "library": [
            ("inner_race_defect", "inner_race_defect (load-zone modulation)"),
            ("tooth_damage", "tooth_damage (once per turn)"),
        ],
        "outside": ["looseness (impacts once per turn)", "rub"],
    },
    "envelope: other lines": {
        "library": [],
        "outside": [
            "looseness sub-harmonics",
            "rub",
            "structural resonance",
            "electrical line",
            "another machine",
        ],
    },
    "envelope: broadband": {
        "library": [],
        "outside": ["more noise than the model's floor", "lubrication / friction noise"],
    },
    "channel mean": {
        "library": [
            ("temperature_offset", "temperature_offset (axial load)"),
            ("tooth_wear", "tooth_wear (DTE mean)"),
        ],
        "outside": ["output torque not the declared one", "sensor offset", "housing thermal growth"],
    },
}


def profile_patterns(p: np.ndarray) -> list[str]:
    """The :data:`PATTERN_TESTS` a 1x-6x profile ``p`` (sums of ``(r / sigma)^2``) passes."""
    tot = float(np.sum(p))
    if not tot > 0:
        return []
    q = np.zeros(6)
    q[: min(len(p), 6)] = np.asarray(p, float)[:6] / tot
    out = []
    if q[0] >= 0.6:
        out.append("1x")
    if q[1] >= 0.3 and q[1] == q.max():
        out.append("2x")
    if min(q[0], q[1], q[2]) >= 0.1 and q[:3].sum() >= 0.7:
        out.append("1x-3x")
    if q[1] + q[3] + q[5] >= 0.7:
        out.append("even")
    if int(np.sum(q >= 0.05)) >= 4:
        out.append("broad")
    return out


def tried_candidates(rounds: list[list[dict[str, Any]]], claimed: Iterable[str]) -> dict[str, dict[str, Any]]:
    """Best Delta BIC of every candidate over the rounds, and whether it was claimed."""
    found = set(claimed)
    out: dict[str, dict[str, Any]] = {}
    for table in rounds:
        for row in table:
            dbic = row.get("delta_bic")
            if dbic is None:
                continue
            lab = str(row.get("label") or row.get("name"))
            if lab not in out or dbic > out[lab]["best_delta_bic"]:
                out[lab] = {"best_delta_bic": float(dbic), "claimed": lab in found}
    return out


def reading(
    component: dict[str, Any],
    profile: np.ndarray | None,
    tried: dict[str, dict[str, Any]],
    family_share: float = 0.0,
    halved: bool = True,
) -> dict[str, Any]:
    """The reading of one trace component.

    Parameters
    ----------
    component : dict
        ``{channel, family, share}`` of the trace.
    profile : numpy.ndarray or None
        The 1x-6x profile of its shaft's low orders or sideband spacings (None for the other families).
    tried : dict
        :func:`tried_candidates` of the record.
    family_share : float
        The share of ``E^2`` of the component's family over every channel.
    halved : bool
        Whether the calibration halved its error (``error_after <= error_before / 2``).

    Returns
    -------
    dict
        ``component``, ``share``, ``profile`` / ``patterns`` (order families), the library effects with
        this signature, those outside it, the library candidates of that kind tried here, ``reading``, and
        ``claim_suspect``: a claimed library effect of this signature left its family holding >= 50 % of
        the final ``E^2`` without halving the error (it explains only part of the residual).
    """
    fam = component["family"].split(" (")[0]
    out: dict[str, Any] = {
        "component": f"{component['channel']}: {component['family']}",
        "share": component["share"],
        "family_share": float(family_share),
    }
    if profile is not None:
        table = ORDER_PATTERNS if fam == "shaft orders" else SIDEBAND_PATTERNS
        pats = profile_patterns(profile)
        tot = float(np.sum(profile))
        out["profile"] = {f"{k + 1}x": float(v / tot) for k, v in enumerate(profile)} if tot > 0 else {}
        out["patterns"] = pats
        lib: Lib = [x for pt in pats for x in table[pt]["library"]]
        outside = [x for pt in pats for x in table[pt]["outside"]]
    else:
        lib = list(FAMILY_SIGNATURES.get(fam, {}).get("library", []))
        outside = list(FAMILY_SIGNATURES.get(fam, {}).get("outside", []))
    out["library_effects_with_this_signature"] = list(dict.fromkeys(t for _, t in lib))
    out["outside_the_library"] = list(dict.fromkeys(outside))
    keys = {k for k, _ in lib}
    rel = {lab: v for lab, v in tried.items() if any(k in lab for k in keys)}
    out["library_candidates_tried"] = rel
    claimed = [lab for lab, v in rel.items() if v["claimed"]]
    out["claim_suspect"] = bool(claimed and family_share >= 0.5 and not halved)
    if not lib:
        out["reading"] = "matches the signature of no library effect"
    elif out["claim_suspect"]:
        out["reading"] = (
            f"{', '.join(claimed)} (claimed, of this signature) leaves this family {family_share:.0%} of the "
            "final error and did not halve the error: it explains only part of the residual, whose pattern "
            "the effects outside the library below also produce"
        )
    elif claimed:
        out["reading"] = (
            f"{', '.join(claimed)} (claimed, of this signature); this family holds the largest part of what "
            "remains (its model-form misfit or a further effect)"
        )
    elif rel:
        out["reading"] = (
            "the library effects with this signature were fitted and not claimed: the residual points "
            "outside the library"
        )
    else:
        out["reading"] = "the library effects with this signature were not fitted on this record"
    return out
