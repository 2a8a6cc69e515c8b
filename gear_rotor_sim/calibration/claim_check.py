"""Claims forced by a fault outside the library: what a claimed effect leaves in its own signature (issue 11).

A library effect is claimed when it explains enough of the residual (Delta BIC, its share of the excess, its
own signature present; docs/calibration.md Sec. 4). A fault the library does not have (a breathing shaft
crack, a Cardan joint, looseness) puts its energy on the same shaft orders and mesh sidebands as some library
effect, which is then fitted to the part it can follow and claimed with confidence 1.0 (history Sec. 8.44:
the crack as ``tooth_damage@pinion``, the Cardan joint as ``shaft_misalignment@node1``). What gives such a
claim away is the **shape** of what it leaves in its own families (its shaft's low orders 1-6 and mesh
sidebands): the fit has taken all of the record's content that the effect's own shape can follow, so content
the model still lacks there in a shape the effect cannot produce comes from another mechanism. Three tests,
read from the final residual trace (``residual_trace.py``) only, so that they are evaluated alike in the
calibration and on saved reports (docs/calibration.md Sec. 8.3, "Claims the residual contradicts"):

1. **Pattern.** A reading of the trace (content the model lacks, >= 10 % of the final ``E^2`` in one
   channel's component, its largest such feature >= 5 uncertainties out) on one of the effect's own families
   (for a damaged tooth its mesh sidebands only: its shaft's orders 1-6 also hold the FE model's and a
   machine's own difference, e.g. the input's order 4 in the independent records' true tooth rows)
   whose 1x-6x profile, spread over more than one order (none >= :data:`SINGLE_ORDER`: a single order's
   rest is also what the two models' own difference at that order leaves), passes none of the effect's own
   patterns (:data:`OWN_PATTERNS`; the tests of
   ``residual_signatures.PATTERN_TESTS``): a damaged tooth is an impulse once per turn, a flat comb over the
   spacings 1-6 (``broad``), so a rest concentrated on 1x-3x (a breathing crack's smooth modulation) or in
   no simple pattern is not a tooth's; an eccentricity or unbalance is ``1x``, a gear misalignment ``2x``
   or ``even``, a shaft misalignment (a coupling reaction at order 2 alone, ``faults/shaft.py``) ``2x``
   only (since session 20: a rest of 2x 41 %, 6x 45 % after it is not its own); a breathing shaft crack
   (session 22, ``faults/crack.py``: 1x, 2x, 3x of its shaft, also as mesh sidebands) ``1x-3x``, ``2x``,
   ``1x`` or ``broad`` on its shaft's orders and mesh sidebands (a crack breathing on its vibration too puts
   sidebands beyond +-3, which the linearised effect leaves; even orders left after it are not its).
2. **Torsional rest of a lateral effect.** ``shaft_misalignment`` and ``mass_unbalance`` are lateral forces
   at a node (Sec. 3); where the dynamic transmission error's component of the effect's own shaft orders is
   among the trace's largest and its largest feature is the effect's own order (2, 1), standing at least
   5 uncertainties out with the record holding at least :data:`TORSIONAL_RATIO` times the final model's
   amplitude, the record's order is torsional (a Cardan joint's 2x turns the shaft non-uniformly), which a
   lateral force at that node does not make.

3. **Own order spread over the lateral channels** (session 20, history Sec. 8.56). The same lateral effects:
   the fit sets one force (size and phase) from every channel, so after it the record / model ratio of its
   own order should be alike on the lateral channels (bearing forces, accelerations; not the DTE). Among the
   trace's largest components, those on a lateral channel and an own family whose largest feature is the
   effect's own order at least 5 uncertainties out give their ratios, and the fit itself counts as ratio
   1 (the channels not listed). Where the largest ratio over the smallest is :data:`SPREAD_RATIO` or more,
   the record's own-order content is split between the directions or paths in a way a lateral force at that
   node does not make: a force along a fixed line (a Cardan joint's 2x arrives through the mesh force,
   along the line of action: bearing 2's y force holds 2.2-2.5 x the fitted misalignment's) or a one-sided,
   anisotropic support (a loose housing's 2x across the line of action: bearing 2's x force 1.5 x the
   fitted misalignment's, its y force 0.57 x).

A claim failing any test is **not a confident finding**: it stays in ``effects`` (the order found, its
parameters) with ``status: "suspect"``, its ``confidence`` capped at :data:`SUSPECT_CONFIDENCE`, a
``claim_checks`` entry (which test, the trace's reading of the rest and the effects outside the library that
produce it), a note, and a sentence in the conclusion. Bearing defects, tooth wear and a temperature offset
are not checked (their families, the envelope's lines and the channel means, carry no shaft pattern).

Each check also reports ``lacking_ratio``, ``s_lack E_after^2 / (E_e,before^2 - E_e,after^2)`` (the share
of the final ``E^2`` in the 8 largest components that lies in the effect's own families where the record
exceeds the model, in units of what the claim explained): measured, not used (it does not separate the true
contact tooth rows from the Cardan claims, history Sec. 8.48).
"""

