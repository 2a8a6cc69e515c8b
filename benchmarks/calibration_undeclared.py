"""Calibration on records that hold an effect nobody declared (issue 11).

A user's measurement holds things the sidecar does not say: an encoder zero, a sensor mounted the other
way, x and y swapped, a wrong sensitivity, mains hum, a channel delayed in the acquisition, a clipped
channel, a machine whose bearings are stiffer or softer than nominal, more noise, a short record. Each
record here is a ``lumped_gearbox`` record of the issue-11 table (same generator, seed and sampling as
``benchmarks/calibration_independent.py``, so the correctly declared result of the same record is that
table's row) with ONE such effect added: in the measurement chain by post-processing the noisy record
(the generator is never changed), or through the generator's own inputs (``bearing_stiffness`` fault,
noise level, duration). Session 18 added the acquisition chain's disturbances (spikes, a mount resonance,
coloured noise, dropouts, NaN, time-base gaps and repeats, a gain modulation: ``undeclared_disturbances.py``)
and base records at other seeds and 8000 rpm (:data:`BASES`). It is then diagnosed by
``gear-rotor-sim calibrate RECORD --json``.

What is asked (docs/history/calibration_sessions.md Sec. 8.43): the calibration either explains the
effect (a baseline update, or a library effect with the right meaning) or says plainly that it cannot
(an ``issues`` entry naming the channel), and never names a wrong fault with confidence. Verdict per record:
healthy: nothing in ``effects``; fault: named first (right wheel / tooth), main parameter within
25 %, error at least halved (``calibration_independent.judge``). Besides, ``issues_true``: does an
``issues`` entry name the disturbed channel (effects on one channel), or is it ``-`` (effects of the
whole record, which the verdict alone judges). A refusal (exit status 2) whose message names the disturbed
field is ``REFUSED`` and counts as a pass; ``wrong_claim`` counts a library effect on a healthy record or a
wrong effect named first.

Usage::

    python benchmarks/calibration_undeclared.py [--jobs N] [--out DIR] [--cases SUBSTR ...]
        [--baseline | --only-baseline]
    python benchmarks/calibration_undeclared.py --from-results DIR [DIR ...]   # re-render saved results
    python benchmarks/calibration_undeclared.py --list                          # the cases, no calibration
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import calibration_independent as ci
import undeclared_disturbances as ud
import undeclared_probe as up

from lumped_gearbox import CONTACT_RPM, RATTLE_RPM, make_record, write_record
from lumped_gearbox.record import Record

#: the records of the issue-11 table this benchmark disturbs: tag -> (fault or None, the table's seed, speed)
BASES: dict[str, tuple[str | None, int, float]] = {
    "healthy": (None, 34, CONTACT_RPM),  # healthy_3000rpm_25C
    "tooth_pinion": (ci.FAULTS[0], 11, CONTACT_RPM),  # contact_tooth_damage_pinion: pinion tooth 7, depth 0.4
    "gear_ecc": (ci.FAULTS[3], 14, CONTACT_RPM),  # contact_gear_eccentricity: 20 um
    "unbalance": (ci.FAULTS[4], 15, CONTACT_RPM),  # contact_mass_unbalance: 3e-4 kg m
    "wear": (ci.FAULTS[6], 17, CONTACT_RPM),  # contact_tooth_wear: 20 um
    "outer_race": (ci.FAULTS[8], 19, CONTACT_RPM),  # contact_outer_race_defect: 300 N
    "ball": (ci.FAULTS[10], 21, CONTACT_RPM),  # contact_ball_defect: 300 N
    "healthy_8000": (None, 35, RATTLE_RPM),  # healthy_8000rpm_25C
    "healthy_125C": (None, 36, CONTACT_RPM),  # healthy_3000rpm_125C (the axial force's mean 1.8 kN)
}
#: a base record's declared temperature where it is not 25 C
BASE_TEMPERATURE_C: dict[str, float] = {"healthy_125C": 125.0}

#: a disturbance applied to the noisy record in place (data, time axis) at sample rate ``fs``
Post = Callable[[Record, float], None]


def offset(col: str, value: float | None = None, rms_fraction: float | None = None) -> Post:
    """Add a constant to one column: ``value`` (SI) or ``rms_fraction`` x its RMS about the mean."""

    def post(rec: Record, fs: float) -> None:
        data = rec.data
        x = data[col]
        data[col] = x + (value if value is not None else float(rms_fraction or 0.0) * float(np.std(x)))

    return post


def gain(col: str, factor: float) -> Post:
    """Multiply one column (a wrong sensitivity; a sign flip is ``factor = -1``)."""

    def post(rec: Record, fs: float) -> None:
        rec.data[col] = factor * rec.data[col]

    return post


def swap(a: str, b: str) -> Post:
    """Exchange two columns (x and y of a sensor swapped in the wiring or the sidecar)."""

    def post(rec: Record, fs: float) -> None:
        data = rec.data
        data[a], data[b] = data[b], data[a]

    return post


def mains(cols: tuple[str, ...], hz: float = 50.0, rms_fraction: float = 0.5) -> Post:
    """Add a mains line ``sqrt(2) * rms_fraction * RMS`` at ``hz`` (phase 0.3 rad) to each column."""

    def post(rec: Record, fs: float) -> None:
        data = rec.data
        for c in cols:
            x = data[c]
            t = np.arange(x.size) / fs
            amp = math.sqrt(2.0) * rms_fraction * float(np.std(x))
            data[c] = x + amp * np.sin(2.0 * math.pi * hz * t + 0.3)

    return post


def delay(col: str, samples: int) -> Post:
    """Delay one column by whole samples (the first sample repeated at the start)."""

    def post(rec: Record, fs: float) -> None:
        x = rec.data[col]
        rec.data[col] = np.concatenate([np.full(samples, x[0]), x[:-samples]])

    return post


def clip(col: str, fraction: float = 0.8) -> Post:
    """Clip one column at ``fraction`` of its largest deviation from the mean (both signs)."""

    def post(rec: Record, fs: float) -> None:
        x = rec.data[col]
        m = float(np.mean(x))
        lim = fraction * float(np.max(np.abs(x - m)))
        rec.data[col] = np.clip(x, m - lim, m + lim)

    return post


@dataclass(frozen=True)
class Undeclared:
    """One undeclared effect and the table records it is added to."""

    name: str
    what: str
    bases: tuple[str, ...]
    channel: str | tuple[str, ...] | None = None  # the disturbed column(s) (issues are checked for one)
    post: Post | None = None
    record_kw: dict[str, Any] = field(default_factory=dict)  # make_record keywords (noise, duration_s)
    extra_fault: str | None = None  # a generator fault that is a baseline property, not a fault
    keyword: str | None = None  # a word the naming issue must hold too (other notes name channels as well)


#: the record's data columns (lumped_gearbox.record.SIDECAR_CHANNELS)
ALL_COLUMNS = ("dte", "bearing2_fx", "bearing2_fy", "bearing2_fz", "node5_ax", "node5_ay")

#: in the order of how likely a real user's data holds them
EFFECTS: list[Undeclared] = [
    Undeclared(
        "declared",
        "nothing undeclared (the table's record)",
        ("healthy", "tooth_pinion", "gear_ecc", "wear", "outer_race"),
    ),
    Undeclared(
        "dte_offset_+5um",
        "DTE encoder zero +5 um",
        ("healthy", "wear", "tooth_pinion"),
        "dte",
        offset("dte", 5e-6),
    ),
    Undeclared(
        "dte_offset_-5um",
        "DTE encoder zero -5 um",
        ("healthy", "wear", "tooth_pinion"),
        "dte",
        offset("dte", -5e-6),
    ),
    Undeclared(
        "flip_node5_ay",
        "accelerometer node5_ay mounted the other way (sign flip)",
        ("healthy", "gear_ecc", "tooth_pinion"),
        "node5_ay",
        gain("node5_ay", -1.0),
    ),
    Undeclared(
        "flip_bearing2_fy",
        "force sensor bearing2_fy sign flipped",
        ("healthy", "gear_ecc"),
        "bearing2_fy",
        gain("bearing2_fy", -1.0),
    ),
    Undeclared(
        "swap_node5_axy",
        "accelerometer x and y swapped",
        ("healthy", "gear_ecc"),
        "node5_a",
        swap("node5_ax", "node5_ay"),
    ),
    Undeclared(
        "gain_x0.5_node5_ay",
        "accelerometer node5_ay sensitivity x0.5",
        ("healthy", "gear_ecc"),
        "node5_ay",
        gain("node5_ay", 0.5),
    ),
    Undeclared(
        "gain_x2_bearing2_fx",
        "force sensor bearing2_fx sensitivity x2",
        ("healthy", "outer_race"),
        "bearing2_fx",
        gain("bearing2_fx", 2.0),
    ),
    Undeclared(
        "dc_node5_ax",
        "accelerometer node5_ax DC offset of 1 RMS",
        ("healthy", "gear_ecc"),
        "node5_ax",
        offset("node5_ax", rms_fraction=1.0),
    ),
    Undeclared(
        "mains_50hz",
        "50 Hz mains line at 0.5 RMS on both accelerometers (= the pinion's shaft rate at 3000 rpm)",
        ("healthy", "outer_race"),
        "node5_a",
        mains(("node5_ax", "node5_ay")),
    ),
    Undeclared(
        "skew_node5_ay_3",
        "node5_ay delayed by 3 samples",
        ("healthy", "tooth_pinion"),
        "node5_ay",
        delay("node5_ay", 3),
    ),
    Undeclared(
        "clip_bearing2_fy_0.8",
        "bearing2_fy clipped at 80 % of its peak deviation",
        ("healthy", "outer_race"),
        "bearing2_fy",
        clip("bearing2_fy", 0.8),
    ),
    Undeclared(
        "bearing_stiffness_x0.7",
        "bearings 0.7 x the nominal stiffness (judged as a baseline update)",
        ("healthy", "gear_ecc"),
        extra_fault="bearing_stiffness:scale=0.7",
    ),
    Undeclared(
        "noise_10pct",
        "noise 10 % of each channel's RMS (the table: 2-5 %)",
        ("healthy", "tooth_pinion"),
        record_kw={"noise": (0.10, 0.10)},
    ),
    Undeclared(
        "short_0.5s",
        "record 0.5 s instead of 2 s",
        ("healthy", "tooth_pinion"),
        record_kw={"duration_s": 0.5},
    ),
    # session 18 (rnoise9, Sec. 8.47): disturbances of the acquisition chain
    Undeclared(
        "spikes_bearing2_fy",
        "random spikes on bearing2_fy: 20 per second, 10-50 x its noise, 1-3 samples",
        ("healthy", "tooth_pinion", "outer_race", "ball", "unbalance", "healthy_8000"),
        "bearing2_fy",
        ud.spikes(("bearing2_fy",)),
        keyword="spike",
    ),
    Undeclared(
        "spikes_common",
        "common-mode spikes on every channel at the same times: 20 per second, 10-50 x each noise, "
        "1-3 samples",
        ("healthy", "outer_race", "ball", "healthy_8000"),
        ALL_COLUMNS,
        ud.spikes(ALL_COLUMNS),
        keyword="spike",
    ),
    Undeclared(
        "mount_resonance_node5_ay",
        "node5_ay on a compliant mount: resonance at 6 kHz, Q 20",
        ("healthy", "tooth_pinion", "ball"),
        "node5_ay",
        ud.mount_resonance("node5_ay"),
    ),
    Undeclared(
        "pink_noise",
        "every channel's noise 1/f (pink) instead of white, same standard deviation",
        # session 20 (Sec. 8.53) added the 8000 rpm, outer-race and gear-eccentricity records
        ("healthy", "tooth_pinion", "ball", "healthy_8000", "outer_race", "gear_ecc"),
        post=ud.pink_noise(),
    ),
    Undeclared(
        "dropout_zero_bearing2_fx",
        "bearing2_fx reads 0 for 30 ms from t = 0.9 s",
        ("healthy", "tooth_pinion", "ball"),
        "bearing2_fx",
        ud.dropout("bearing2_fx"),
    ),
    Undeclared(
        "dropout_hold_node5_ay",
        "node5_ay holds its value for 30 ms from t = 0.9 s",
        ("healthy", "tooth_pinion"),
        "node5_ay",
        ud.dropout("node5_ay", hold=True),
    ),
    Undeclared(
        "nan_node5_ax",
        "5 single NaN samples on node5_ax",
        ("healthy",),
        "node5_ax",
        ud.nan_samples("node5_ax"),
    ),
    Undeclared(
        "time_gap_50ms",
        "50 ms of samples lost at t = 1 s (the time column jumps)",
        ("healthy",),
        "time_s",
        ud.time_gap(),
    ),
    Undeclared(
        "repeat_block_20ms",
        "the 20 ms before t = 1 s delivered twice with their time stamps (the time column steps back)",
        ("healthy",),
        "time_s",
        ud.repeated_block(),
    ),
    Undeclared(
        "repeat_block_20ms_retimed",
        "the 20 ms before t = 1 s delivered twice, the time column running on",
        ("healthy", "tooth_pinion"),
        (*ALL_COLUMNS, "every column"),  # a whole-row effect: named as "every column"
        ud.repeated_block(retime=True),
    ),
    Undeclared(
        "gain_mod_bearing2_fy",
        "bearing2_fy gain modulated 8 % at 3.7 Hz (a loose connector)",
        ("healthy", "outer_race", "ball"),
        "bearing2_fy",
        ud.gain_modulation("bearing2_fy"),
    ),
]


def mains_cases() -> list[Undeclared]:
    """Session 19 (rspike10, history Sec. 8.51): mains pickup on one channel, on and near a shaft order.

    At 3000 rpm the input shaft turns at 50 Hz: a 50 Hz hum and its odd harmonics sit on its orders 1, 3
    and 5; at 8000 rpm (133.3 Hz, output 78.9 Hz) on no order. 60 Hz lies 0.82 Hz from the output shaft's
    order 2 (59.18 Hz) at 3000 rpm: near an order, resolved from it on a 2 s record."""
    return [
        Undeclared(
            "mains_50hz_odd_node5_ay",
            "50 Hz mains with its 3rd and 5th harmonics on node5_ay (0.5, 0.2, 0.1 RMS)",
            ("healthy", "unbalance", "outer_race", "healthy_8000"),
            "node5_ay",
            ud.mains_hum("node5_ay", 50.0, {1: 0.5, 3: 0.2, 5: 0.1}),
            keyword="mains",
        ),
        Undeclared(
            "mains_60hz_node5_ay",
            "60 Hz mains on node5_ay (0.5 RMS), 0.82 Hz from the output shaft's order 2 at 3000 rpm",
            ("healthy", "tooth_pinion", "ball"),
            "node5_ay",
            ud.mains_hum("node5_ay", 60.0),
            keyword="mains",
        ),
    ]


def sensor_transfer_cases() -> list[Undeclared]:
    """Session 19 (rsensor10, Sec. 8.50): a channel's own slow gain on other channels and speeds, and an
    accelerometer's sensitivity x2."""
    return [
        Undeclared(
            "gain_mod_node5_ay",
            "node5_ay gain modulated 8 % at 3.7 Hz (an accelerometer: no static carrier)",
            ("healthy", "tooth_pinion"),
            "node5_ay",
            ud.gain_modulation("node5_ay"),
        ),
        Undeclared(
            "gain_mod_dte",
            "dte gain modulated 8 % at 3.7 Hz (the wear depth is read from its mean)",
            ("wear",),
            "dte",
            ud.gain_modulation("dte"),
        ),
        Undeclared(
            "gain_mod_bearing2_fy_8000",
            "bearing2_fy gain modulated 8 % at 3.7 Hz where the teeth separate",
            ("healthy_8000",),
            "bearing2_fy",
            ud.gain_modulation("bearing2_fy"),
        ),
        Undeclared(
            "gain_x2_node5_ay",
            "accelerometer node5_ay sensitivity x2",
            ("healthy", "gear_ecc"),
            "node5_ay",
            gain("node5_ay", 2.0),
        ),
    ]


