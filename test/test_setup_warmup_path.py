"""``scripts/setup_env.sh`` warms the numba cache beside the colcon build, importing the package from the
checkout, while the node imports it through colcon's ``--symlink-install`` (``build/gear_rotor_sim/
gear_rotor_sim`` -> the checkout's ``gear_rotor_sim``). That is sound only if numba's cache, without
``NUMBA_CACHE_DIR``, is found again when the same source file is imported through a symlinked directory;
with ``NUMBA_CACHE_DIR`` numba keys the cache by the path as imported, and the script then warms after the
build, through the install (test_warmup.py: the cache directory mirrors the path; docs/history/
calibration_sessions.md Sec. 8.81).

Checked with numba itself on a one-function module: one process compiles it through the real directory,
a second process imports it through a symlink and must load it from the cache (numba's own counters).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

KERNEL = "import numba\n\n@numba.njit(cache=True)\ndef plus_one(x):\n    return x + 1.0\n"
CALL = (
    "import sys\n"
    "sys.path.insert(0, sys.argv[1])\n"
    "import nbmod\n"
    "assert nbmod.plus_one(1.0) == 2.0\n"
    "s = nbmod.plus_one.stats\n"
    "print(sum(s.cache_hits.values()), sum(s.cache_misses.values()))\n"
)


def _hits_misses(directory: Path, env: dict[str, str]) -> list[str]:
    r = subprocess.run(
        [sys.executable, "-c", CALL, str(directory)], env=env, capture_output=True, text=True, timeout=300
    )
    assert r.returncode == 0, r.stderr[-2000:]
    return r.stdout.split()


@pytest.fixture
def linked(tmp_path: Path) -> tuple[Path, Path]:
    """A module in a directory (the checkout) and a symlink to that directory (colcon's build)."""
    real = tmp_path / "checkout" / "pkg"
    real.mkdir(parents=True)
    (real / "nbmod.py").write_text(KERNEL, encoding="utf-8")
    link = tmp_path / "build" / "pkg"
    link.parent.mkdir()
    link.symlink_to(real, target_is_directory=True)
    return real, link


def test_cache_written_through_the_checkout_is_loaded_through_the_symlinked_install(linked) -> None:
    real, link = linked
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    assert _hits_misses(real, env) == ["0", "1"]  # compiled, written next to the source
    assert _hits_misses(link, env) == ["1", "0"]  # the node's path: loaded, nothing compiled
