"""The step count of the calibration's model runs from the model's own convergence (issue 11;
docs/history/calibration_sessions.md Sec. 8.24, ``calibration/model_steps.py``).

Truths the rule is held to: a constructed step error whose size is known (the rule must stop at the
first count whose error is below the stated fraction of the noise); on the FE paper gearbox, a run at
256 steps per mesh period (the chosen count must agree with it), the known non-periodic share of the
healthy model at 4500 rpm / 75 C at 32 steps (Sec. 8.22, cause B: 20 % at ``bearing2_fx``), and
operating points where 32 steps are converged and must be kept (3000 rpm in contact, 8000 rpm where the
teeth separate and the dt rule takes more steps anyway).
"""

from __future__ import annotations

import numpy as np
import pytest

from gear_rotor_sim.calibration.features_orders import remove_synchronous
from gear_rotor_sim.calibration.model_steps import (
    STEP_NOISE_FRACTION,
    converged_steps_per_mesh,
    robust_noise,
)

FS = 20000.0


def _periodic(n: int, f: float) -> np.ndarray:
    t = np.arange(n) / FS
    return np.column_stack([np.sin(2 * np.pi * 3 * f * t) + 0.3 * np.cos(2 * np.pi * 7 * f * t)])


def test_rule_stops_at_the_first_count_whose_step_error_is_below_the_noise_fraction() -> None:
    """A step error that halves with the step (first order) on a non-synchronous tone: with noise
    sigma and error amplitude A / n, the difference between n and 2n has RMS A / (2 n sqrt 2); the rule
    must keep the first n where that is <= STEP_NOISE_FRACTION sigma, computed here by hand."""
    f, n_s = 50.0, 20000
    t = np.arange(n_s) / FS
    sigma = 0.1
    rng = np.random.default_rng(1)
    measured = _periodic(n_s, f) + sigma * rng.standard_normal((n_s, 1))
    amp = 30.0  # error amplitude at n = 1
    tone = np.sin(2 * np.pi * 1234.567 * t)  # not a harmonic of the 50 Hz shaft

    def run(n: int) -> np.ndarray:
        return _periodic(n_s, f) + (amp / n) * tone[:, None]

    choice = converged_steps_per_mesh(run, measured, [0], ["x"], FS, [f], start=32)
    # difference RMS between n and 2n: amp / (2 n) / sqrt(2); first n with it <= the fraction of sigma
    expected = next(n for n in (32, 64, 128) if amp / (2 * n) / np.sqrt(2) <= STEP_NOISE_FRACTION * sigma)
    assert choice.steps_per_mesh == expected == 128
    assert choice.converged
    ratios = [c["worst_ratio"] for c in choice.checks]
    want = [amp / (2 * n) / np.sqrt(2) / sigma for n in (32, 64, 128)]
    assert np.allclose(ratios, want, rtol=0.05)
    # a synchronous step error (lines at shaft orders, as at 3000 rpm) is not the envelope's concern
    sync = converged_steps_per_mesh(
        lambda n: _periodic(n_s, f) * (1 + 10.0 / n), measured, [0], ["x"], FS, [f], start=32
    )
    # the difference 32 vs 64 is 0.078 x the signal (1.2 sigma as a whole signal): removed to < 1 %
    whole = np.std(_periodic(n_s, f)[:, 0] * (10.0 / 32 - 10.0 / 64)) / sigma
    assert whole > STEP_NOISE_FRACTION
    assert sync.steps_per_mesh == 32 and sync.checks[0]["worst_ratio"] < 0.01 * whole
    # an error that never converges stops at the finest count and says so
    stuck = converged_steps_per_mesh(
        lambda n: _periodic(n_s, f) + (n % 3) * tone[:, None], measured, [0], ["x"], FS, [f], max_steps=128
    )
    assert stuck.steps_per_mesh == 128 and not stuck.converged


def test_robust_noise_ignores_sparse_impacts() -> None:
    """The noise a bearing channel's comparison is scaled by: 1.4826 MAD of the record's non-synchronous
    part, which sparse impacts (a bearing defect) hardly move while they double the RMS."""
    rng = np.random.default_rng(2)
    x = rng.standard_normal(40000)
    imp = np.zeros_like(x)
    imp[::74] = 30.0  # 270 impacts per second at 20 kHz
    assert abs(robust_noise(x) - 1.0) < 0.03
    assert abs(robust_noise(x + imp) - 1.0) < 0.06
    assert np.std(x + imp) > 2.0


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory) -> dict[tuple[float, float], object]:
    from gear_rotor_sim.calibration.measurement import load_measurement
    from lumped_gearbox import make_record, write_record

    out = tmp_path_factory.mktemp("steps")
    recs = {}
    for speed, temp in ((4500.0, 75.0), (3000.0, 25.0), (8000.0, 25.0)):
        csv = write_record(
            out / f"h{speed:.0f}.csv", make_record(speed, temp, [], duration_s=0.6, seed=int(speed) + 3)
        )
        recs[(speed, temp)] = load_measurement(csv)
    return recs


@pytest.mark.parametrize(
    ("op", "expected"), [((4500.0, 75.0), 64), ((3000.0, 25.0), 32), ((8000.0, 25.0), 32)]
)
def test_fe_model_steps_against_a_finer_run(records: dict, op: tuple[float, float], expected: int) -> None:
    """On the FE paper gearbox (independent 0.6 s healthy records give the noise): the count the
    calibrator chooses, and its healthy model's non-synchronous part against a 256-step run."""
    from gear_rotor_sim.calibration.fit import Calibrator

    m = records[op]
    cal = Calibrator(m)
    cal._setup()
    choice = cal.step_choice
    assert choice is not None and choice.converged
    assert choice.steps_per_mesh == expected, choice.checks
    assert cal.runner.steps_per_mesh == expected
    env = [c for c, n in enumerate(m.model_channels) if n.startswith("bearing")]
    shafts = [sh.ratio * cal.cmp.speed_hz for sh in cal.cmp.shafts]

    def nonsync(n: int) -> np.ndarray:
        cal.runner.steps_per_mesh = n
        out = cal.runner.outputs(cal._raw(()))
        return np.column_stack([remove_synchronous(out[:, c], m.sample_rate_hz, shafts) for c in env])

    chosen, truth = nonsync(expected), nonsync(256)
    noise = np.array([robust_noise(remove_synchronous(m.data[:, c], m.sample_rate_hz, shafts)) for c in env])
    # the chosen count agrees with the 256-step run within the rule's fraction of the noise
    assert np.all(np.std(chosen - truth, axis=0) <= STEP_NOISE_FRACTION * noise)
    fx = m.model_channels.index("bearing2_fx")
    rms = np.std(cal.runner.outputs(cal._raw(()))[:, fx])
    share_truth = np.std(truth[:, env.index(fx)]) / rms
    if op == (4500.0, 75.0):
        # cause B: at 32 steps the healthy model holds a non-synchronous fifth of its RMS, numerically
        coarse = nonsync(32)
        assert np.std(coarse[:, env.index(fx)]) / rms > 0.1
        assert np.std(coarse - truth, axis=0)[env.index(fx)] > 5 * noise[env.index(fx)]
    # the converged model is periodic (below the envelope's 1 % limit) at every point
    assert share_truth < 0.01
    assert np.std(chosen[:, env.index(fx)]) / rms < 0.01