#: the bases every session-20 probe runs on: healthy at 3000 and 8000 rpm, three contact faults
PROBE_BASES = ("healthy", "healthy_8000", "tooth_pinion", "outer_race", "gear_ecc")


def probe_cases() -> list[Undeclared]:
    """Session 20 (rprobe11, history Sec. 8.53): a sample clock off, force-sensor zeros, mount resonances
    on both accelerometers, coarse quantisation, a slow baseline wander, cross-talk and a force channel's
    skew (and ``pink_noise`` above on three more records)."""
    clock_kw, clock_post = up.clock_error(0.003)
    return [
        Undeclared(
            "fz_offset_+50N",
            "bearing2_fz zero offset +50 N (the axial force is the model's thermometer: 2.7 C)",
            (*PROBE_BASES, "healthy_125C"),
            "bearing2_fz",
            offset("bearing2_fz", 50.0),
            keyword="zero offset",
        ),
        Undeclared(
            "crosstalk_fy_fz_5pct",
            "5 % of bearing2_fy summed into bearing2_fz (a tri-axial load cell's cross-axis sensitivity)",
            PROBE_BASES,
            "bearing2_fz",
            up.crosstalk("bearing2_fy", "bearing2_fz", 0.05),
            keyword="cross-talk",
        ),
        Undeclared(
            "clock_+0.3pct",
            "sample clock 0.3 % fast: generated at 20060 Hz, the file says 20000 Hz",
            PROBE_BASES,
            record_kw=clock_kw,
            post=clock_post,
        ),
        Undeclared(
            "skew_bearing2_fx_3",
            "bearing2_fx delayed by 3 samples against the other channels",
            PROBE_BASES,
            "bearing2_fx",
            delay("bearing2_fx", 3),
            keyword="delay",
        ),
        Undeclared(
            "mount_res_node5_axy",
            "node5_ax and node5_ay on compliant mounts: resonance at 6 kHz, Q 15",
            PROBE_BASES,
            ("node5_ax", "node5_ay"),
            up.mount_resonances(("node5_ax", "node5_ay")),
            keyword="resonance",
        ),
        Undeclared(
            "fy_offset_-5pct",
            "bearing2_fy zero offset of 5 % of its mean (-67 N on the 3000 rpm healthy record)",
            PROBE_BASES,
            "bearing2_fy",
            offset("bearing2_fy", -67.0),
            keyword="measured mean",
        ),
        Undeclared(
            "quantise_10bit_x8",
            "every channel quantised to 10 bits over +-8 x its peak",
            PROBE_BASES,
            post=up.quantise(10, 8.0),
        ),
        Undeclared(
            "wander_0.3-5Hz",
            "every channel: a random baseline wander at 0.3-5 Hz, 0.2 x its RMS",
            PROBE_BASES,
            post=up.baseline_wander(),
        ),
        Undeclared(
            "crosstalk_ax_ay_10pct",
            "10 % of node5_ax summed into node5_ay (an accelerometer's cross-axis sensitivity)",
            PROBE_BASES,
            "node5_ay",
            up.crosstalk("node5_ax", "node5_ay", 0.10),
            keyword="cross",
        ),
        Undeclared(
            "fz_drift_0-60N",
            "bearing2_fz zero drifting 0 -> 60 N over the record (or a temperature rising 3.3 C)",
            ("healthy", "tooth_pinion", "healthy_125C"),
            "bearing2_fz",
            up.zero_drift("bearing2_fz", 0.0, 60.0),
            keyword="drift",
        ),
    ]


