"""``python -m gear_rotor_sim.warmup --if-changed``: the stamp that decides whether to compile again."""

from __future__ import annotations

import os
import shutil
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
