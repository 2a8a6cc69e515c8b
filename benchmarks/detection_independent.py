"""The monitor scored on data the FE model did not make: lumped_gearbox records and the CWRU recordings.

``benchmarks/detection.py`` scores the monitor's fault alarms (gear_rotor_sim.fault_indicators,
gear_rotor_sim.alarms, config/fault_thresholds.json) on the FE model's own runs. This benchmark scores
the same computation on

1. records of ``lumped_gearbox`` (an independent lumped-parameter simulator that shares no code
   with gear_rotor_sim, docs/independent_data.md) with its housing path (``bearing2_housing_ax/ay``:
   one 4 kg, 2.6 kHz, zeta 0.04 housing mode per direction driven by the bearing-2 force; white
   noise 2-5 % of each channel's RMS, gains 1 +- 3 %): every fault it shares with the effect library
   at three severities, 1500 and 3000 rpm, 25 and 75 C (noise seed 1; ``--fault-seeds N``: seeds 1..N); and
   healthy records at the
   four operating points with 12 speed offsets (-2.75 % to +2.75 % in 0.5 % steps), one seed each.
   ``gear_misalignment`` (not a library fault) is scored with the ``shaft_misalignment`` group;
2. the CWRU bearing recordings (../shared/data/cwru, drive-end accelerometer, 12 kHz): the normal
   file split in a training and a held-out half, the three fault files.

Scores (docs/detection.md, "On data the model did not make"):

(a) shipped thresholds: :class:`gear_rotor_sim.alarms.FaultAlarms` on ``config/fault_thresholds.json``
    (learnt on the FE model's healthy runs), window by window, exactly as the monitor node calls it;
(b) machine-learnt thresholds: ``mean + k std`` per feature and operating class learnt on the healthy
    lumped records of even offset position (:func:`gear_rotor_sim.alarms_learn.learn`, what
    ``gear-rotor-sim thresholds learn`` runs), scored on the fault records and on the healthy
    records of odd position (held out);
(c) CWRU: the monitor's features on ``config/cwru_rig.yaml`` (no mesh, so no FM0/FM4/SER; envelope
    lines at the 6205's BPFO, BPFI and 2 BSF), as ``thresholds learn`` reads the files, learnt on the
    first half of the normal file; the three bearing groups scored.

Windows: 0.25 s from 0.5 s (6 per 2 s record), as in the FE benchmark; CWRU: 0.25 s from 0 s.

Usage::

    python benchmarks/detection_independent.py [--out DIR] [--workers N] [--markdown docs/detection.md]
    python benchmarks/detection_independent.py --quick      # 1 seed, 3000 rpm / 25 C only

Records are cached in ``--out`` (``DIR/records/*.npz``; the run is resumable).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gear_rotor_sim.alarms import FAULT_GROUPS, FaultAlarms, group_alarms, operating_class
from gear_rotor_sim.alarms_learn import RecordWindow, array_windows, features_of, learn, measurement_windows

sys.path.insert(0, str(Path(__file__).resolve().parent))
from detection import write_block  # the FE benchmark's Markdown block writer

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ROOT / "config" / "fault_thresholds.json"
SPEEDS = (1500.0, 3000.0)
TEMPERATURES = (25.0, 75.0)
OFFSETS_PCT = tuple(-2.75 + 0.5 * i for i in range(12))
KS = (3.0, 4.0, 5.0, 6.0)
#: fault -> (main parameter, severities, other fields); severities as in benchmarks/detection_sweep.py
FAULT_GRID: dict[str, tuple[str, tuple[float, ...], str]] = {
    "tooth_damage": ("depth", (0.1, 0.3, 0.6), "wheel=gear,tooth=5"),
    "tooth_wear": ("wear_depth_m", (2e-6, 5e-6, 1.5e-5), ""),
    "pinion_eccentricity": ("eccentricity_m", (5e-6, 2e-5, 5e-5), ""),
    "gear_eccentricity": ("eccentricity_m", (5e-6, 2e-5, 5e-5), ""),
    "mass_unbalance": ("unbalance_kg_m", (2e-5, 1e-4, 4e-4), "node=5"),
    "gear_misalignment": ("angle_rad", (2.5e-4, 1e-3, 3e-3), "member=gear"),
    "outer_race_defect": ("force_n", (50.0, 200.0, 1000.0), ""),
    "inner_race_defect": ("force_n", (50.0, 200.0, 1000.0), ""),
    "ball_defect": ("force_n", (50.0, 200.0, 1000.0), ""),
}
#: the library group that watches a lumped fault (its own name when the library has it)
GROUP_OF = {"gear_misalignment": "shaft_misalignment"}
CWRU_FAULTS = {
    "OR007_at6_0.mat": "outer_race_defect",
    "IR007_0.mat": "inner_race_defect",
    "B007_0.mat": "ball_defect",
}
BEARING_GROUPS = ("outer_race_defect", "inner_race_defect", "ball_defect")


@dataclass(frozen=True)
class Spec:
    """One lumped record: fault type (``healthy``), severity, operating point, seed, offset position."""

    kind: str
    severity: float
    speed_rpm: float
    temperature_c: float
    seed: int
    position: int = -1  # healthy: index of the speed offset (even: training, odd: held out)

    @property
    def key(self) -> str:
        return f"{self.kind}_{self.severity:g}_{self.speed_rpm:.4f}rpm_{self.temperature_c:g}C_s{self.seed}"

    def fault(self) -> str | None:
        if self.kind == "healthy":
            return None
        name, _, extra = FAULT_GRID[self.kind]
        return f"{self.kind}:{name}={self.severity!r}" + (f",{extra}" if extra else "")


def grid(quick: bool = False, fault_seeds: int = 1) -> list[Spec]:
    """All records: faults x severities x speeds x temperatures x noise seeds 1..``fault_seeds``, then
    the healthy ones (one seed each)."""
    speeds, temps = ((3000.0,), (25.0,)) if quick else (SPEEDS, TEMPERATURES)
    seeds = range(1, fault_seeds + 1)
    out = [
        Spec(kind, sev, s, t, seed)
        for kind, (_, sevs, _) in FAULT_GRID.items()
        for sev in sevs
        for s in speeds
        for t in temps
        for seed in seeds
    ]
    seed = 100
    for s in speeds:
        for t in temps:
            for i, off in enumerate(OFFSETS_PCT):
                out.append(Spec("healthy", 0.0, s * (1.0 + off / 100.0), t, seed, i))
                seed += 1
    return out


def make(args: tuple[Spec, Path]) -> float:
    """Simulate one record into ``DIR/<key>.npz`` (housing channels only) unless cached; CPU seconds."""
    from lumped_gearbox import make_record

    spec, folder = args
    path = folder / f"{spec.key}.npz"
    if path.exists():
        return 0.0
    t0 = time.process_time()
    fault = spec.fault()
    r = make_record(
        spec.speed_rpm, spec.temperature_c, [fault] if fault else [], seed=spec.seed, housing=True
    )
    fs = 1.0 / float(r.time_s[1] - r.time_s[0])
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, fs=fs, ax=r.data["bearing2_housing_ax"], ay=r.data["bearing2_housing_ay"])
    tmp.replace(path)
    return time.process_time() - t0


def record_windows(spec: Spec, folder: Path) -> list[RecordWindow]:
    """The monitor's windows of a cached record (declared operating point = the simulated one)."""
    z = np.load(folder / f"{spec.key}.npz")
    ch = {"bearing2_housing_ax": z["ax"], "bearing2_housing_ay": z["ay"]}
    return array_windows(ch, float(z["fs"]), spec.speed_rpm, spec.temperature_c)