EFFECTS += mains_cases()
EFFECTS += sensor_transfer_cases()
EFFECTS += probe_cases()


def mains_neighbour_cases() -> list[Undeclared]:
    """Session 20 (rmains11, history Sec. 8.54): mains hum split over three channels on the input shaft's
    orders at 3000 rpm, and a neighbouring machine's tones (24.7 Hz = 1482 rpm, and 2x-4x: 49.4 Hz lies
    0.6 Hz from the input shaft's order 1 at 3000 rpm, 98.8 Hz 1.2 Hz from its order 2) on every channel
    through the foundation, or on the accelerometers only."""
    acc = ("node5_ax", "node5_ay")
    return [
        Undeclared(
            "mains_50hz_split3",
            "50 Hz mains at 0.2 RMS on node5_ax, node5_ay and bearing2_fy (each alone a small share)",
            ("healthy", "unbalance", "outer_race"),
            ("node5_ax", "node5_ay", "bearing2_fy"),
            _mains_on(("node5_ax", "node5_ay", "bearing2_fy"), 0.2),
            keyword="mains",
        ),
        Undeclared(
            "neighbour_24.7hz_all",
            "a neighbouring machine's 24.7 Hz and 2x-4x (0.3, 0.15, 0.1, 0.05 RMS) on every channel",
            ("healthy", "tooth_pinion", "unbalance", "outer_race", "ball", "healthy_8000"),
            ALL_COLUMNS,
            ud.neighbour_machine(ALL_COLUMNS),
            keyword="neighbouring",
        ),
        Undeclared(
            "neighbour_24.7hz_acc",
            "a neighbouring machine's 24.7 Hz and 2x-4x on the two accelerometers only",
            ("healthy", "gear_ecc", "unbalance"),
            acc,
            ud.neighbour_machine(acc),
            keyword="neighbouring",
        ),
    ]