from __future__ import annotations

import math
import re
from typing import Any

from gear_rotor_sim.calibration.residual_trace import READING_MIN_RESIDUAL

#: the 1x-6x patterns (``residual_signatures.PATTERN_TESTS``) an effect's own signature has on its families
OWN_PATTERNS: dict[str, tuple[str, ...]] = {
    "tooth_damage": ("broad",),
    "eccentricity": ("1x",),
    "mass_unbalance": ("1x",),
    "shaft_misalignment": ("2x",),  # the library's: a coupling reaction at order 2 alone (faults/shaft.py)
    "misalignment": ("2x", "even"),  # gear or pinion misalignment beyond rho = 1 (+-2 sidebands)
    # 1x, 2x, 3x of its shaft and as mesh sidebands (faults/crack.py); broad: a crack that breathes on its
    # vibration too (beyond the load-dominance linearisation) puts sidebands beyond +-3 (history Sec. 8.61)
    "shaft_crack": ("1x-3x", "2x", "1x", "broad"),
}

#: lateral effects at a node and their own order (test 2)
LATERAL_ORDER: dict[str, int] = {"shaft_misalignment": 2, "mass_unbalance": 1}

#: test 1 reads a rest only where no single order holds this share of its 1x-6x profile
SINGLE_ORDER = 0.9

#: test 2: the record's torsional order at least this many times the final model's
TORSIONAL_RATIO = 3.0

#: test 3: the record / model ratios of the effect's own order over the lateral channels spread this much
SPREAD_RATIO = 2.0

#: the confidence of a suspect claim is at most this (the benchmarks count > 0.5 as confident)
SUSPECT_CONFIDENCE = 0.2


def _kind(label: str) -> str:
    for k in (
        "tooth_damage",
        "shaft_crack",
        "shaft_misalignment",
        "mass_unbalance",
        "eccentricity",
        "misalignment",
    ):
        if k in label:
            return k
    return ""


def _wheel_shaft(cfg: Any, wheel: str, mesh: int) -> str | None:
    if not 1 <= mesh <= len(cfg.meshes):
        return None
    m = cfg.meshes[mesh - 1]
    node0 = cfg.gear(m.pinion if wheel == "pinion" else m.gear).node0
    return str(cfg.shafts[cfg.shaft_of_node(node0)].name)


def own_families(effect: dict[str, Any], cfg: Any) -> list[str]:
    """The residual trace's families that hold a claimed effect's own signature.

    Parameters
    ----------
    effect : dict
        The effect as reported (``name``, ``label``, ``parameters``).
    cfg : RigConfig
        The rig (shaft of a node, of a wheel).

    Returns
    -------
    list of str
        ``shaft orders (<shaft>)`` and, for wheel effects, ``mesh sidebands (<shaft>)``; empty for the
        effects that are not checked (bearing defects, wear, temperature).
    """
    label = str(effect.get("label") or effect.get("name"))
    p = effect.get("parameters") or {}
    m = re.search(r"@mesh(\d+)", label)
    mesh = int(m.group(1)) if m else int(p.get("mesh", 1))
    node = re.search(r"@node(\d+)", label)
    kind = _kind(label)
    shaft: str | None = None
    if kind == "tooth_damage":
        shaft = _wheel_shaft(cfg, str(p.get("wheel", label.split("@")[1])), mesh)
    elif kind in ("eccentricity", "misalignment"):
        shaft = _wheel_shaft(cfg, label.split("_")[0], mesh)
    elif node and (kind in LATERAL_ORDER or kind == "shaft_crack") and 0 < int(node.group(1)) <= cfg.n_nodes:
        shaft = str(cfg.shafts[cfg.shaft_of_node(int(node.group(1)) - 1)].name)
    if shaft is None:
        return []
    fams = [f"shaft orders ({shaft})"]
    return fams if kind in LATERAL_ORDER else [*fams, f"mesh sidebands ({shaft})"]