def _score_record(args: tuple[Spec, Path]) -> list[dict]:
    """Per window: shipped-threshold alarms (FaultAlarms.check, as the node) and the features."""
    spec, folder = args
    shipped = FaultAlarms(str(SHIPPED))
    wins = record_windows(spec, folder)
    feats = features_of(wins)
    return [{"alarms": shipped.check(w)[0], "features": f} for w, f in zip(wins, feats, strict=True)]


def _rate(flags: list[bool]) -> float:
    return float(np.mean(flags)) if flags else float("nan")


def score_lumped(specs: list[Spec], rows: list[list[dict]], ks: tuple[float, ...]) -> dict:
    """Detection and false-alarm rates with the shipped thresholds and with machine-learnt ones."""
    healthy = [(s, r) for s, r in zip(specs, rows, strict=True) if s.kind == "healthy"]
    faulty = [(s, r) for s, r in zip(specs, rows, strict=True) if s.kind != "healthy"]
    train = [(s, w) for s, r in healthy if s.position % 2 == 0 for w in r]
    held = [(s, w) for s, r in healthy if s.position % 2 == 1 for w in r]

    def table(alarms_of) -> dict:
        """Rates over all windows and per nominal speed (``by_speed``: {speed: rate})."""
        det: dict[str, dict[float, dict[float, list[bool]]]] = defaultdict(
            lambda: defaultdict(lambda: defaultdict(list))
        )
        for s, r in faulty:
            g = GROUP_OF.get(s.kind, s.kind)
            det[s.kind][s.severity][s.speed_rpm] += [g in alarms_of(s, w) for w in r]
        fa: dict[str, dict[float, list[bool]]] = defaultdict(lambda: defaultdict(list))
        for s, w in held:
            hit = alarms_of(s, w)
            nominal = operating_class(s.speed_rpm, s.temperature_c, SPEEDS, TEMPERATURES)[0]
            for g in (*FAULT_GROUPS, "any"):
                fa[g][nominal].append(g in hit if g != "any" else bool(hit))

        def rates(by: dict[float, list[bool]]) -> dict:
            return {
                "all": _rate([x for v in by.values() for x in v]),
                **{sp: _rate(v) for sp, v in sorted(by.items())},
            }

        return {
            "detection": {t: {sev: rates(v) for sev, v in sorted(d.items())} for t, d in det.items()},
            "false_alarm": {g: rates(v) for g, v in fa.items()},
            "false_alarm_train": _rate([bool(alarms_of(s, w)) for s, w in train]),
        }

    out = {
        "shipped": table(lambda s, w: w["alarms"]),
        "train_windows": len(train),
        "held_out_windows": len(held),
    }
    for k in ks:
        th = learn(
            [w["features"] for _, w in train],
            [(s.speed_rpm, s.temperature_c) for s, _ in train],
            k,
            SPEEDS,
            TEMPERATURES,
        )

        def learnt(s: Spec, w: dict, th=th) -> dict:
            c = operating_class(s.speed_rpm, s.temperature_c, SPEEDS, TEMPERATURES)
            return group_alarms(th.exceeded(w["features"], c))

        out[f"learnt_k{k:g}"] = table(learnt)
    return out