def _mains_on(cols: tuple[str, ...], fraction: float) -> Post:
    """50 Hz hum of ``fraction`` x each column's RMS on several columns (``undeclared_disturbances.mains_hum``
    on each)."""
    posts = [ud.mains_hum(c, 50.0, {1: fraction}) for c in cols]

    def post(rec: Record, fs: float) -> None:
        for p in posts:
            p(rec, fs)

    return post


EFFECTS += mains_neighbour_cases()

#: the bases of the session-21 sensor-zero rows (Sec. 8.58): the probe's and contact wear
ZERO_BASES = (*PROBE_BASES, "wear")


def mean_offset(col: str, fraction: float) -> Post:
    """Add ``fraction`` x the column's own mean to it (a zero off by that share of the static load: +0.05
    makes the mean's magnitude 5 % larger)."""

    def post(rec: Record, fs: float) -> None:
        x = rec.data[col]
        rec.data[col] = x + fraction * float(np.mean(x))

    return post


def zero_cases() -> list[Undeclared]:
    """Session 21 (rzero11, history Sec. 8.58): a radial force sensor's zero 5 % of its mean off (either
    sign, x and y), and the session-17/20 DTE zero and axial cross-talk rows on the bases they were not run
    on (healthy 8000 rpm, outer race, gear eccentricity; contact wear); the accelerometers exchanged or one
    x2 on a gear misalignment and an 8000 rpm outer race (session 19 ran them on the healthy and eccentric
    records)."""
    radial = [
        Undeclared(
            f"{c}_zero_{s:+d}pct",
            f"{c} zero off by {s:+d} % of its mean (the mean's magnitude {'larger' if s > 0 else 'smaller'})",
            ZERO_BASES,
            c,
            mean_offset(c, s / 100.0),
            keyword="zero",
        )
        for c in ("bearing2_fy", "bearing2_fx")
        for s in (5, -5)
    ]
    more = [
        Undeclared(
            f"dte_offset_{v:+d}um",
            f"DTE encoder zero {v:+d} um",
            ("healthy_8000", "outer_race", "gear_ecc"),
            "dte",
            offset("dte", v * 1e-6),
        )
        for v in (5, -5)
    ]
    more.append(
        Undeclared(
            "crosstalk_fy_fz_5pct",
            "5 % of bearing2_fy summed into bearing2_fz (a tri-axial load cell's cross-axis sensitivity)",
            ("wear",),
            "bearing2_fz",
            up.crosstalk("bearing2_fy", "bearing2_fz", 0.05),
            keyword="cross-talk",
        )
    )
    accel_bases = ("misalign", "outer_race_8000")
    more += [
        Undeclared(
            "swap_node5_axy",
            "accelerometer x and y swapped",
            accel_bases,
            "node5_a",
            swap("node5_ax", "node5_ay"),
        ),
        Undeclared(
            "gain_x2_node5_ay",
            "accelerometer node5_ay sensitivity x2",
            accel_bases,
            "node5_ay",
            gain("node5_ay", 2.0),
        ),
    ]
    return radial + more


