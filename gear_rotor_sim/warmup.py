"""Compile the numba kernels ahead of the first run: ``python -m gear_rotor_sim.warmup [--if-changed]``.

The solver kernels are compiled with ``@njit(cache=True)``: the first process that calls them spends
tens of seconds in LLVM (46 s for the node's first message on a 2-core machine) and writes the
machine code next to the sources (``gear_rotor_sim/solver/__pycache__``, or ``NUMBA_CACHE_DIR``);
every later process loads it. ``scripts/setup_env.sh`` runs this module, so that the first
``ros2 run gear_rotor_sim simulator`` after the set-up starts as fast as the later ones.

What is compiled: a :class:`~gear_rotor_sim.simulator.Simulator` of the node's default model
(``paper_sun2021``) with every channel of the rig (the dispatch is by argument types, not sizes, so
this covers any channel selection), run briefly at steady speed, at a speed where the teeth
separate (event location), and through a speed ramp and a temperature ramp (the output FIR and the
rebuilds), with a misaligned gear (the binning of its running mesh-force average,
``solver/sync_average.py``); then the two-stage example (``two_stage_example``, two meshes
through the same gear kernel, ``solver/gear_kernel.py``).

``--if-changed`` skips the run when the stamp written by the last warm-up still matches: numba's and
numpy's versions, the Python version, the CPU numba compiles for and the modification time and
size of every source file holding a kernel (:func:`kernel_sources`, found by their ``@njit``; the
quantities numba itself checks before reusing a cached function). The stamp lives in the cache
directory, so deleting the cache also re-runs it.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import platform
import sys
import time
from pathlib import Path

STAMP_NAME = "gear_rotor_sim_warmup.stamp"
_PACKAGE = Path(os.path.abspath(os.path.dirname(__file__)))  # as imported, like numba's locators
_MARKERS = ("@njit", "@jit", "numba.njit", "numba.jit")


def kernel_sources() -> list[str]:
    """Package-relative paths of the source files holding numba-compiled functions."""
    out = []
    for path in sorted(_PACKAGE.rglob("*.py")):
        if "__pycache__" in path.parts or path.name == "warmup.py":
            continue
        text = path.read_text(encoding="utf-8", errors="replace")
        if any(m in text for m in _MARKERS):
            out.append(path.relative_to(_PACKAGE).as_posix())
    return out


def cache_dir() -> Path:
    """Where numba caches the solver kernels.

    ``solver/__pycache__`` next to the sources by default (a symlinked install, such as colcon's
    ``--symlink-install``, reaches the same directory); with ``NUMBA_CACHE_DIR`` numba mirrors the
    source directory's path, as imported, below that root, so the warm-up must then import the
    package from the same path as the node.
    """
    root = os.environ.get("NUMBA_CACHE_DIR")
    solver = _PACKAGE / "solver"
    if root:
        return Path(root) / str(solver).lstrip(os.sep)
    return solver / "__pycache__"


def stamp() -> str:
    """Hash of what decides whether numba can reuse its cache (versions, CPU, kernel sources)."""
    import numba
    import numpy
    from numba.core import config

    try:
        import llvmlite.binding as llvm

        cpu = config.CPU_NAME or llvm.get_host_cpu_name()
        features = config.CPU_FEATURES or llvm.get_host_cpu_features().flatten()
    except Exception:  # pragma: no cover - llvmlite is a numba dependency
        cpu, features = platform.processor(), ""
    parts = [numba.__version__, numpy.__version__, sys.version, platform.machine(), str(cpu), str(features)]
    for rel in kernel_sources():
        st = (_PACKAGE / rel).stat()
        parts.append(f"{rel}:{st.st_mtime!r}:{st.st_size}")
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


def is_current() -> bool:
    """True when the last warm-up's stamp matches :func:`stamp`."""
    p = cache_dir() / STAMP_NAME
    try:
        return p.read_text(encoding="ascii").strip() == stamp()
    except OSError:
        return False


def kernel_compile_counts() -> tuple[int, int]:
    """Numba signatures of the package's cached kernels (``@njit(cache=True)``) loaded from the cache
    and compiled, so far in this process (the node logs them with its start-up time: a start after
    the warm-up compiles nothing)."""
    from numba.core.registry import CPUDispatcher

    seen: set[int] = set()
    loaded = compiled = 0
    for name, module in list(sys.modules.items()):
        if module is None or not (name == "gear_rotor_sim" or name.startswith("gear_rotor_sim.")):
            continue
        for obj in list(vars(module).values()):
            if isinstance(obj, CPUDispatcher) and id(obj) not in seen:
                seen.add(id(obj))
                loaded += sum(obj.stats.cache_hits.values())
                compiled += sum(obj.stats.cache_misses.values())
    return loaded, compiled


def warm_up(verbose: bool = True) -> float:
    """Run the simulator briefly along every path the node uses; return the wall time, s.

    Writes the stamp of :func:`stamp` into :func:`cache_dir` when done.
    """
    from gear_rotor_sim.examples import paper_gearbox
    from gear_rotor_sim.simulator import Simulator

    t0 = time.perf_counter()
    cfg = paper_gearbox()
    channels = [name for name, _unit in Simulator.available_channels(cfg)]
    sim = Simulator(cfg, speed_rpm=3000.0, temperature_c=25.0, output_rate_hz=20000.0, channels=channels)
    sim.advance(0.02)  # steady, teeth in contact
    sim.set_targets(speed_rpm=3100.0, temperature_c=26.0)
    sim.advance(0.06)  # speed and temperature ramps (rebuilds, ramped mesh phase)
    fast = Simulator(cfg, speed_rpm=17000.0, temperature_c=25.0, output_rate_hz=20000.0, channels=channels)
    fast.advance(0.01)  # inside the main chaotic band: contact loss, located mesh events
    from gear_rotor_sim.faults import GearMisalignment

    tilted = (GearMisalignment(angle_rad=1e-3),)  # its axial force's running mesh-force average
    Simulator(cfg, 3000.0, 25.0, 20000.0, channels=["dte"], effects=tilted).advance(0.01)
    from gear_rotor_sim.config import load_config

    two = load_config("two_stage_example")
    names = [name for name, _unit in Simulator.available_channels(two)]
    Simulator(two, speed_rpm=3000.0, temperature_c=25.0, output_rate_hz=20000.0, channels=names).advance(0.01)
    wall = time.perf_counter() - t0
    d = cache_dir()
    d.mkdir(parents=True, exist_ok=True)
    (d / STAMP_NAME).write_text(stamp() + "\n", encoding="ascii")
    if verbose:
        print(f"[warmup] numba kernels compiled and cached in {wall:.1f} s ({d})")
    return wall


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m gear_rotor_sim.warmup", description=__doc__.split("\n")[0]
    )
    parser.add_argument(
        "--if-changed", action="store_true", help="skip when the cache is current (stamp unchanged)"
    )
    args = parser.parse_args(argv)
    if args.if_changed and is_current():
        print(f"[warmup] numba cache current ({cache_dir()}); nothing to compile")
        return 0
    warm_up()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
