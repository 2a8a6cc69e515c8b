"""A guard against stale numba caches in the solver, run once when :mod:`gear_rotor_sim.solver` is imported.

numba checks a cached function against its own source file only (its modification time and size),
and a caller's cached machine code holds the code of every compiled function it calls (numba links
them into the caller's library). ``gear_kernel.run_chunk_gear`` holds the step loop of
``gear_loop.py``, the inlined parts of ``gear_step.py``, ``gear_events.py``, ... and the mesh solve of
``kernels.py`` (docs/solver.md, "Module layout"; the hazard existed before the split of session 17 for
``kernels.py``'s functions). After an upgrade or an edit of a callee's module alone, numba would load
the caller's old code silently. So :func:`check` keeps a digest of the content of the solver's kernel
sources (the files holding ``@njit``) beside numba's cache of them; when the digest differs (or is
missing), it deletes the solver's cached kernels there (index ``.nbi``, code ``.nbc``) before any
kernel is called, and every kernel is compiled anew once (about a minute; ``python -m
gear_rotor_sim.warmup`` does it ahead). An edit that leaves the content unchanged (a touched file)
clears nothing: numba then recompiles that file's own functions, whose callees are unchanged.

The cache directory is the one numba picks for these files (its locators in numba's order:
``NUMBA_CACHE_DIR``'s mirror of the source path, the ``__pycache__`` beside the sources if writable,
else the user-wide cache). A directory that cannot be written is left alone (nothing of ours can
have been cached there either).
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

#: Name of the digest file kept in numba's cache directory of the solver.
STAMP_NAME = "gear_rotor_sim_solver_sources.sha256"
SOLVER = Path(os.path.abspath(os.path.dirname(__file__)))  # as imported, like numba's locators
_MARKERS = ("@njit", "@jit", "numba.njit", "numba.jit")


def kernel_files(folder: Path = SOLVER) -> list[Path]:
    """The solver's source files holding numba-compiled functions, sorted."""
    out = []
    for path in sorted(folder.glob("*.py")):
        text = path.read_text(encoding="utf-8", errors="replace")
        if path.name != "cache_guard.py" and any(m in text for m in _MARKERS):
            out.append(path)
    return out


def source_digest(folder: Path = SOLVER) -> str:
    """SHA-256 of the kernel sources' names and contents and of numba's version."""
    import numba

    h = hashlib.sha256(f"numba {numba.__version__}\n".encode())
    for path in kernel_files(folder):
        h.update(f"{path.name}\n".encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def cache_dir(folder: Path = SOLVER) -> Path | None:
    """The directory numba caches the solver's kernels in (None if it finds none it can write)."""
    files = kernel_files(folder)
    if not files:
        return None
    try:  # numba's own choice, in its order of locators
        from numba.core.caching import CacheImpl

        for cls in CacheImpl._locator_classes:
            loc = cls.from_function(kernel_files, str(files[0]))
            if loc is not None:
                return Path(loc.get_cache_path())
        return None
    except (ImportError, AttributeError):  # pragma: no cover - another numba layout
        root = os.environ.get("NUMBA_CACHE_DIR")
        return Path(root) / str(folder).lstrip(os.sep) if root else folder / "__pycache__"


def check(folder: Path = SOLVER, cache: Path | None = None) -> int:
    """Delete the cached kernels of ``folder``'s sources in ``cache`` (default: :func:`cache_dir`) if
    the sources' digest differs from the one stored there, and store the new one.

    Returns the number of files deleted (0 when the digest matched, or when nothing was cached)."""
    cache = cache_dir(folder) if cache is None else cache
    if cache is None:
        return 0
    digest = source_digest(folder)
    stamp = cache / STAMP_NAME
    try:
        if stamp.read_text(encoding="ascii").strip() == digest:
            return 0
    except OSError:
        pass
    stems = {p.stem for p in kernel_files(folder)}
    n = 0
    try:
        for p in list(cache.glob("*.nb[ic]")):
            if p.name.split(".", 1)[0] in stems:
                p.unlink(missing_ok=True)
                n += 1
        cache.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=cache, prefix=STAMP_NAME, suffix=".tmp")
        with os.fdopen(fd, "w", encoding="ascii") as fh:
            fh.write(digest + "\n")
        os.replace(tmp, stamp)  # atomic: concurrent imports write the same digest
    except OSError:  # a read-only install: numba cannot have cached anything there either
        return n
    return n
