"""Calibration self-test table: every library effect at two operating points (the acceptance study).

Usage: ``python benchmarks/calibration_selftest.py``. Same cases as test/test_calibration_selftest.py;
prints one Markdown row per case: injected truth, effect found first, fitted main parameter, error
before/after, confidence, simulations and wall time.
"""

from __future__ import annotations

import importlib.util
import math
import tempfile
import time
import zlib
from pathlib import Path

import yaml

from gear_rotor_sim.calibration.fit import Calibrator, synthetic_measurement
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.config import load_config
from gear_rotor_sim.faults import effect_name

REPO = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("selftest", REPO / "test" / "test_calibration_selftest.py")
assert spec is not None and spec.loader is not None
selftest = importlib.util.module_from_spec(spec)
spec.loader.exec_module(selftest)


def main() -> None:
    root = Path(tempfile.mkdtemp(prefix="calib_selftest_"))
    cfg_path = root / "paper_sun2021_compact.yaml"
    cfg_path.write_text(yaml.safe_dump(selftest.compact_gearbox_dict()))
    cfg = load_config(cfg_path)
    print(
        "| op | injected | truth | found first | fitted | rel. error | E before | E after | confidence "
        "| wall (s) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    cases = [(op, None, "") for op in selftest.OPS] + selftest.CASES
    for op, effect, param in cases:
        speed, temp = selftest.OPS[op]
        t = time.perf_counter()
        tag = f"{op}_{effect.label.replace('@', '_') if effect else 'healthy'}"
        csv = synthetic_measurement(
            cfg,
            [effect] if effect else [],
            speed,
            temp,
            selftest.CHANNELS,
            root / f"{tag}.csv",
            str(cfg_path),
            seed=(zlib.crc32(effect.label.encode()) % 1000) if effect else 100,
            output_torque_nm=200.0,
            steps_per_mesh=selftest.STEPS_PER_MESH,
        )
        r = Calibrator(load_measurement(csv), cfg, steps_per_mesh=selftest.STEPS_PER_MESH).run()
        wall = time.perf_counter() - t
        first = r.effects[0] if r.effects else None
        if effect is None:
            print(
                f"| {op} | none | - | {first.label if first else 'none'} | - | - | {r.error_before:.3g} | "
                f"{r.error_after:.3g} | - | {wall:.1f} |"
            )
            continue
        truth = float(getattr(effect, param))
        fitted = (
            first.parameters.get(param, math.nan) if first and first.name == effect_name(effect) else math.nan
        )
        print(
            f"| {op} | {effect.label} | {param} = {truth:.4g} | {first.label if first else 'none'} | "
            f"{fitted:.4g} | {(fitted - truth) / truth:+.1%} | {r.error_before:.3g} | {r.error_after:.3g} | "
            f"{first.confidence if first else 0:.3f} | {wall:.1f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
