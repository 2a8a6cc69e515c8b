"""The cases of ``calibration_undeclared.py``: the table records it disturbs and the effects nobody declared.

Each :class:`Undeclared` is one effect that a user's measurement may hold without the sidecar saying so,
with the base records (:data:`BASES`, the issue-11 table's records by tag) it is added to: in the
measurement chain by a post-processing step (:data:`Post`, applied to the noisy record) or through the
generator's own inputs. :data:`EFFECTS` lists them in the order a real user's data most likely holds them,
then one block per session that added cases (mains, sensor transfer, the session-20 probe, a neighbouring
machine's tones, force-sensor zeros, hum on many channels, a sample clock and a channel skew). The runner,
verdicts and tables are in ``calibration_undeclared.py``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import calibration_independent as ci
import numpy as np
import undeclared_disturbances as ud
import undeclared_probe as up

from lumped_gearbox import CONTACT_RPM, RATTLE_RPM
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
