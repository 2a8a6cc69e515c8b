"""``python -m gear_rotor_sim.warmup --if-changed``: the stamp that decides whether to compile again."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from gear_rotor_sim import warmup


@pytest.fixture
def tree(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A copy of the kernel sources; the stamp and cache directory follow it."""
    pkg = tmp_path / "gear_rotor_sim"
    for rel in warmup.kernel_sources():
        (pkg / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(Path(warmup.__file__).parent / rel, pkg / rel)
    monkeypatch.setattr(warmup, "_PACKAGE", pkg)
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    return pkg


def test_kernel_sources_are_found() -> None:
    assert {"solver/kernels.py", "solver/gear_kernel.py", "solver/decimate.py"} <= set(
        warmup.kernel_sources()
    )
    assert "warmup.py" not in warmup.kernel_sources()


def test_stamp_follows_the_kernel_sources(tree: Path) -> None:
    assert warmup.cache_dir() == tree / "solver" / "__pycache__"
    assert not warmup.is_current()  # no warm-up yet
    warmup.cache_dir().mkdir(parents=True)
    (warmup.cache_dir() / warmup.STAMP_NAME).write_text(warmup.stamp() + "\n", encoding="ascii")
    assert warmup.is_current()
    # numba re-compiles when a source's modification time changes: so does the warm-up
    src = tree / "solver" / "gear_kernel.py"
    st = src.stat()
    os.utime(src, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000_000))
    assert not warmup.is_current()


def test_if_changed_skips_a_current_cache(tree: Path, monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    warmup.cache_dir().mkdir(parents=True)
    (warmup.cache_dir() / warmup.STAMP_NAME).write_text(warmup.stamp() + "\n", encoding="ascii")

    def fail(*_a: object, **_k: object) -> float:
        raise AssertionError("warm_up must not run when the cache is current")

    monkeypatch.setattr(warmup, "warm_up", fail)
    assert warmup.main(["--if-changed"]) == 0
    assert "numba cache current" in capsys.readouterr().out


def test_numba_cache_dir_mirrors_the_source_path(tree: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("NUMBA_CACHE_DIR", "/var/cache/nb")
    assert warmup.cache_dir() == Path("/var/cache/nb") / str(tree / "solver").lstrip(os.sep)


def test_compile_counts_tell_a_cold_cache_from_a_warm_one(tmp_path: Path) -> None:
    """``kernel_compile_counts``: a process with an empty numba cache compiles the kernel it calls,
    the next process loads it (what the node's start-up line reports)."""
    code = (
        "import numpy as np\n"
        "from gear_rotor_sim.solver import decimate\n"
        "from gear_rotor_sim.warmup import kernel_compile_counts\n"
        "decimate._scatter(np.zeros((2, 3, 1)), 0, np.zeros((2, 1)), np.zeros((0, 0)))\n"
        "print(*kernel_compile_counts())\n"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    runs = [
        subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
        for _ in range(2)
    ]
    assert all(r.returncode == 0 for r in runs), [r.stderr[-2000:] for r in runs]
    assert [r.stdout.split() for r in runs] == [["0", "1"], ["1", "0"]]
