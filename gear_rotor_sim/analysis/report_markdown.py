"""Markdown building blocks of docs/REPRODUCTION.md (table rows, window lists, figures with notes)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


def md_row(*cells: Any) -> str:
    """One markdown table row; floats with ``:g``."""
    return "| " + " | ".join(f"{c:g}" if isinstance(c, float) else str(c) for c in cells) + " |"


def fmt_windows(ws: list[tuple[float, float]]) -> str:
    """Speed windows as ``lo-hi`` in rpm, comma-separated (``none`` for no window)."""
    return ", ".join(f"{a:.0f}-{b:.0f}" for a, b in ws) if ws else "none"


def listed(items: list[str], none: str, sep: str = ", ") -> str:
    """``items`` joined by ``sep``, or ``none`` when there is no item."""
    return sep.join(items) if items else none


def figure_and_notes(
    add: Callable[[str], None], alt: str, png: str, notes: list[str], values: dict[str, Any] | None
) -> None:
    """A figure of docs/figures and the explanation under it (``values`` fills its placeholders)."""
    add("")
    add(f"![{alt}](figures/{png})")
    add("")
    for extra in notes:
        add(extra.format(**values) if values is not None else extra)
    add("")