def _is_dte(channel: str) -> bool:
    return channel == "dte" or channel.endswith("_dte")


def _own_order_components(
    kind: str, trace: dict[str, Any], families: list[str], dte: bool
) -> list[dict[str, Any]]:
    """The trace's largest components on the DTE (``dte``) or on the lateral channels whose largest feature is
    a lateral effect's own order on an own family, >= 5 uncertainties out, with ``ratio`` = record / model."""
    if kind not in LATERAL_ORDER:
        return []
    out = []
    for c in trace.get("components") or []:
        lg = c.get("largest") or {}
        if (
            _is_dte(str(c.get("channel"))) == dte
            and c.get("family") in families
            and lg.get("at") == f"order {LATERAL_ORDER[kind]}"
            and lg.get("normalised_residual", 0.0) >= READING_MIN_RESIDUAL
        ):
            model = abs(lg.get("model_over_noise", 0.0))
            ratio = lg.get("measured_over_noise", 0.0) / model if model > 0 else math.inf
            out.append({"channel": c["channel"], "family": c["family"], **lg, "ratio": float(ratio)})
    return out


def _torsional(kind: str, trace: dict[str, Any], families: list[str]) -> dict[str, Any] | None:
    """Test 2: the first DTE component of the effect's own order, the record >= TORSIONAL_RATIO x model."""
    comps = _own_order_components(kind, trace, families, dte=True)
    return next((c for c in comps if c["ratio"] >= TORSIONAL_RATIO), None)


def _own_order_spread(kind: str, trace: dict[str, Any], families: list[str]) -> dict[str, Any] | None:
    """Test 3: the record / model ratios of the effect's own order on the lateral channels (the fitted model,
    1, among them) spread by :data:`SPREAD_RATIO` or more."""
    comps = _own_order_components(kind, trace, families, dte=False)
    if not comps:
        return None
    ratios = [1.0, *(c["ratio"] for c in comps)]
    spread = max(ratios) / min(ratios)
    return {"components": comps, "spread": float(spread)} if spread >= SPREAD_RATIO else None


def claim_check(effect: dict[str, Any], trace: dict[str, Any], families: list[str]) -> dict[str, Any]:
    """Tests 1-3 of the module docstring for one claimed effect.

    Parameters
    ----------
    effect : dict
        The effect as reported (``label``; ``error_before`` / ``error_after`` of its own round).
    trace : dict
        The final residual trace (``residual_trace.trace_residual``).
    families : list of str
        :func:`own_families` of the effect.

    Returns
    -------
    dict
        ``suspect``, ``tests`` (the names of the tests it fails: ``pattern``, ``torsional``, ``own_order``),
        ``families``, ``own_patterns``, ``readings`` (the trace's readings of those families), ``torsional``
        (the DTE component of test 2, or None), ``own_order`` (test 3's components and spread, or None),
        ``lacking_share`` and ``lacking_ratio`` (measured, not used).
    """
    kind = _kind(str(effect.get("label")))
    own = OWN_PATTERNS.get(kind, ())
    readings = [rd for rd in trace.get("readings") or [] if rd["component"].split(": ", 1)[-1] in families]
    # a damaged tooth is read on its comb about the mesh: its shaft's orders 1-6 also hold the two models'
    # own difference (the input's order 4 on the pinion accelerometers, 35-96 sigma in true rows, Sec. 8.48)
    pattern_readings = [
        rd for rd in readings if not (kind == "tooth_damage" and "shaft orders" in rd["component"])
    ]
    # a rest on one order alone (>= SINGLE_ORDER of the profile) is not read: the two models' difference at
    # an order looks the same (the input's order 4 after a true eccentricity claim, 99 %, Sec. 8.48)
    pattern_readings = [
        rd for rd in pattern_readings if max((rd.get("profile") or {}).values(), default=1.0) < SINGLE_ORDER
    ]
    tests = []
    if any(rd.get("profile") and not set(rd.get("patterns") or ()) & set(own) for rd in pattern_readings):
        tests.append("pattern")
    torsional = _torsional(kind, trace, families)
    if torsional:
        tests.append("torsional")
    short = _own_order_spread(kind, trace, families)
    if short:
        tests.append("own_order")
    comps = [c for c in trace.get("components") or [] if c.get("family") in families]
    lack = float(sum(c.get("model_lacks_share", 0.0) for c in comps))
    explained = float(effect["error_before"]) ** 2 - float(effect["error_after"]) ** 2
    e2 = float(trace.get("error", float("nan"))) ** 2
    return {
        "suspect": bool(families and tests),
        "tests": tests,
        "families": families,
        "own_patterns": list(own),
        "readings": readings,
        "torsional": torsional,
        "own_order": short,
        "lacking_share": lack,
        "lacking_ratio": float(lack * e2 / explained) if explained > 0 else float("nan"),
    }


