"""Samples an acquisition chain did not deliver but wrote anyway (issue 11; docs/calibration.md Sec. 1,
"Validation" and "Sensor conventions and faults nobody declared").

- **A held value or a run of zeros** (a data-acquisition dropout: the driver repeats its last value or
  writes 0 while a channel's buffer is lost). A channel that carries vibration and noise repeats a value
  in consecutive samples only through quantisation; with ``p`` the fraction of consecutive equal
  samples outside the run, a run of ``L`` equal samples is a dropout when ``L >= MIN_HOLD`` and
  ``N p^(L - 1) < HOLD_CHANCE`` (not expected once by chance in the record), and the channel holds at
  most :data:`MAX_HELD_RUNS` such runs covering at most :data:`MAX_HELD_FRACTION` of it (a signal that
  holds its value often or mostly, a clamped, constant or coarsely quantised one, a mesh force that is
  exactly zero while the teeth separate, is what it is).
- **A repeated block** (a buffer delivered twice while the time column runs on): :data:`REPEAT_WINDOW`
  consecutive rows equal, on every column that varies, to an earlier stretch of rows. Noise makes
  that impossible by chance; on at most :data:`MAX_REPEATS` such blocks (an exactly periodic synthetic
  signal repeats everywhere and is left alone).

Both are returned as sample masks; ``measurement_checks._finish`` treats them as it treats NaN runs: an
error naming the column and the time by default, the longest clean segment with ``--allow-gaps``.
They are never interpolated.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: shortest held run (samples) for a dropout
MIN_HOLD = 8
#: largest expected number of chance runs of that length in the record
HOLD_CHANCE = 1e-6
#: a channel with more held runs than this holds values by nature (quantisation, clamping)
MAX_HELD_RUNS = 3
#: runs covering more than this fraction of the channel: a (mostly) constant channel, not a dropout
MAX_HELD_FRACTION = 0.25
#: rows compared for a repeated block
REPEAT_WINDOW = 16
#: a record with more repeated blocks than this is periodic by construction (synthetic)
MAX_REPEATS = 3


def equal_runs(x: np.ndarray) -> list[tuple[int, int]]:
    """Runs of at least two exactly equal consecutive samples as ``(start, length)``."""
    same = x[1:] == x[:-1]
    if not same.any():
        return []
    d = np.diff(np.concatenate([[0], same.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    return [(int(s), int(e - s + 1)) for s, e in zip(starts, ends, strict=True)]


def held_runs(x: np.ndarray) -> list[tuple[int, int, float]]:
    """Dropouts of one channel (module docstring).

    Parameters
    ----------
    x : numpy.ndarray
        The samples of one column (NaN never belongs to a run).

    Returns
    -------
    list of (int, int, float)
        ``(first sample, number of samples, the value held)`` of each dropout; none on a clean channel.
    """
    n = x.size
    runs = [r for r in equal_runs(x) if r[1] >= MIN_HOLD]
    if not runs or len(runs) > MAX_HELD_RUNS:
        return []
    if sum(length for _, length in runs) > MAX_HELD_FRACTION * np.count_nonzero(np.isfinite(x)):
        return []  # a channel that is mostly constant: no vibration to have dropped out of
    inside = sum(length - 1 for _, length in runs)
    pairs = n - 1 - inside
    same = int(np.count_nonzero(x[1:] == x[:-1])) - inside
    p = same / pairs if pairs > 0 else 1.0
    out = []
    for s, length in runs:
        chance = n * p ** (length - 1) if p > 0 else 0.0
        if chance < HOLD_CHANCE:
            out.append((s, length, float(x[s])))
    return out


def _row_keys(data: np.ndarray) -> np.ndarray:
    """A 64-bit key per row from the bit patterns of its values (equal rows, equal keys)."""
    bits = np.ascontiguousarray(data, dtype=np.float64).view(np.uint64)
    mult = np.uint64(0x9E3779B97F4A7C15)
    key = np.zeros(data.shape[0], dtype=np.uint64)
    with np.errstate(over="ignore"):
        for k in range(data.shape[1]):
            key = (key ^ bits[:, k]) * mult + np.uint64(k + 1)
    return key


def repeated_blocks(data: np.ndarray) -> list[tuple[int, int, int]]:
    """Blocks of rows that repeat an earlier stretch exactly: ``(start, length, lag)`` (module docstring).

    Parameters
    ----------
    data : numpy.ndarray
        ``(n_samples, n_channels)`` finite samples.

    Returns
    -------
    list of (int, int, int)
        Each block's first row, its number of rows and how many rows earlier its original starts; empty
        without one, and for data with more than :data:`MAX_REPEATS` blocks.
    """
    n = data.shape[0]
    varying = [k for k in range(data.shape[1]) if np.ptp(data[:, k]) > 0]
    if not varying or n < 2 * REPEAT_WINDOW:
        return []
    rows = _row_keys(data[:, varying])
    mult = np.uint64(0xBF58476D1CE4E5B9)
    win = np.zeros(n - REPEAT_WINDOW + 1, dtype=np.uint64)
    with np.errstate(over="ignore"):
        for j in range(REPEAT_WINDOW):
            win = (win ^ rows[j : j + win.size]) * mult
    _, first, inverse = np.unique(win, return_index=True, return_inverse=True)
    origin = first[inverse]
    cand = np.flatnonzero(origin < np.arange(win.size))
    sub = data[:, varying]
    hits = [
        (int(i), int(origin[i]))
        for i in cand
        if np.array_equal(sub[i : i + REPEAT_WINDOW], sub[origin[i] : origin[i] + REPEAT_WINDOW])
    ]
    blocks: list[tuple[int, int, int]] = []
    for i, o in hits:
        if blocks and blocks[-1][2] == i - o and i <= blocks[-1][0] + blocks[-1][1]:
            s, _, lag = blocks[-1]
            blocks[-1] = (s, i + REPEAT_WINDOW - s, lag)
        else:
            blocks.append((i, REPEAT_WINDOW, i - o))
    return [] if len(blocks) > MAX_REPEATS else blocks


def dropout_problems(
    data: np.ndarray, columns: Sequence[str], units: Sequence[str], t: np.ndarray
) -> tuple[np.ndarray, list[str]]:
    """Samples not delivered: held runs per channel and repeated blocks, as a mask and problem texts.

    Parameters
    ----------
    data : numpy.ndarray
        ``(n_samples, n_channels)`` SI samples (NaN allowed: never part of a run).
    columns, units : sequence of str
        Each channel's column name and SI unit (named in the texts).
    t : numpy.ndarray
        Time of each sample, s.

    Returns
    -------
    (numpy.ndarray, list of str)
        ``bad`` (n_samples,) bool: the samples to drop like a NaN run; one text per finding, naming the
        column (or every column) and the time.
    """
    n = data.shape[0]
    bad = np.zeros(n, dtype=bool)
    problems: list[str] = []
    for k, col in enumerate(columns):
        for s, length, value in held_runs(data[:, k]):
            bad[s : s + length] = True
            what = "reads 0" if value == 0.0 else f"holds the value {value:.6g} {units[k]}"
            problems.append(
                f"column {col!r}: {what} for {length} samples ({length * _step(t):.4g} s) "
                f"from t = {t[s]:.6g} s (a data-acquisition dropout: the channel cannot repeat a value "
                "by chance that often)"
            )
    finite = np.all(np.isfinite(data), axis=1)
    rows = np.flatnonzero(finite)
    for s, length, lag in repeated_blocks(data[finite]):
        i0, i1 = rows[s], rows[s + length - 1]
        bad[i0 : i1 + 1] = True
        problems.append(
            f"rows at t = {t[i0]:.6g} .. {t[i1]:.6g} s repeat, on every column, the {length} samples "
            f"{lag} rows earlier exactly (a buffer delivered twice? the samples after it are late by "
            f"{length} samples)"
        )
    return bad, problems


def _step(t: np.ndarray) -> float:
    return float(np.median(np.diff(t))) if t.size > 1 else 0.0
