"""Writes the malformed-measurement corpus (test/corpus/measurements/) and its manifest.

Run from the repository root: ``python test/corpus/make_measurements.py``. The files are committed;
this script documents how each one was made and regenerates them byte for byte (fixed seed).
Each case is a CSV (or another file) with its YAML sidecar, and an entry in ``manifest.yaml``:
``expect: error`` with the regular expression the one-line error must match, or ``expect: ok``
with the expression one of ``Measurement.issues`` must match (or none).
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import yaml

OUT = Path(__file__).resolve().parent / "measurements"
FS = 1000.0
N = 400
SIDECAR = {
    "sample_rate_hz": FS,
    "operating_point": {"speed_rpm": 3000, "temperature_c": 25},
    "gearbox": "paper_sun2021",
    "channels": [
        {"column": "dte", "quantity": "dynamic_transmission_error", "unit": "um"},
        {"column": "bearing2_fx", "quantity": "bearing_force", "bearing": 2, "direction": "x", "unit": "N"},
    ],
}


def base_rows(n: int = N, fs: float = FS) -> np.ndarray:
    rng = np.random.default_rng(14)
    t = np.arange(n) / fs
    dte = 0.5 * np.sin(2 * np.pi * 145.0 * t) + 0.05 * rng.standard_normal(n)  # um
    force = 800.0 + 40.0 * np.sin(2 * np.pi * 50.0 * t) + 2.0 * rng.standard_normal(n)  # N
    return np.column_stack([t, dte, force])


def csv_text(rows: np.ndarray, header: str = "time_s,dte,bearing2_fx") -> str:
    lines = [header]
    for r in rows:
        lines.append(",".join(repr(float(v)) if np.isfinite(v) else str(v).lower() for v in r))
    return "\n".join(lines) + "\n"


CASES: list[dict] = []


def case(name: str, expect: str, match: str | None, data: bytes | str | None, sidecar=SIDECAR, ext=".csv"):
    CASES.append({"case": name, "file": f"{name}{ext}", "expect": expect, "match": match})
    path = OUT / f"{name}{ext}"
    if data is not None:
        path.write_bytes(data.encode() if isinstance(data, str) else data)
    if sidecar is not None:
        side = OUT / f"{name}.yaml"
        if isinstance(sidecar, dict):
            sidecar = yaml.safe_dump(sidecar)
        side.write_bytes(sidecar.encode() if isinstance(sidecar, str) else sidecar)


def with_side(**changes) -> dict:
    d = copy.deepcopy(SIDECAR)
    for k, v in changes.items():
        d[k] = v
    return d


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    for p in OUT.iterdir():
        p.unlink()
    rows = base_rows()
    case("clean", "ok", None, csv_text(rows))
    r = rows.copy()
    r[123, 1] = 400.0  # one sample of 400 um among a 0.5 um signal: an isolated spike
    case(
        "isolated_spike",
        "ok",
        r"column 'dte': 1 isolated spike\(s\).*replaced by linear interpolation at t = 0.123 s",
        csv_text(r),
    )
    r = rows.copy()
    r[200:202, 2] = -9.0e5  # two samples of -900 kN on an 800 N force
    case("double_spike", "ok", r"column 'bearing2_fx': 1 isolated spike\(s\)", csv_text(r))
    r = rows.copy()
    r[50:60, 1] = 300.0 + 0.1 * np.arange(10)  # ten samples far out: kept and reported, not interpolated
    case("long_excursion", "ok", r"column 'dte': 1 excursion\(s\) beyond 100 robust scales kept", csv_text(r))
    r = rows.copy()
    r[100:120, 2] = r[99, 2]  # the acquisition repeats its last value (a dropout): like a NaN run
    case(
        "held_value",
        "error",
        r"column 'bearing2_fx': holds the value \d+\.\d+ N for 21 samples \(0.021 s\) from t = 0.099 s",
        csv_text(r),
    )
    r = rows.copy()
    r[200:240, 1:] = r[160:200, 1:]  # a buffer delivered twice, the time column running on
    case(
        "repeated_block",
        "error",
        r"rows at t = 0.2 .. 0.239 s repeat, on every column, the 40 samples",
        csv_text(r),
    )
    r = rows.copy()
    r[77, 1] = 1e300
    case(
        "glitch_1e300",
        "error",
        r"column 'dte': 1 non-physical sample\(s\), first 1e\+294 m at t = 0.077 s "
        r"\(sample 77\), beyond the physical limit 1 m",
        csv_text(r),
    )
    r = rows.copy()
    r[10, 2] = -1e12
    case(
        "force_beyond_limit",
        "error",
        r"column 'bearing2_fx'.*-1e\+12 N at t = 0.01 s.*physical limit 1e\+09 N",
        csv_text(r),
    )
    r = rows.copy()
    r[300, 1] = 9.0e5  # 0.9 m: below the 1 m limit, but ~1.5e6 robust scales of a 0.5 um signal
    case(
        "glitch_robust_scale",
        "error",
        r"column 'dte'.*t = 0.3 s.*more than 1e\+06 robust scales",
        csv_text(r),
    )
    r = rows.copy()
    r[40, 1] = np.inf
    case(
        "inf_sample",
        "error",
        r"column 'dte': 1 NaN/inf run\(s\), 1 samples, longest 1, first at t = 0.04 s",
        csv_text(r),
    )
    r = rows.copy()
    r[41:44, 2] = -np.inf
    case("neg_inf_run", "error", r"column 'bearing2_fx': 1 NaN/inf run\(s\), 3 samples", csv_text(r))
    r = rows.copy()
    r[100:130, 1] = np.nan
    case(
        "nan_run",
        "error",
        r"column 'dte': 1 NaN run\(s\), 30 samples, longest 30, first at t = 0.1 s",
        csv_text(r),
    )
    r = rows.copy()
    r[5, 0] = np.nan
    case("nan_time", "error", r"time_s: non-finite value at row 7", csv_text(r))
    rng = np.random.default_rng(9)
    blob = bytes(rng.integers(0, 256, 2048, dtype=np.uint8))
    blob = blob[:10] + b"\x9d" + blob[11:]
    case(
        "binary_as_csv",
        "error",
        r"binary_as_csv.csv: not a text file \(byte 0x.. at offset \d+\); expected a UTF-8 "
        r"CSV file \(header row 'time_s,<column>,...'\) with a YAML sidecar",
        blob,
    )
    case(
        "latin1_header",
        "error",
        r"latin1_header.csv: not a text file \(byte 0xb5 at offset 20\)",
        csv_text(rows, "time_s,dte,bearing2_fx").replace("bearing2_fx", "bearing2_\xb5", 1).encode("latin-1"),
        sidecar=with_side(channels=[SIDECAR["channels"][0]]),
    )
    case(
        "binary_sidecar",
        "error",
        r"binary_sidecar.yaml: not a text file .*expected a UTF-8 YAML sidecar",
        csv_text(rows),
        sidecar=b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR",
    )
    case("empty_file", "error", r"first column must be 'time_s', header is \[\]", "")
    case(
        "header_only", "error", r"header_only.csv: no data rows after the header", "time_s,dte,bearing2_fx\n"
    )
    case("single_row", "error", r"only 1 sample\(s\); at least 2 are required", csv_text(rows[:1]))
    r = rows.copy()
    r[[150, 151], 0] = r[[151, 150], 0]
    case(
        "time_not_increasing",
        "error",
        r"time_s: not strictly increasing at row 153 \(0.151 -> 0.15\)",
        csv_text(r),
    )
    r = rows.copy()
    r[:, 0] *= 2.0
    case(
        "wrong_sample_rate",
        "error",
        r"time_s: median step 0.002 s disagrees with sample_rate_hz 1000.0",
        csv_text(r),
    )
    r = rows.copy()
    r[200:, 0] += 0.0003
    case("irregular_step", "error", r"time_s: 1 irregular step\(s\), first after t = 0.199 s", csv_text(r))
    r = rows.copy()
    r[250:, 0] += 0.5
    case("time_gap", "error", r"gap in time_s of 0.501 s after t = 0.249 s", csv_text(r))
    case(
        "unknown_unit",
        "error",
        r"channels\[0\].unit: unit 'furlong' is not understood",
        csv_text(rows),
        sidecar=with_side(channels=[{**SIDECAR["channels"][0], "unit": "furlong"}, SIDECAR["channels"][1]]),
    )
    case(
        "unit_wrong_dimension",
        "error",
        r"channels\[1\].unit: unit 'mm' is a length unit, this channel needs force",
        csv_text(rows),
        sidecar=with_side(channels=[SIDECAR["channels"][0], {**SIDECAR["channels"][1], "unit": "mm"}]),
    )
    case(
        "unknown_quantity",
        "error",
        r"channels\[0\].quantity: unknown quantity 'temperature'",
        csv_text(rows),
        sidecar=with_side(
            channels=[{**SIDECAR["channels"][0], "quantity": "temperature"}, SIDECAR["channels"][1]]
        ),
    )
    case(
        "missing_column",
        "error",
        r"channels\[1\].column: 'bearing3_fy' missing from the CSV header",
        csv_text(rows),
        sidecar=with_side(
            channels=[SIDECAR["channels"][0], {**SIDECAR["channels"][1], "column": "bearing3_fy"}]
        ),
    )
    case(
        "missing_bearing",
        "error",
        r"channels\[1\].bearing: required for quantity 'bearing_force'",
        csv_text(rows),
        sidecar=with_side(
            channels=[
                SIDECAR["channels"][0],
                {k: v for k, v in SIDECAR["channels"][1].items() if k != "bearing"},
            ]
        ),
    )
    case(
        "missing_sidecar", "error", r"sidecar .*missing_sidecar.yaml not found", csv_text(rows), sidecar=None
    )
    case(
        "speed_zero",
        "error",
        r"operating_point.speed_rpm: must be positive and finite, got 0",
        csv_text(rows),
        sidecar=with_side(operating_point={"speed_rpm": 0, "temperature_c": 25}),
    )
    case(
        "speed_negative",
        "error",
        r"operating_point.speed_rpm: must be positive and finite, got -3000",
        csv_text(rows),
        sidecar=with_side(operating_point={"speed_rpm": -3000, "temperature_c": 25}),
    )
    case(
        "temperature_nan",
        "error",
        r"operating_point.temperature_c: must be finite, got nan",
        csv_text(rows),
        sidecar=with_side(operating_point={"speed_rpm": 3000, "temperature_c": float("nan")}),
    )
    case(
        "sample_rate_text",
        "error",
        r"sample_rate_hz: expected a number, got 'fast'",
        csv_text(rows),
        sidecar=with_side(sample_rate_hz="fast"),
    )
    case(
        "broken_yaml",
        "error",
        r"broken_yaml.yaml: not valid YAML",
        csv_text(rows),
        sidecar="sample_rate_hz: 1000\nchannels: [\n  {column: dte\n",
    )
    case(
        "sidecar_is_list",
        "error",
        r"sidecar_is_list.yaml: expected a mapping at the top level",
        csv_text(rows),
        sidecar="- 1\n- 2\n",
    )
    case(
        "sidecar_unknown_key",
        "error",
        r"unknown key\(s\) \['sampling_rate'\]",
        csv_text(rows),
        sidecar=with_side(sampling_rate=1000),
    )
    lines = csv_text(rows).splitlines()
    lines[10] = lines[10].split(",")[0] + ",abc," + lines[10].split(",")[2]
    case(
        "malformed_row",
        "error",
        r"malformed row: could not convert string 'abc' to float64 at row \d+, column 2",
        "\n".join(lines) + "\n",
    )
    lines = csv_text(rows).splitlines()
    lines[21] += ",1.0"
    case(
        "extra_field",
        "error",
        r"malformed row: the number of columns changed from 3 to 4 at row \d+",
        "\n".join(lines) + "\n",
    )
    lines = csv_text(rows).splitlines()
    lines[31] = lines[31].split(",")[0] + ",," + lines[31].split(",")[2]
    case(
        "empty_field",
        "error",
        r"column 'dte': 1 NaN run\(s\), 1 samples, longest 1, first at t = 0.03 s",
        "\n".join(lines) + "\n",
    )
    case(
        "duplicate_column",
        "error",
        r"duplicate column\(s\) \['dte'\]",
        csv_text(rows, "time_s,dte,dte"),
        sidecar=with_side(channels=[SIDECAR["channels"][0]]),
    )
    case(
        "no_time_column",
        "error",
        r"first column must be 'time_s', header is \['t', 'dte', 'bearing2_fx'\]",
        csv_text(rows, "t,dte,bearing2_fx"),
    )
    case(
        "unsupported_type",
        "error",
        r"unsupported file type '.txt'; supported: .csv \(\+ .yaml\), .mcap, .mat",
        csv_text(rows),
        ext=".txt",
    )
    case("garbage_mcap", "error", r"garbage_mcap.mcap: cannot read MCAP", blob, sidecar=None, ext=".mcap")
    case(
        "garbage_mat",
        "error",
        r"garbage_mat.mat: cannot read MATLAB file",
        blob,
        ext=".mat",
        sidecar=with_side(
            channels=[
                {
                    "key": "X*_DE_time",
                    "quantity": "housing_acceleration",
                    "bearing": 1,
                    "direction": "y",
                    "unit": "g",
                }
            ]
        ),
    )
    manifest = {
        "description": "Malformed measurements for gear-rotor-sim calibrate; made by make_measurements.py. "
        "expect: error -> exit status 2 and a one-line error matching `match`; "
        "expect: ok -> loaded, one of Measurement.issues matches `match` (if given).",
        "cases": CASES,
    }
    (OUT / "manifest.yaml").write_text(yaml.safe_dump(manifest, sort_keys=False, width=200))
    print(f"{len(CASES)} cases -> {OUT}")


if __name__ == "__main__":
    main()
