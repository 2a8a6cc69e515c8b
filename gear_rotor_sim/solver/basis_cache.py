"""Eigenbases cached on disk across runs, keyed by the content of the state matrix they diagonalise.

A ramp (docs/solver.md "Ramps") diagonalises the state matrix once per node of its speed and
temperature grids (17-54 ms each on a 2-core machine); the same nodes come back in every run of the
same rig (the node's ramps, a dataset's runs, a second ``record``). :func:`cached_eigen_basis`
stores each well-conditioned basis as one ``.npz`` file named by the SHA-1 of everything
:func:`~gear_rotor_sim.solver.newmark.eigen_basis` reads (state matrix, force columns, mesh rows,
speed, dense flag; a format tag), so a later run loads it (about 1 ms) instead of diagonalising, and
any change of the rig, the temperature or the speed gives a different key. The dense fallback is not
stored (it is built without an eigendecomposition).

Location: ``$GEAR_ROTOR_SIM_BASIS_CACHE`` if set (``off`` disables the cache), else
``$XDG_CACHE_HOME/gear_rotor_sim/bases`` (``~/.cache/...``). About 1.1 MB per basis of the paper
gearbox; the oldest files are removed when the directory grows over ``MAX_CACHE_BYTES``. Files are
written to a temporary name and renamed, so concurrent runs never read a partial file; a file that
cannot be read is recomputed and rewritten.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import zipfile
from collections import OrderedDict
from pathlib import Path

import numpy as np

from gear_rotor_sim.solver.linear_model import LinearModel
from gear_rotor_sim.solver.modal_basis import Basis, eigen_basis

__all__ = ["MAX_CACHE_BYTES", "basis_key", "cache_dir", "cached_eigen_basis"]

#: Size above which the oldest cached bases are removed, bytes.
MAX_CACHE_BYTES = 512 * 1024 * 1024
_FORMAT = "basis-v1"
#: The last bases read or computed here, by key (simulators of one rig in one process share them).
_RECENT: OrderedDict[str, Basis] = OrderedDict()
_RECENT_SIZE = 8


def cache_dir() -> Path | None:
    """The cache directory (None when ``GEAR_ROTOR_SIM_BASIS_CACHE=off``)."""
    env = os.environ.get("GEAR_ROTOR_SIM_BASIS_CACHE", "").strip()
    if env.lower() in ("off", "0", "false", "no"):
        return None
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME", "").strip()
    if not base:
        try:
            base = str(Path.home() / ".cache")
        except RuntimeError:  # no home directory: run without the cache
            return None
    return Path(base) / "gear_rotor_sim" / "bases"


def basis_key(lin: LinearModel, omega: float, force_dense: bool = False) -> str:
    """SHA-1 of everything the eigenbasis at ``omega`` depends on (hex)."""
    h = hashlib.sha1(_FORMAT.encode())
    for arr in (lin.state_matrix(omega), lin.MinvF, lin.V, lin.MinvK):
        a = np.ascontiguousarray(arr, dtype=float)
        h.update(repr(a.shape).encode())
        h.update(a.tobytes())
    h.update(repr((float(omega), bool(force_dense))).encode())
    return h.hexdigest()


def _load(path: Path, omega: float) -> Basis | None:
    try:
        with np.load(path, allow_pickle=False) as z:
            return Basis(
                omega,
                False,
                z["lam"],
                z["phi"],
                (z["lu"], z["piv"]),
                z["kept"],
                float(z["cond"]),
                None,
                float(z["scale"]),
                int(z["n_forced"]),
            )
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile):  # a damaged file: recompute
        return None


def _store(directory: Path, path: Path, b: Basis) -> None:
    try:
        directory.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=directory, suffix=".tmp")
        with os.fdopen(fd, "wb") as f:
            np.savez(
                f,
                lam=b.lam,
                phi=b.phi,
                lu=b.lu[0],
                piv=b.lu[1],
                kept=b.kept,
                cond=b.cond,
                scale=b.scale,
                n_forced=b.n_forced,
            )
        os.replace(tmp, path)
        _prune(directory)
    except OSError:
        pass  # a read-only or full disk: the run goes on without the cache


def _prune(directory: Path) -> None:
    files = [(p.stat().st_mtime, p.stat().st_size, p) for p in directory.glob("*.npz")]
    total = sum(s for _, s, _ in files)
    for _, size, p in sorted(files):
        if total <= MAX_CACHE_BYTES:
            break
        p.unlink(missing_ok=True)
        total -= size


def cached_eigen_basis(lin: LinearModel, omega: float, force_dense: bool = False) -> Basis:
    """:func:`eigen_basis`, read from or written to the disk cache (:func:`cache_dir`)."""
    directory = cache_dir()
    if directory is None or force_dense:
        return eigen_basis(lin, omega, force_dense)
    key = basis_key(lin, omega, force_dense)
    b = _RECENT.get(key)
    if b is not None:
        _RECENT.move_to_end(key)
        return b
    path = directory / f"{key}.npz"
    b = _load(path, omega) if path.exists() else None
    if b is None or b.phi.shape[0] != lin.nstate:
        b = eigen_basis(lin, omega, force_dense)
        if not b.dense:
            _store(directory, path, b)
    _RECENT[key] = b
    if len(_RECENT) > _RECENT_SIZE:
        _RECENT.popitem(last=False)
    return b
