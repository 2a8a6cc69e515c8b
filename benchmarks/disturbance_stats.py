"""The acquisition-disturbance checks' statistics on the benchmark records: none may fire (issue 11).

For the 71 records of the issue-11 benchmarks (28 of the table, its 2 references, 41 held out: the same
generator calls, seeds and sampling as ``calibration_independent.py`` / ``calibration_heldout.py``), the
4 CWRU files when present, and optionally the disturbed records of ``calibration_undeclared.py``, load each
record as ``gear-rotor-sim calibrate`` does and print per record the margins of the checks of
``calibration/measurement_impulses.py`` and ``measurement_dropouts.py``: the largest interpolation error
(robust scales of the AR interpolation error) and the count beyond the threshold per channel, the longest
run of equal samples, repeated blocks, and whether loading added an ``issues`` entry. Records are written
to ``--out`` once and reused. Docs: docs/history/calibration_sessions.md Sec. 8.47. Session 19 (Sec. 8.51)
added the events outside a regular train per channel (before the MIN_EVENTS threshold) and the mains check's
statistic (``calibration/mains_check.py``): the largest line at a 50/60 Hz harmonic (1-10) that is no shaft's
order at the declared speed, peak within EXACT_HZ, over its neighbourhood's median (LINE_SNR needed).
Session 20 (Sec. 8.54) added the line removal's (``calibration/line_removal.py``): the lines it would
remove, and the largest line locked to no shaft, mains harmonic or bearing frequency.

Usage::

    python benchmarks/disturbance_stats.py [--out DIR] [--cases SUBSTR ...] [--undeclared] [--no-cwru]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import calibration_heldout as ch
import calibration_independent as ci
import calibration_undeclared as cu

from gear_rotor_sim.calibration import line_removal as lr
from gear_rotor_sim.calibration import mains_check as mc
from gear_rotor_sim.calibration import measurement_impulses as mi
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.calibration.measurement_dropouts import equal_runs, held_runs, repeated_blocks


def records(out: Path, undeclared: bool) -> list[tuple[str, Path, Any]]:
    """(tag, CSV path, maker) of every record: the maker writes the CSV (once: it is reused)."""
    held = out / "heldout"
    todo: list[tuple[str, Path, Any]] = [
        (c.tag, out / f"{c.tag}.csv", lambda c=c: ci.make(c, out, 2.0)) for c in ci.cases(False)
    ]
    for sp, tc in (ci.BASELINE, ci.BASELINE_ALT):
        ref = ci.Case(f"baseline_{sp:.0f}rpm_{tc:.0f}C", sp, tc, None, 999)
        todo.append((ref.tag, out / f"{ref.tag}.csv", lambda c=ref: ci.make(c, out, 2.0)))
    held.mkdir(parents=True, exist_ok=True)
    for h in ch.cases():
        todo.append((f"heldout_{h.tag}", held / f"{h.tag}.csv", lambda h=h: ch.make(h, held, 2.0)))
    if undeclared:
        for c in cu.cases():
            todo.append((f"undeclared_{c.tag}", out / f"{c.tag}.csv", lambda c=c: cu.make(c, out)))
    return todo


def _unrepaired(path: Path) -> np.ndarray:
    """A CWRU file's SI data as loaded, without the spike repair (the detector's input)."""
    from unittest import mock

    from gear_rotor_sim.calibration import measurement_checks
    from gear_rotor_sim.calibration.cwru import CWRU_MAPPING
    from gear_rotor_sim.calibration.measurement_files import load_mat

    with mock.patch.object(measurement_checks, "repair_spikes", lambda d, *a: d):
        return load_mat(path, CWRU_MAPPING).data


def _outside_train(spikes: mi.Spikes, fs: float, duration_s: float) -> int:
    """Events of a channel outside its regular train (all of them when there is none)."""
    t = spikes.starts / fs
    regular = mi.regular_rate(t, duration_s) if t.size else None
    return int(t.size if regular is None else np.count_nonzero(~mi.train_members(t, regular[0])))


def mains_margin(data: np.ndarray, fs: float, speed_rpm: float, cwru: bool) -> float:
    """The mains check's statistic on the record: the largest line at a mains harmonic that is no shaft's
    order (the paper gearbox: input and output shaft, 29 / 49), its peak within EXACT_HZ of the harmonic,
    over its neighbourhood's median. The CWRU rig has no mesh: the check does not examine it (0)."""
    if cwru:
        return 0.0
    sp = speed_rpm / 60.0
    shafts = [("input", sp), ("output", sp * 29.0 / 49.0)]
    big_t = data.shape[0] / fs
    spectra = [mc.Spectrum(data[:, c], fs) for c in range(data.shape[1])]
    worst = 0.0
    for f0 in mc.MAINS_HZ:
        for h in range(1, mc.MAX_HARMONIC + 1):
            if mc.nearest_order(h * f0, shafts)[2] < 1.0 / big_t:
                continue
            for sp_c in spectra:
                line = sp_c.line(h * f0)
                if line is not None and abs(line[1] - h * f0) <= mc.EXACT_HZ:
                    worst = max(worst, line[2])
    return worst


