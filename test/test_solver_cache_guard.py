"""``solver/cache_guard.py``: a caller's cached numba code holds its callees', and numba checks only
the caller's own source file, so the guard deletes the solver's cached kernels when the content of
any kernel source changed (docs/solver.md, "Module layout")."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from gear_rotor_sim.solver import cache_guard


@pytest.fixture
def solver(tmp_path: Path) -> Path:
    """A copy of the solver's kernel sources and a cache directory with files of two kernels and
    of a module that is not the solver's."""
    folder = tmp_path / "solver"
    folder.mkdir()
    for p in cache_guard.kernel_files():
        shutil.copy2(p, folder / p.name)
    return folder


def _cached(cache: Path) -> list[Path]:
    cache.mkdir(exist_ok=True)
    files = [
        cache / "gear_kernel.run_chunk_gear-111.py311.nbi",
        cache / "gear_kernel.run_chunk_gear-111.py311.1.nbc",
        cache / "kernels.mesh_solve-178.py311.nbi",
    ]
    for p in files:
        p.write_bytes(b"x")
    return files


def test_kernel_files_are_the_solvers_compiled_modules() -> None:
    names = {p.name for p in cache_guard.kernel_files()}
    assert {"gear_kernel.py", "gear_loop.py", "gear_step.py", "gear_events.py", "kernels.py"} <= names
    assert "newmark.py" not in names and "cache_guard.py" not in names


def test_an_edited_callee_clears_its_callers_cache(solver: Path, tmp_path: Path) -> None:
    cache = tmp_path / "cache"
    files = _cached(cache)
    other = cache / "decimate_copy.fir-1.py311.nbi"  # not a kernel source of this folder: kept
    other.write_bytes(b"x")
    assert cache_guard.check(solver, cache) == 3  # no digest yet: whatever is there may be stale
    assert not any(p.exists() for p in files) and other.exists()
    files = _cached(cache)
    assert cache_guard.check(solver, cache) == 0  # digest matches: the cache stays
    assert all(p.exists() for p in files)
    src = solver / "gear_loop.py"  # the callee's module alone, not gear_kernel.py (the caller's)
    st = src.stat()
    os.utime(src, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    assert cache_guard.check(solver, cache) == 0  # touched, same content: numba's own check suffices
    src.write_text(src.read_text(encoding="utf-8") + "\n# edited\n", encoding="utf-8")
    assert cache_guard.check(solver, cache) == 3
    assert not any(p.exists() for p in files)
    assert cache_guard.check(solver, cache) == 0


def test_a_cache_that_cannot_be_written_is_left_alone(solver: Path, tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a directory", encoding="ascii")
    assert cache_guard.check(solver, blocker / "cache") == 0  # no error: the import must not fail


def test_cache_dir_is_numbas_choice(tmp_path: Path) -> None:
    """With ``NUMBA_CACHE_DIR`` numba mirrors the source directory below it (its own locator)."""
    code = (
        "from gear_rotor_sim.solver import cache_guard\n"
        "print(cache_guard.cache_dir())\n"
        "print((cache_guard.cache_dir() / cache_guard.STAMP_NAME).exists())\n"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "nb")}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    where, stamped = out.stdout.split()
    assert Path(where).is_relative_to(tmp_path / "nb")
    assert stamped == "True"  # the import of gear_rotor_sim.solver ran the guard
