"""Write the fault-grid sweep of the detection benchmark (benchmarks/detection_sweep.yaml).

9 fault types x 3 severities x 2 speeds x 2 temperatures (108 faulty runs) plus 92 healthy runs:
the 4 nominal operating points and 22 small speed offsets (+-0.25 % steps, within +-2.75 %) at each,
so that the alarm thresholds are learnt over an operating band rather than one repeated point.

    python benchmarks/detection_sweep.py            # rewrites benchmarks/detection_sweep.yaml
"""

from __future__ import annotations

from pathlib import Path

import yaml

SPEEDS_RPM = (1500.0, 3000.0)
TEMPERATURES_C = (25.0, 75.0)
#: type -> (location and fixed keys, severity key, three severities)
FAULTS = {
    "tooth_damage": ({"wheel": "gear", "tooth": 5}, "depth", (0.1, 0.3, 0.6)),
    "tooth_wear": ({}, "wear_depth_m", (2e-6, 5e-6, 15e-6)),
    "pinion_eccentricity": ({}, "eccentricity_m", (5e-6, 20e-6, 50e-6)),
    "gear_eccentricity": ({}, "eccentricity_m", (5e-6, 20e-6, 50e-6)),
    "mass_unbalance": ({"node": 5}, "unbalance_kg_m", (2e-5, 1e-4, 4e-4)),
    "shaft_misalignment": ({"node": 1}, "offset_m", (1e-5, 5e-5, 2e-4)),
    "outer_race_defect": ({"bearing": 2}, "force_n", (50.0, 200.0, 1000.0)),
    "inner_race_defect": ({"bearing": 3}, "force_n", (50.0, 200.0, 1000.0)),
    "ball_defect": ({"bearing": 1}, "force_n", (50.0, 200.0, 1000.0)),
}
HEALTHY_OFFSETS = [0.0025 * k for k in range(-11, 12) if k != 0]  # 22 offsets


def sweep() -> dict:
    fault_lists: list[list[dict]] = [[]]
    for ftype, (loc, key, severities) in FAULTS.items():
        for s in severities:
            fault_lists.append([{"type": ftype, **loc, key: s}])
    runs = [
        {"speed_rpm": round(v * (1.0 + d), 3), "temperature_c": t}
        for v in SPEEDS_RPM
        for t in TEMPERATURES_C
        for d in HEALTHY_OFFSETS
    ]
    return {
        "name": "detection_benchmark",
        "base": {
            "duration_s": 2.0,
            "sample_rate_hz": 20000,
            "streams": ["dte", "housing_accelerations"],
        },
        "grid": {"speed_rpm": list(SPEEDS_RPM), "temperature_c": list(TEMPERATURES_C), "faults": fault_lists},
        "runs": runs,
    }


def main() -> None:
    out = Path(__file__).with_name("detection_sweep.yaml")
    text = "# Written by benchmarks/detection_sweep.py; do not edit.\n" + yaml.safe_dump(
        sweep(), sort_keys=False, default_flow_style=None, width=110
    )
    out.write_text(text, encoding="utf-8")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