# faults whose reading rests on the accelerometers too (the table's records, same seeds)
BASES["misalign"] = (ci.FAULTS[5], 16, CONTACT_RPM)  # contact_gear_misalignment: 1 mrad
BASES["outer_race_8000"] = (ci.FAULTS[8], 30, RATTLE_RPM)  # rattle_outer_race_defect: 300 N
EFFECTS += zero_cases()


def hum_cases() -> list[Undeclared]:
    """Session 21 (rhum11, history Sec. 8.59): 50 Hz hum on every channel (the input shaft's order 1 at
    3000 rpm), over the faults whose own order-1 content it hides (``mains_50hz_split3`` above: three
    channels)."""
    return [
        Undeclared(
            "mains_50hz_all6",
            "50 Hz mains at 0.2 RMS on all six channels (pickup through every cable)",
            ("healthy", "unbalance", "outer_race"),
            ALL_COLUMNS,
            _mains_on(ALL_COLUMNS, 0.2),
            keyword="mains",
        ),
    ]


EFFECTS += hum_cases()


def clock_skew_cases() -> list[Undeclared]:
    """Session 21 (rclock11, history Sec. 8.57): a sample clock off by 0.1 % and 0.5 % (0.3 %:
    ``probe_cases``) on the probe's bases, and one channel delayed by 1 or 5 samples (3: above) on a force
    channel and on an accelerometer."""
    out = []
    for pct in (0.1, 0.5):
        kw, post = up.clock_error(pct / 100.0)
        out.append(
            Undeclared(
                f"clock_+{pct:g}pct",
                f"sample clock {pct:g} % fast: generated at {20000 * (1 + pct / 100):g} Hz, "
                "the file says 20000 Hz",
                PROBE_BASES,
                record_kw=kw,
                post=post,
            )
        )
    for col in ("bearing2_fx", "node5_ay"):
        for n in (1, 5):
            out.append(
                Undeclared(
                    f"skew_{col}_{n}",
                    f"{col} delayed by {n} sample{'s' if n > 1 else ''} against the other channels",
                    ("healthy", "tooth_pinion"),
                    col,
                    delay(col, n),
                    keyword="delay",
                )
            )
    return out