def shipped_versus_lumped(specs: list[Spec], rows: list[list[dict]]) -> list[dict]:
    """Per feature of bearing 2 and class: lumped healthy mean and std, shipped FE mean, std, limit."""
    shipped = FaultAlarms(str(SHIPPED)).thresholds
    out = []
    for c in sorted(shipped.mean):
        vals = [
            w["features"]
            for s, r in zip(specs, rows, strict=True)
            if s.kind == "healthy"
            and operating_class(s.speed_rpm, s.temperature_c, SPEEDS, TEMPERATURES) == c
            for w in r
        ]
        for i, n in enumerate(shipped.names):
            if not vals or n not in vals[0]:
                continue
            v = np.array([f[n] for f in vals])
            fe = (shipped.mean[c][i], shipped.std[c][i], shipped.limit(c)[i])
            out.append(
                {
                    "class": c,
                    "feature": n,
                    "lumped_mean": float(v.mean()),
                    "lumped_std": float(v.std(ddof=1)),
                    **dict(zip(("fe_mean", "fe_std", "fe_limit"), map(float, fe), strict=True)),
                }
            )
    return out


def cwru_windows(directory: Path, window_s: float = 0.25) -> dict[str, tuple[list[dict], float]]:
    """The monitor's features of every window of each CWRU file in ``directory`` (drive end, 12 kHz;
    ``config/cwru_rig.yaml``: no gear mesh, the 6205 at the drive end), as ``thresholds learn`` reads them."""
    from gear_rotor_sim.calibration.cwru import CWRU_FILES

    out = {}
    for name in CWRU_FILES:
        wins, gearbox = measurement_windows(str(Path(directory) / name), window_s, 0.0)
        out[name] = (features_of(wins, gearbox), wins[0].speed_rpm)
    return out


