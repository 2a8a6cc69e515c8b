"""Gear misalignment and tooth wear on data the model did not make (issue 11,
docs/history/calibration_sessions.md Sec. 8.8).

* A ``lumped_gearbox`` record (0.6 s, 3000 rpm, teeth in contact) of a gear tilted by 1 mrad: the
  misalignment candidate of the nominal model (linear axial part for the phase, full-simulation grid
  for the angle) finds the angle within 25 % and explains the record better on the gear than on the
  pinion (the axial force sits at the gear's order 1).
* The rule that a mesh-periodic candidate (wear, misalignment) must gain on the synchronous features:
  properties of the balanced weights of ``Score.balanced_chi2`` on random records (envelope gains are
  not synchronous, gains add, equal gain per feature weighs equally across families), and an
  envelope-only gain (the kind of the healthy 225 C record's tooth-wear claim) refused however large.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.calibration.candidates_misalignment import fit_gear_misalignment
from gear_rotor_sim.calibration.candidates_wear import periodic_signature_present, synchronous_gain
from gear_rotor_sim.calibration.fit import Calibrator, CandidateFit, FitSettings
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.calibration.residual import Score
from gear_rotor_sim.faults import GearMisalignment, ToothWear


@pytest.fixture(scope="module")
def misaligned(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from lumped_gearbox import make_record, write_record

    rec = make_record(3000.0, 25.0, ["gear_misalignment:member=gear,angle_rad=1e-3"], duration_s=0.6, seed=11)
    return write_record(tmp_path_factory.mktemp("misalignment") / "mis.csv", rec)


def test_misalignment_angle_from_an_independent_record(misaligned: Path) -> None:
    cal = Calibrator(load_measurement(misaligned))
    cal._setup()
    cal._refit_transfer(cal._features(cal.base_raw))
    cal.n_total = cal.cmp.score(cal._features(cal.base_raw)).n_total
    cur = cal._features(cal.base_raw)
    gear = fit_gear_misalignment(cal, GearMisalignment(member="gear"), cur)
    pinion = fit_gear_misalignment(cal, GearMisalignment(member="pinion"), cur)
    assert gear is not None and pinion is not None
    angle = gear.effect.angle_rad
    assert abs(angle - 1e-3) <= 0.25e-3, angle
    assert gear.score.balanced_chi2 < pinion.score.balanced_chi2
    assert gear.score.balanced_chi2 < cal.cmp.score(cur).balanced_chi2


FAMILIES = ("order", "envelope", "static")


def _score(chi2: dict[str, float], n: dict[str, int]) -> Score:
    return Score(dict(chi2), dict(n), np.ones(6), {}, {})


def _random_case(rng: np.random.Generator) -> tuple[dict[str, int], dict[str, float], dict[str, float]]:
    """Feature counts, chi^2 before a candidate and per-family chi^2 gains, all drawn at random: the
    properties below follow from the definitions and must hold for any record."""
    n = {"order": int(rng.integers(50, 5000)), "envelope": int(rng.integers(50, 5000))}
    n["static"] = int(rng.integers(1, 10))
    before = {f: float(rng.uniform(2.0, 50.0)) * n[f] for f in FAMILIES}
    gain = {f: float(rng.uniform(0.05, 0.9)) * before[f] for f in FAMILIES}
    return n, before, gain


def _after(n: dict[str, int], before: dict[str, float], gain: dict[str, float], *fams: str) -> Score:
    """The score after a candidate that gains ``gain[f]`` on the families ``fams`` only."""
    return _score({f: before[f] - (gain[f] if f in fams else 0.0) for f in FAMILIES}, n)


def test_synchronous_gain_follows_the_balanced_weights() -> None:
    """From the definition of ``Score.balanced_chi2`` (spectral families weighted to equal total
    counts, the channel means with weight 1 each), on random records: an envelope-only gain has no
    synchronous part and an order- or mean-only gain is all synchronous; the gains add over the
    families; two spectral families with the same gain per feature carry the same weighted gain,
    whatever their counts; a mean's gain counts once."""
    rng = np.random.default_rng(20261126)
    for _ in range(25):
        n, before, gain = _random_case(rng)
        ref = _score(before, n)

        def close(a: float, b: float, ref: Score = ref) -> bool:
            # the gains are differences of balanced chi^2 values: round-off relative to those
            return abs(a - b) <= 1e-12 * ref.balanced_chi2

        parts = {f: synchronous_gain(ref, _after(n, before, gain, f)) for f in FAMILIES}
        assert close(parts["envelope"][0], 0.0) and parts["envelope"][1] > 0.0
        for f in ("order", "static"):
            assert close(parts[f][0], parts[f][1])
        assert close(parts["static"][1], gain["static"])
        sync, whole = synchronous_gain(ref, _after(n, before, gain, *FAMILIES))
        assert close(whole, sum(p[1] for p in parts.values()))
        assert close(sync, parts["order"][0] + parts["static"][0])
        # the same gain per feature on both spectral families: equal weighted gains
        per_feature = {**gain, "envelope": gain["order"] / n["order"] * n["envelope"]}
        eq = {f: synchronous_gain(ref, _after(n, before, per_feature, f))[1] for f in ("order", "envelope")}
        assert close(eq["order"], eq["envelope"])