EFFECTS += clock_skew_cases()


@dataclass(frozen=True)
class Case:
    effect: Undeclared
    base: str

    @property
    def tag(self) -> str:
        return f"{self.effect.name}__{self.base}"

    @property
    def fault(self) -> str | None:
        return BASES[self.base][0]

    def judged(self) -> ci.Case:
        """The table's case type, for ``ci.judge`` (a baseline property is not a fault to name)."""
        temp = BASE_TEMPERATURE_C.get(self.base, 25.0)
        return ci.Case(self.tag, BASES[self.base][2], temp, self.fault, BASES[self.base][1])


def cases() -> list[Case]:
    return [Case(e, b) for e in EFFECTS for b in e.bases]


def make(case: Case, out: Path) -> Path:
    """The table's record (same seed, daq sampling) with the undeclared effect added."""
    faults = [f for f in (case.fault, case.effect.extra_fault) if f]
    kw = {"duration_s": 2.0, **case.effect.record_kw}
    _, seed, speed = BASES[case.base]
    temp = BASE_TEMPERATURE_C.get(case.base, 25.0)
    rec = make_record(speed, temp, faults, seed=seed, sampling="daq", **kw)
    if case.effect.post is not None:
        fs = 1.0 / float(rec.time_s[1] - rec.time_s[0])
        case.effect.post(rec, fs)
    return write_record(out / f"{case.tag}.csv", rec)