def unlocked_margin(data: np.ndarray, fs: float, speed_rpm: float, cwru: bool) -> tuple[int, float]:
    """The line removal's statistic (``calibration/line_removal.py``, session 20): the number of lines it
    removes, and the largest line in 5-250 Hz that is no shaft's order, no mains harmonic, no bearing line and
    no order's sidelobe, read as a comb's fundamental is (``line_removal.line_at``; a neighbouring machine's
    if it had a harmonic too), over its neighbourhood's median (only lines from LINE_SNR are read: 0 if none).
    The CWRU rig has no mesh: not examined (0, 0)."""
    if cwru:
        return 0, 0.0
    from gear_rotor_sim.faults.bearing import BEARING_6206

    sp = speed_rpm / 60.0
    shafts = [("input", sp), ("output", sp * 29.0 / 49.0)]
    big_t = data.shape[0] / fs
    n = len(lr.find_lines(data, fs, shafts, BEARING_6206.multiples()))
    bearing = lr.bearing_lines_hz([f for _, f in shafts], BEARING_6206.multiples())
    worst = 0.0
    for c in range(data.shape[1]):
        sp_c = mc.Spectrum(data[:, c], fs)
        for f in lr.peaks(sp_c):
            line = sp_c.line(float(f))
            if line is None or not lr.is_unlocked(line[1], shafts, big_t, bearing):
                continue
            # as the comb's fundamental is read: fitted with the orders beside it, no far order's sidelobe
            found = lr.line_at(data[:, c], sp_c, line[1], 0.5 / big_t, shafts)
            worst = max(worst, found[1] if found is not None else 0.0)
    return n, worst