def score_cwru(windows: dict[str, tuple[list[dict], float]], ks: tuple[float, ...]) -> dict:
    """Thresholds learnt on the first half of normal_0's windows; held-out half and fault files scored."""
    normal, rpm = windows["normal_0.mat"]
    half = len(normal) // 2
    train, held = normal[:half], normal[half:]
    out: dict = {
        "train_windows": len(train),
        "held_out_windows": len(held),
        "fault_windows": {n: len(windows[n][0]) for n in CWRU_FAULTS},
    }
    for k in ks:
        th = learn(train, [(rpm, 25.0)] * len(train), k)
        c = next(iter(th.mean))

        def scored(feats: list[dict], th=th, c=c) -> tuple[list[dict], dict[str, float]]:
            """Bearing groups that alarm per window; per indicator, the fraction of windows above."""
            ex = [th.exceeded(f, c) for f in feats]
            grp = [{g: v for g, v in group_alarms(e).items() if g in BEARING_GROUPS} for e in ex]
            inds = sorted({n.rsplit(".", 1)[1] for n in th.names})
            return grp, {i: _rate([any(n.endswith("." + i) for n in e) for e in ex]) for i in inds}

        held_groups, held_ind = scored(held)
        res = {
            "false_alarm": {g: _rate([g in a for a in held_groups]) for g in BEARING_GROUPS},
            "false_alarm_any": _rate([bool(a) for a in held_groups]),
            "held_out_indicators": held_ind,
        }
        for name, fault in CWRU_FAULTS.items():
            a, ind = scored(windows[name][0])
            res[name] = {
                "own_group": _rate([fault in x for x in a]),
                "any_group": _rate([bool(x) for x in a]),
                "groups": {g: _rate([g in x for x in a]) for g in BEARING_GROUPS},
                "indicators": ind,
            }
        out[f"k{k:g}"] = res
    medians = {}
    for name, (feats, _) in windows.items():
        medians[name] = {key.rsplit(".", 1)[1]: float(np.median([f[key] for f in feats])) for key in feats[0]}
    out["medians"] = medians
    return out


def _pct(v: float) -> str:
    return f"{100 * v:.0f} %"


