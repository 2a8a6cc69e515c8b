"""``gear-rotor-sim reproduce``: the paper's Section 4 results side by side with this model.

Regenerates ``docs/REPRODUCTION.md`` and ``docs/figures/*.png`` (and caches the raw results as
``docs/figures/data/*.npz``). ``--quick`` uses a coarser speed grid and shorter windows (< 5 min
on the 2-core development machine); ``--json`` prints one JSON object with the key numbers.

What is computed
----------------
* Fig 6: bifurcation diagrams (25 C; 225 C with and without thermal backlash), motion windows,
  the chaotic windows against the paper's, and the wall time of panel (a) with set-up included.
* Fig 7: RMS total force of bearing 2 against speed at 25/125/225 C (A#), the quoted points.
* Fig 8/9/10: one speed (19000 rpm), 25/125/225 C x A#/B#/C#: node displacement amplitudes,
  force shares per direction, bearing-2 orbits.
* Sensitivity of the Fig 7 points at 1000 rpm to the parameters the paper does not give (mesh
  damping ratio, friction coefficient, shaft Rayleigh damping).
* Solver benchmark: steps per second and real-time factors at 3000 and 20000 rpm.

This module holds the plan (how much to compute), :func:`compute` (the studies in order) and the
command line. Elsewhere: the Fig 6-10 runs in :mod:`~gear_rotor_sim.analysis.reproduce_figs`, the
side studies in :mod:`~gear_rotor_sim.analysis.reproduce_studies`, the solver numbers in
:mod:`~gear_rotor_sim.analysis.reproduce_bench`, the window algebra in
:mod:`~gear_rotor_sim.analysis.bands`, the ``--json`` object in
:mod:`~gear_rotor_sim.analysis.reproduce_json`, the paper's numbers in
:mod:`~gear_rotor_sim.analysis.paper_data` and the Markdown report in
:mod:`~gear_rotor_sim.analysis.reproduction_report`.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from gear_rotor_sim.analysis.bands import (  # noqa: F401 (re-exported: readings, tests)
    condense_windows,
    label_at,
    main_band,
    merge_windows,
    overlap_near,
)
from gear_rotor_sim.analysis.bifurcation import RunSettings
from gear_rotor_sim.analysis.paper_data import (
    INV_ISO_SCALE,
    ISO_SCALE,
    PANELS,
    STIFFNESS_SCALES,
)
from gear_rotor_sim.analysis.reproduce_bench import (  # noqa: F401 (re-exported: benchmarks, docs)
    ACCURACY_POINTS,
    REFERENCE_STEPS_PER_MESH,
    benchmark,
    default_against_full,
)
from gear_rotor_sim.analysis.reproduce_figs import (
    DEFAULT_CONFIG,
    Output,
    config_extras,
    fig6_numbers,
    fig6_runs,
    fig7_numbers,
    figs8_10_numbers,
)
from gear_rotor_sim.analysis.reproduce_json import printed_json, summary_json  # noqa: F401
from gear_rotor_sim.analysis.reproduce_studies import (  # noqa: F401 (re-exported)
    Runner,
    iso_stiffness_ratio,
    mesh_modes,
    refine_main_band,
    sensitivity_study,
    single_speed_figures,
    static_axial_estimate,
    stiffness_study,
)
from gear_rotor_sim.analysis.reproduction_report import write_report
from gear_rotor_sim.examples import PAPER_CONFIGS


# ----------------------------------------------------------------------------------------------- plan
@dataclass(frozen=True)
class Plan:
    """How much to compute.

    Attributes
    ----------
    name : str
        ``"full"``, ``"quick"`` or ``"tiny"`` (tests).
    fig6_speeds : tuple of float
        Bifurcation grid.
    fig6 : RunSettings
        Window per speed of the bifurcation runs.
    fig7_speeds : tuple of float
        Fig 7 grid (always contains 1000 and 14400 rpm).
    sweep : RunSettings
        Window per speed of the force/displacement sweeps.
    fig8_bearings : tuple of str
        Bearing types of the 19000 rpm study.
    sensitivity : bool
        Run the parameter-sensitivity study.
    bench_duration_s : float
        Simulated seconds per benchmark speed.
    single_speed_figures : bool
        Draw the phase portraits, Poincare maps and spectra at 3000 and 14000 rpm.
    stiffness_scales : tuple of float
        Mesh-stiffness scales of the stiffness study (Fig 7 sweep and 19000 rpm point per scale);
        empty: no stiffness study.
    stiffness_bifurcations : tuple of (str, float)
        (Fig 6 panel key, scale) bifurcation runs of the stiffness study (scale 1 is the main run).
    """

    name: str
    fig6_speeds: tuple[float, ...]
    fig6: RunSettings
    fig7_speeds: tuple[float, ...]
    sweep: RunSettings
    fig8_bearings: tuple[str, ...]
    sensitivity: bool
    bench_duration_s: float
    single_speed_figures: bool = True
    stiffness_scales: tuple[float, ...] = ()
    stiffness_bifurcations: tuple[tuple[str, float], ...] = ()

    @staticmethod
    def level(name: str) -> Plan:
        """The plan of level ``name`` (``"full"``, ``"quick"`` or ``"tiny"``); ValueError otherwise."""

        def grid(n: int) -> tuple[float, ...]:
            return tuple(float(s) for s in np.round(np.linspace(500.0, 20000.0, n), 1))

        def fig7(n: int) -> tuple[float, ...]:
            return tuple(float(s) for s in np.union1d(np.linspace(500.0, 20000.0, n), [1000.0, 14400.0]))

        if name == "full":
            return Plan(
                "full",
                grid(400),
                RunSettings(300, 200, 32, 4.0),
                fig7(79),
                RunSettings(300, 200, 32, 4.0),
                ("A#", "B#", "C#"),
                True,
                0.5,
                stiffness_scales=STIFFNESS_SCALES,
                stiffness_bifurcations=(
                    ("25C", INV_ISO_SCALE),
                    ("25C", 0.87),
                    ("25C", 1.15),
                    ("25C", ISO_SCALE),
                    ("225C", INV_ISO_SCALE),
                    ("225C", ISO_SCALE),
                    ("225C_fixed", INV_ISO_SCALE),
                    ("225C_fixed", ISO_SCALE),
                ),
            )
        if name == "quick":
            return Plan(
                "quick",
                grid(80),
                RunSettings(150, 100, 32, 4.0),
                fig7(14),
                RunSettings(150, 100, 32, 4.0),
                ("A#", "B#", "C#"),
                True,
                0.1,
                stiffness_scales=STIFFNESS_SCALES,
                stiffness_bifurcations=(("25C", INV_ISO_SCALE), ("25C", ISO_SCALE)),
            )
        if name == "tiny":
            return Plan(
                "tiny",
                grid(2),
                RunSettings(10, 20, 16, 2.0),
                (1000.0, 14400.0),
                RunSettings(20, 20, 16, 4.0),
                ("A#",),
                False,
                0.005,
                False,
            )
        raise ValueError(f"level: {name!r} is not 'full', 'quick' or 'tiny'")


def _data_dir(out: Path) -> Path:
    d = out / "figures" / "data"
    d.mkdir(parents=True, exist_ok=True)
    return d


# ----------------------------------------------------------------------------------------------- the run
def compute(
    plan: Plan,
    out: Path,
    workers: int | None,
    scheduler: str | None,
    progress: bool,
    config: str = DEFAULT_CONFIG,
) -> dict[str, Any]:
    """Run every study of ``plan``; save caches and figures under ``out``; return the numbers.

    ``config`` names the paper configuration (:data:`gear_rotor_sim.examples.PAPER_CONFIGS`); a
    non-default one writes its figures to ``out/figures/<config>/``, prefixes its caches with the
    name and adds the finely resolved Fig 6a main band (:func:`refine_main_band`).
    """
    data_dir = _data_dir(out)
    tag = "" if config == DEFAULT_CONFIG else f"{config}_"
    fig_dir = out / "figures" if config == DEFAULT_CONFIG else out / "figures" / config
    panels = {k: dataclasses.replace(c, config=config) for k, c in PANELS.items()}
    r: dict[str, Any] = {"level": plan.name, "config": config}
    runner = Runner(workers, scheduler, progress)

    # Figs 6-10 ------------------------------------------------------------------------------------
    o = Output(data_dir, fig_dir, tag)
    bif, load_avg = fig6_runs(plan, runner, panels, o)
    r["fig6"] = fig6_numbers(bif, load_avg)
    if config != DEFAULT_CONFIG:
        r.update(config_extras(plan, config, panels, bif))
    if plan.single_speed_figures:
        single_speed_figures(fig_dir, plan)
    s7, fig7 = fig7_numbers(plan, runner, config, o)
    r.update(fig7)
    r.update(figs8_10_numbers(plan, runner, config, o))

    # Sensitivity ---------------------------------------------------------------------------------
    if plan.sensitivity:
        r["sensitivity"] = sensitivity_study(plan, runner, data_dir, fig_dir)

    # Mesh-stiffness scale --------------------------------------------------------------------------
    if plan.stiffness_scales:
        r["stiffness"] = stiffness_study(plan, bif, s7, runner, data_dir, fig_dir)

    # Benchmark -----------------------------------------------------------------------------------
    r["benchmark"] = benchmark(
        plan.bench_duration_s, quick=plan.name != "full", use_script=plan.name != "tiny"
    )
    return r


# ----------------------------------------------------------------------------------------------- CLI
def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``gear-rotor-sim reproduce``."""
    parser.add_argument("--quick", action="store_true", help="coarser grid and shorter windows (< 5 min)")
    parser.add_argument(
        "--level", choices=("full", "quick", "tiny"), default=None, help="explicit level (tiny: tests)"
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object with the key numbers")
    parser.add_argument("--out", default="docs", help="output directory (REPRODUCTION.md, figures/)")
    parser.add_argument(
        "--workers", type=int, default=None, help="local worker processes (default: all cores)"
    )
    parser.add_argument("--scheduler", default=None, help="Dask scheduler address")
    parser.add_argument("--no-report", action="store_true", help="do not write REPRODUCTION.md")
    parser.add_argument(
        "--config",
        choices=PAPER_CONFIGS,
        default=DEFAULT_CONFIG,
        help="paper configuration (paper_sun2021_as_published: gear mass in Eq 20 and Eq 32, "
        "docs/REPRODUCTION.md); a non-default one skips the sensitivity and stiffness studies, adds "
        "the finely resolved Fig 6a band and the as-published section of REPRODUCTION.md",
    )
    parser.add_argument(
        "--report-only",
        action="store_true",
        help="rewrite REPRODUCTION.md from the saved numbers (no simulation)",
    )


def _default_results(out: Path, level: str) -> dict[str, Any] | None:
    """The saved default results REPRODUCTION.md is built from (full, else quick; tiny for tiny)."""
    for lv in ("tiny",) if level == "tiny" else ("full", "quick"):
        p = _data_dir(out) / f"reproduce_{lv}.json"
        if p.is_file():
            return json.loads(p.read_text(encoding="utf-8"))
    return None


def run(args: argparse.Namespace) -> int:
    """Run ``gear-rotor-sim reproduce`` (compute, save, write REPRODUCTION.md, print); exit status."""
    level = args.level or ("quick" if args.quick else "full")
    config = getattr(args, "config", DEFAULT_CONFIG)
    plan = Plan.level(level)
    if config != DEFAULT_CONFIG:  # the studies of the default model are not repeated
        plan = dataclasses.replace(
            plan,
            sensitivity=False,
            single_speed_figures=False,
            stiffness_scales=(),
            stiffness_bifurcations=(),
        )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    suffix = "" if config == DEFAULT_CONFIG else f"_{config}"
    saved = _data_dir(out) / f"reproduce_{level}{suffix}.json"
    if args.report_only:
        r = json.loads(saved.read_text(encoding="utf-8"))
        base = r if config == DEFAULT_CONFIG else _default_results(out, level)
        path = write_report(base, out, float(base["total_wall_s"])) if base is not None else saved
        print(json.dumps(printed_json(r), default=float) if args.json else f"wrote {path}")
        return 0
    t0 = time.perf_counter()
    r = compute(plan, out, args.workers, args.scheduler, progress=True, config=config)
    total = time.perf_counter() - t0
    r["total_wall_s"] = total
    saved.write_text(json.dumps(r, indent=1, default=float), encoding="utf-8")
    if not args.no_report:
        # REPRODUCTION.md is the default model's report; a non-default run rewrites it from the saved
        # default results with its own section added (reproduction_report.published_section)
        base = r if config == DEFAULT_CONFIG else _default_results(out, level)
        if base is not None:
            path = write_report(base, out, float(base["total_wall_s"]))
            if not args.json:
                print(f"wrote {path} ({total:.0f} s)")
        elif not args.json:
            print(f"saved {saved} ({total:.0f} s); no default results in {out} to write REPRODUCTION.md from")
    if args.json:
        print(json.dumps(printed_json(r), default=float))
    sys.stdout.flush()
    return 0