def stats(csv: Path) -> dict[str, Any]:
    """The checks' margins on one record, loaded as the calibration loads it."""
    t = time.process_time()
    try:
        if csv.suffix == ".mat":
            from gear_rotor_sim.calibration.cwru import CWRU_MAPPING
            from gear_rotor_sim.calibration.measurement_files import load_mat

            m = load_mat(csv, CWRU_MAPPING)
        else:
            m = load_measurement(csv)
    except Exception as exc:
        return {"refused": str(exc)[:160]}
    raw = np.loadtxt(csv, delimiter=",", skiprows=1)[:, 1:] if csv.suffix == ".csv" else _unrepaired(csv)
    row: dict[str, Any] = {"issues": len(m.issues), "issue_text": [i[:90] for i in m.issues]}
    peaks, counts, random, longest, outside = [], [], [], [], []
    fs = m.sample_rate_hz
    for k in range(m.data.shape[1]):
        x = raw[:, k]
        fitted = mi.channel_zscores(x) if np.all(np.isfinite(x)) else None
        peaks.append(float(np.max(np.abs(fitted[2]))) if fitted is not None else 0.0)
        spikes, _ = mi.find_spikes(x)
        counts.append(int(spikes.starts.size))
        random.append(int(mi._interference(spikes, fs, x.size / fs).size) if spikes.starts.size else 0)
        outside.append(_outside_train(spikes, fs, x.size / fs))
        runs = equal_runs(raw[:, k]) if raw.shape[0] > 1 else []
        longest.append(max((r[1] for r in runs), default=1))
        if held_runs(raw[:, k]):
            row.setdefault("held", []).append(m.channels[k].column)
    row.update(peak_z=peaks, n_spikes=counts, n_random=random, longest_equal=longest, outside=outside)
    row["mains"] = mains_margin(m.data, fs, m.operating_point.speed_rpm, csv.suffix == ".mat")
    row["removed"], row["unlocked"] = unlocked_margin(
        m.data, fs, m.operating_point.speed_rpm, csv.suffix == ".mat"
    )
    row["repeats"] = len(repeated_blocks(raw[np.all(np.isfinite(raw), axis=1)]))
    row["cpu_s"] = time.process_time() - t
    return row


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/disturbance_stats", help="records directory (reused)")
    ap.add_argument("--cases", nargs="*", default=None, help="only records whose tag contains one of these")
    ap.add_argument("--undeclared", action="store_true", help="also the disturbed records")
    ap.add_argument("--no-cwru", action="store_true", help="skip the CWRU files")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    todo = records(out, args.undeclared)
    if args.cases:
        todo = [r for r in todo if any(s in r[0] for s in args.cases)]
    if not args.no_cwru:
        from gear_rotor_sim.calibration.cwru import CWRU_FILES, cwru_data_dir

        repo = Path(__file__).resolve().parents[1]
        dirs = (cwru_data_dir(repo), repo.parents[1] / "shared" / "data" / "cwru")
        data = next((d for d in dirs if d.is_dir()), repo)
        todo += [(f"cwru_{n}", data / n, None) for n in CWRU_FILES if (data / n).exists()]
    load0 = os.getloadavg()[0]
    print(
        "| record | issues | largest interpolation error per channel (robust scales) | isolated "
        f"spikes >= {mi.Z_SPIKE:g} | outside a train | of them repaired | longest equal run | held | "
        "repeated blocks | mains line off the orders (x median) | lines removed | largest unlocked line "
        "(x median) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    worst = mains_worst = unlocked_worst = 0.0
    most_outside = 0
    fired = 0
    for tag, csv, maker in todo:
        if not csv.exists():
            maker()
        s = stats(csv)
        if "refused" in s:
            print(f"| {tag} | refused: {s['refused']} | | | | | | | | | | |")
            continue
        fires = s["issues"] > 0 or s.get("held") or s["repeats"] or max(s["n_random"]) >= mi.MIN_EVENTS
        fires = fires or s["mains"] >= mc.LINE_SNR or s["removed"] > 0
        fired += bool(fires)
        if not tag.startswith("undeclared"):
            worst = max(worst, *s["peak_z"])
            most_outside = max(most_outside, *s["outside"])
            mains_worst = max(mains_worst, s["mains"])
            unlocked_worst = max(unlocked_worst, s["unlocked"])
        print(
            f"| {tag} | {s['issues']} | {', '.join(f'{z:.1f}' for z in s['peak_z'])} | "
            f"{', '.join(map(str, s['n_spikes']))} | {', '.join(map(str, s['outside']))} | "
            f"{', '.join(map(str, s['n_random']))} | {max(s['longest_equal'])} | {s.get('held', '-')} | "
            f"{s['repeats']} | {s['mains']:.3g} | {s['removed']} | {s['unlocked']:.3g} |",
            flush=True,
        )
    print(
        f"\n{len(todo)} records, {fired} with a finding; undisturbed records: largest interpolation error "
        f"{worst:.1f} robust scales, most events outside a train on a channel {most_outside} (repaired from "
        f"{mi.MIN_EVENTS}), largest mains line off the orders {mains_worst:.3g} x its neighbourhood (named "
        f"from {mc.LINE_SNR:g}), largest line locked to no shaft, mains or bearing {unlocked_worst:.3g} x "
        f"its neighbourhood (removed from {mc.LINE_SNR:g} with a harmonic); load {load0:.1f} -> "
        f"{os.getloadavg()[0]:.1f}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