def check_claims(effects: list[dict[str, Any]], trace: dict[str, Any], cfg: Any) -> list[dict[str, Any]]:
    """:func:`claim_check` of every claimed effect (``[]`` without a trace)."""
    if not trace:
        return []
    return [{"label": e.get("label"), **claim_check(e, trace, own_families(e, cfg))} for e in effects]


def _sentence(label: str, chk: dict[str, Any]) -> str:
    text = f"{label} is not a confident finding: "
    parts = []
    rd = next(
        (r for r in chk["readings"] if not set(r.get("patterns") or ()) & set(chk["own_patterns"])), None
    )
    if "pattern" in chk["tests"] and rd is not None:
        pats = "/".join(rd.get("patterns") or []) or "no simple pattern"
        prof = ", ".join(f"{k} {v:.0%}" for k, v in (rd.get("profile") or {}).items() if v >= 0.05)
        parts.append(
            f"the residual it leaves in its own signature ({rd['component']}, {rd['share']:.0%} of the final "
            f"error, where the record holds more than the model) reads {pats} ({prof}), not its own "
            f"{'/'.join(chk['own_patterns'])}"
        )
        outside = ", ".join(rd.get("outside_the_library") or [])
        if outside:
            parts[-1] += f": the signature of {outside} (not in the library)"
    tq = chk.get("torsional")
    if tq:
        parts.append(
            f"the record's {tq['at']} on {tq['channel']} ({tq['measured_over_noise']:.3g} noise deviations "
            f"against the model's {tq['model_over_noise']:.3g}) is torsional, which a lateral force at a "
            "node does not make: e.g. a Cardan (Hooke's) joint or angular coupling misalignment (not in the "
            "library)"
        )
    sh = chk.get("own_order")
    if sh:
        ratios = ", ".join(f"{c['channel']} {c['ratio']:.2g}" for c in sh["components"])
        parts.append(
            f"the record / model ratio of its own {sh['components'][0]['at']} differs between the lateral "
            f"channels ({ratios}; the fitted model 1): the record's content there takes a direction or path "
            "that a lateral force at that node does not make (e.g. a torque fluctuation reaching the "
            "bearings through the mesh force, or a one-sided support; not in the library)"
        )
    return text + "; ".join(parts)


def apply_claim_checks(result: Any, cfg: Any) -> None:
    """Mark the claims :func:`check_claims` finds suspect (the hook at the end of ``Calibrator.run``).

    A suspect claim keeps its place and parameters in ``result.effects``; its ``status`` becomes
    ``"suspect"``, its ``confidence`` at most :data:`SUSPECT_CONFIDENCE`, and a note and the conclusion say
    why. Every claim's check is kept in ``result.claim_checks`` (the JSON's ``claim_checks``).
    """
    checks = check_claims([e.as_dict() for e in result.effects], result.residual_trace, cfg)
    if not checks:  # no trace (or no claim): nothing to check
        return
    result.claim_checks = [{k: v for k, v in c.items() if k != "readings"} for c in checks]
    said = []
    for e, chk in zip(result.effects, checks, strict=True):
        if not chk["suspect"]:
            continue
        e.status = "suspect"
        e.confidence = min(e.confidence, SUSPECT_CONFIDENCE)
        text = _sentence(e.label, chk)
        result.notes.append(text)
        said.append(text)
    if said:
        result.conclusion = f"{result.conclusion}; " + "; ".join(said)