def _columns(case: Case) -> tuple[str, ...]:
    col = case.effect.channel
    return () if col is None else (col,) if isinstance(col, str) else col


def _names(text: str, cols: tuple[str, ...], keyword: str | None = None) -> bool:
    return any(c in text for c in cols) and (keyword is None or keyword in text)


def _issues_true(case: Case, res: dict[str, Any]) -> str:
    """``yes`` if an ``issues`` entry (or a refusal's message) names a disturbed column, ``no`` if none
    does, ``-`` for an effect of the whole record."""
    cols = _columns(case)
    if not cols or case.effect.name == "declared":
        return "-"
    kw = case.effect.keyword
    if res.get("failed"):
        return "yes" if _names(str(res.get("stderr", "")), cols) else "no"
    return "yes" if any(_names(str(i), cols, kw) for i in res.get("issues") or []) else "no"


def judge(case: Case, res: dict[str, Any]) -> dict[str, Any]:
    """The table's verdict, and whether the disturbance was named; a refusal (exit status 2) naming the
    disturbed field is ``REFUSED`` (the calibration said plainly that it cannot use the record)."""
    row = ci.judge(case.judged(), res)
    row.update(effect=case.effect.name, base=case.base, issues_true=_issues_true(case, res))
    cols = _columns(case)
    if res.get("failed"):
        msg = str(res.get("stderr", "")).strip().splitlines()
        row["issues"] = msg[-1:] if msg else []
        if row["issues_true"] == "yes":
            row["verdict"] = "REFUSED"
        row["wrong_claim"] = False
        return row
    kw = case.effect.keyword
    row["issues"] = [str(i) for i in res.get("issues") or [] if not cols or _names(str(i), cols, kw)]
    row["wrong_claim"] = _wrong_claim(case, res)
    row["not_claimed"] = [e.get("label") or e.get("name") for e in res.get("not_claimed") or []]
    return row


def _wrong_claim(case: Case, res: dict[str, Any]) -> bool:
    """A library effect on a healthy record, or a first effect other than the injected fault's."""
    effects = res.get("effects") or []
    if case.fault is None:
        return bool(effects)
    return bool(effects) and effects[0].get("name") != ci.parse_fault(case.fault).name


def _job(args: tuple[Case, str, str | None]) -> dict[str, Any]:
    case, out, baseline = args
    csv = Path(out) / f"{case.tag}.csv"
    if not csv.exists():
        make(case, Path(out))
    res = ci.calibrate(csv, Path(baseline) if baseline else None)
    (Path(out) / f"{case.tag}{'.baseline' if baseline else ''}.calibration.json").write_text(
        json.dumps(res, indent=1, default=str)
    )
    row = judge(case, res)
    row["baseline"] = Path(baseline).name if baseline else None
    return row


def table(rows: list[dict[str, Any]]) -> str:
    head = (
        "| effect | record | first effect (baseline updates) | main parameter: fitted / truth (error) | "
        "E before -> after | verdict | issue names the channel | issues on that channel |\n"
        "|---|---|---|---|---|---|---|---|\n"
    )
    lines = []
    for r in rows:
        par = ci.param_cell(r)
        first = r.get("first", "-")
        if r.get("baseline_updates"):
            first += f" ({', '.join(r['baseline_updates'])})"
        issues = "; ".join(i[:140] for i in r.get("issues") or []) if r.get("issues_true") != "-" else ""
        err = f"{ci._fmt(r.get('error_before'))} -> {ci._fmt(r.get('error_after'))}"
        lines.append(
            f"| {r['effect']} | {r['base']} | {first} | {par} | {err} | {r['verdict']} | "
            f"{r.get('issues_true', '-')} | {issues.replace('|', '/')} |"
        )
    return head + "\n".join(lines) + "\n"