@pytest.mark.parametrize("effect", [ToothWear(wear_depth_m=2.2e-6), GearMisalignment(member="gear")])
def test_periodic_candidates_need_synchronous_evidence(effect: object) -> None:
    """A mesh-periodic effect acts alike on every mesh cycle, so its response is synchronous with the
    shafts: a candidate whose gain sits on the envelope while its orders get worse is refused however
    large that gain (the healthy 225 C record's wear claim was of this kind); a gain on the orders and
    the channel means beyond the BIC penalty (``bic_threshold + k ln n``) is claimed; a synchronous
    gain within the penalty is refused even with nothing elsewhere. Random records, no fitted numbers."""
    rng = np.random.default_rng(11)
    for _ in range(10):
        n, before, gain = _random_case(rng)
        ref = _score(before, n)
        cal = SimpleNamespace(fit=FitSettings(), notes=[])
        penalty = cal.fit.bic_threshold + math.log(ref.n_total)
        # envelope-only gain of many penalties, orders slightly worse
        envelope_only = _score(
            {**before, "envelope": 0.05 * before["envelope"], "order": 1.01 * before["order"]}, n
        )
        assert synchronous_gain(ref, envelope_only)[1] > 10.0 * penalty
        assert not periodic_signature_present(cal, CandidateFit(effect, envelope_only, None, 1, {}), ref)
        assert "synchronous features" in cal.notes[-1]
        # the gain on the orders and the means, many penalties
        periodic = _after(n, before, gain, "order", "static")
        assert synchronous_gain(ref, periodic)[0] > 10.0 * penalty
        assert periodic_signature_present(cal, CandidateFit(effect, periodic, None, 1, {}), ref)
        # a synchronous gain of half the penalty, nothing elsewhere
        small = _score({**before, "static": before["static"] - 0.5 * penalty}, n)
        assert not periodic_signature_present(cal, CandidateFit(effect, small, None, 1, {}), ref)
        # other candidates are not judged by this rule
        assert periodic_signature_present(cal, CandidateFit(object(), envelope_only, None, 1, {}), ref)


def test_wear_needs_a_static_offset_and_must_reduce_it() -> None:
    """Wear's model-robust signature is the DTE mean (issue 11 item 3): refused where the channel means
    agree with the unworn model (chi^2 within 9 per mean + 25) or where it fits them worse."""
    from types import SimpleNamespace

    from gear_rotor_sim.calibration.candidates_wear import wear_static_inconsistency
    from gear_rotor_sim.faults import MassUnbalance, ToothWear

    def score(chi2: float) -> SimpleNamespace:
        return SimpleNamespace(chi2={"static": chi2}, n={"static": 5})

    off = score(400.0)  # 5 means, about 9 sigma each: beyond 9 * 5 + 25 = 70
    fit = SimpleNamespace(effect=ToothWear(wear_depth_m=20e-6), score=score(30.0))
    assert wear_static_inconsistency(fit, off) == ""
    worse = SimpleNamespace(effect=ToothWear(wear_depth_m=20e-6), score=score(500.0))
    assert "fit worse" in wear_static_inconsistency(worse, off)
    assert "agree with the unworn model" in wear_static_inconsistency(fit, score(60.0))
    other = SimpleNamespace(effect=MassUnbalance(), score=score(500.0))
    assert wear_static_inconsistency(other, off) == ""