def markdown(res: dict, head: str) -> str:
    """Tables of the results (docs/detection.md, "On data the model did not make")."""
    lum = res["lumped"]
    lines = [head, ""]

    def cell(r: dict) -> str:
        return f"{_pct(r['all'])} ({' / '.join(_pct(r[sp]) for sp in SPEEDS)})"

    def block(title: str, t: dict) -> None:
        lines.extend(
            [
                title,
                "",
                f"Held-out healthy windows with any alarm: {cell(t['false_alarm']['any'])} "
                f"(training windows: {_pct(t['false_alarm_train'])}).",
                "",
                "| fault type (lumped) | severity parameter "
                "| detection rate: all (1500 / 3000 rpm), per severity "
                "| false alarms of its group (held-out healthy) |",
                "|---|---|---|---|",
            ]
        )
        for kind, d in t["detection"].items():
            g = GROUP_OF.get(kind, kind)
            det = "; ".join(f"{s:g}: {cell(v)}" for s, v in d.items())
            label = kind if g == kind else f"{kind} (group {g})"
            lines.append(f"| {label} | {FAULT_GRID[kind][0]} | {det} | {cell(t['false_alarm'][g])} |")
        lines.append("")

    block(
        "**(a) Shipped thresholds** (`config/fault_thresholds.json`, k = 6, learnt on the FE model):",
        lum["shipped"],
    )
    for k in res["ks"]:
        block(
            f"**(b) Thresholds learnt on this machine's healthy records**, k = {k:g} "
            f"({lum['train_windows']} training windows, {lum['held_out_windows']} held-out windows):",
            lum[f"learnt_k{k:g}"],
        )
    lines += [
        "**Why the shipped thresholds do not transfer** (bearing 2, class 3000 rpm / 25 C: the healthy "
        "lumped windows against the FE model's healthy statistics in `config/fault_thresholds.json`):",
        "",
        "| feature | lumped mean | lumped std | FE mean | FE std | FE limit (k = 6) "
        "| lumped mean / FE limit |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in res["transfer"]:
        if tuple(r["class"]) == (3000.0, 25.0):
            lines.append(
                f"| {r['feature']} | {r['lumped_mean']:.4g} | {r['lumped_std']:.3g} | {r['fe_mean']:.4g} | "
                f"{r['fe_std']:.3g} | {r['fe_limit']:.4g} | {r['lumped_mean'] / r['fe_limit']:.3g} |"
            )
    if res.get("cwru"):
        lines += cwru_markdown(res["cwru"], res["ks"])
    return "\n".join(lines)


def cwru_markdown(cw: dict, ks: list[float]) -> list[str]:
    """The CWRU tables: alarms per k, the groups that alarm per file, the median features."""
    lines = [
        "",
        "**(c) CWRU** (drive-end accelerometer, 12 kHz; thresholds learnt on the first "
        f"{cw['train_windows']} windows of normal_0, held out: its last {cw['held_out_windows']}; "
        "fault files: " + ", ".join(f"{n} {v} windows" for n, v in cw["fault_windows"].items()) + "):",
        "",
        "| k | false alarms (held-out normal): outer / inner / ball / any "
        "| OR007 own group (any) | IR007 own group (any) | B007 own group (any) |",
        "|---|---|---|---|---|",
    ]
    for k in ks:
        r = cw[f"k{k:g}"]
        fa = " / ".join(_pct(r["false_alarm"][g]) for g in BEARING_GROUPS)
        cells = [f"{_pct(r[n]['own_group'])} ({_pct(r[n]['any_group'])})" for n in CWRU_FAULTS]
        lines.append(f"| {k:g} | {fa} / {_pct(r['false_alarm_any'])} | " + " | ".join(cells) + " |")
    r6 = cw[f"k{ks[-1]:g}"]
    lines += [
        "",
        f"Which bearing groups alarm, k = {ks[-1]:g} (fraction of the file's windows):",
        "",
        "| file | " + " | ".join(BEARING_GROUPS) + " |",
        "|---|---|---|---|",
    ]
    for n in CWRU_FAULTS:
        lines.append(f"| {n} | " + " | ".join(_pct(r6[n]["groups"][g]) for g in BEARING_GROUPS) + " |")
    inds = list(r6["held_out_indicators"])
    lines += [
        "",
        f"Indicators above their thresholds, k = {ks[-1]:g} (fraction of the windows):",
        "",
        "| file | " + " | ".join(inds) + " |",
        "|---|" + "---|" * len(inds),
        "| normal_0.mat (held out) | " + " | ".join(_pct(r6["held_out_indicators"][i]) for i in inds) + " |",
    ]
    for n in CWRU_FAULTS:
        lines.append(f"| {n} | " + " | ".join(_pct(r6[n]["indicators"][i]) for i in inds) + " |")
    lines += [
        "",
        "Median over the windows of each file:",
        "",
        "| file | rms (m/s^2) | kurtosis | crest factor | env_bpfo | env_bpfi | env_bsf |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, m in cw["medians"].items():
        lines.append(
            f"| {name} | {m['rms']:.3g} | {m['kurtosis']:.3g} | {m['crest_factor']:.3g} | "
            f"{m['env_bpfo']:.3g} | {m['env_bpfi']:.3g} | {m['env_bsf']:.3g} |"
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--out", type=Path, default=Path("detection_independent_ds"), help="cache and results folder"
    )
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--quick", action="store_true", help="3000 rpm / 25 C only")
    ap.add_argument("--fault-seeds", type=int, default=1, help="noise seeds per fault record (default 1)")
    ap.add_argument("--no-cwru", action="store_true", help="skip the CWRU part")
    ap.add_argument(
        "--cwru-dir", type=Path, help="CWRU files (default ../shared/data/cwru of the repository)"
    )
    ap.add_argument("--markdown", type=Path, help="write the tables into this file's results block")
    args = ap.parse_args(argv)
    folder = args.out / "records"
    folder.mkdir(parents=True, exist_ok=True)
    specs = grid(args.quick, args.fault_seeds)
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        cpu = list(pool.map(make, [(s, folder) for s in specs]))
    t_gen = time.perf_counter() - t0
    made = [c for c in cpu if c > 0]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        rows = list(pool.map(_score_record, [(s, folder) for s in specs]))
    t_feat = time.perf_counter() - t0
    res = {
        "ks": list(KS),
        "lumped": score_lumped(specs, rows, KS),
        "transfer": shipped_versus_lumped(specs, rows),
    }
    if not args.no_cwru:
        from gear_rotor_sim.calibration.cwru import cwru_data_dir

        res["cwru"] = score_cwru(cwru_windows(args.cwru_dir or cwru_data_dir(ROOT)), KS)
    n_h = sum(s.kind == "healthy" for s in specs)
    made_text = (
        f"{len(made)} records simulated in {t_gen:.0f} s wall ({np.mean(made):.1f} s CPU each)"
        if made
        else f"all records read from the cache in {args.out}"
    )
    head = (
        f"{len(specs)} lumped_gearbox records ({len(specs) - n_h} faulty, {n_h} healthy), "
        f"{sum(len(r) for r in rows)} windows of 0.25 s from 0.5 s; {made_text}; features and alarms in "
        f"{t_feat:.0f} s wall, {args.workers} worker(s)"
    )
    text = markdown(res, head)
    print(text)
    (args.out / "results.json").write_text(json.dumps(res, indent=1, default=str), encoding="utf-8")
    return write_block(args.markdown, text, "independent") if args.markdown else 0


if __name__ == "__main__":
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    raise SystemExit(main())