def render(rows: list[dict[str, Any]], note: str) -> str:
    text = ""
    for variant, title in ((None, "Without a reference"), ("yes", "With `--baseline` (healthy 2000 rpm)")):
        part = [r for r in rows if bool(r.get("baseline")) == bool(variant)]
        if not part:
            continue
        done = [r for r in part if r["verdict"] != "not run"]
        n_pass = sum(r["verdict"] in ("PASS", "REFUSED") for r in done)
        wrong = sum(bool(r.get("wrong_claim")) for r in done)
        silent = sum(r.get("issues_true") == "no" for r in done)
        cpus = sorted(r["cpu_s"] for r in done if r.get("cpu_s") is not None)
        text += (
            f"#### {title}: {n_pass} of {len(done)} pass (PASS or REFUSED naming the field), "
            f"{wrong} wrong claim(s), {silent} silent on the disturbed channel\n\n" + table(part)
        )
        if cpus:
            text += f"\nCPU per record: median {cpus[len(cpus) // 2]:.0f} s, max {cpus[-1]:.0f} s.\n\n"
    return text + f"{note}.\n"


def collect(todo: list[Case], dirs: list[Path], baseline: bool) -> list[dict[str, Any]]:
    rows = []
    for c in todo:
        name = f"{c.tag}{'.baseline' if baseline else ''}.calibration.json"
        found = [d / name for d in dirs if (d / name).exists()]
        if found:
            row = judge(c, json.loads(found[0].read_text()))
            row["baseline"] = "yes" if baseline else None
            rows.append(row)
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=1, help="parallel calibrations (default 1)")
    ap.add_argument("--out", default="out/calibration_undeclared", help="records and results directory")
    ap.add_argument("--cases", nargs="*", default=None, help="only cases whose tag contains one of these")
    ap.add_argument("--baseline", action="store_true", help="also the --baseline variant (healthy 2000 rpm)")
    ap.add_argument("--only-baseline", action="store_true", help="only the --baseline variant")
    ap.add_argument(
        "--reference",
        metavar="JSON",
        help="saved reference baseline to use (default: fitted here on the table's healthy 2000 rpm record)",
    )
    ap.add_argument("--from-results", nargs="+", metavar="DIR", help="judge saved *.calibration.json")
    ap.add_argument("--list", action="store_true", help="print the cases and exit")
    args = ap.parse_args(argv)
    todo = ci.select_cases(cases(), args.cases)
    if args.list:
        for c in todo:
            print(f"{c.tag}: {c.effect.what}; truth {c.fault or 'healthy'}")
        return 0
    if not todo:
        print("no case matches --cases", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.from_results:
        dirs = [Path(d) for d in args.from_results]
        rows = collect(todo, dirs, False) + collect(todo, dirs, True)
        text = render(rows, f"results from {', '.join(map(str, dirs))}")
    else:
        t0, load0 = time.perf_counter(), os.getloadavg()[0]
        for c in todo:
            make(c, out)
        jobs: list[tuple[Case, str, str | None]] = (
            [] if args.only_baseline else [(c, str(out), None) for c in todo]
        )
        if args.baseline or args.only_baseline:
            saved = args.reference
            if saved is None:
                ref = ci.Case("baseline_2000rpm_25C", *ci.BASELINE, None, 999)
                saved = ci._reference((ref, str(out), 2.0))
            jobs += [(c, str(out), saved) for c in todo]
        rows = _run(jobs, args.jobs)
        text = render(rows, ci.run_note(args.jobs, load0, t0))
    ci.save_results(out, text, rows)
    return 0


def _run(jobs: list[tuple[Case, str, str | None]], n_jobs: int) -> list[dict[str, Any]]:
    """The calibrations, in a pool or one by one (each row's verdict printed as it comes: the saved
    results let a cut-short run be re-rendered with ``--from-results``)."""
    if n_jobs > 1:
        with ProcessPoolExecutor(max_workers=n_jobs) as pool:
            return list(pool.map(_job, jobs))
    rows = []
    for j in jobs:
        rows.append(_job(j))
        print(f"{rows[-1]['record']}: {rows[-1]['verdict']}", file=sys.stderr, flush=True)
    return rows


if __name__ == "__main__":
    sys.exit(main())
