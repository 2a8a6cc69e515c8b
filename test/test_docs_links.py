"""Every relative link of README.md and docs/**/*.md resolves; no text cites a moved section by its old file.

A link ``[text](path#anchor)`` must name a file that exists (relative to the linking file) and, for a
Markdown target, an anchor that one of its headings makes (GitHub's rule: lower case, punctuation but
``-`` and ``_`` dropped, spaces to ``-``, a repeated heading gets ``-1``, ``-2``, ...). Links inside code
blocks and code spans are not links. Secs. 8.5 and later of the calibration log live in
docs/history/calibration_sessions.md (docs/calibration.md keeps Secs. 1-8.4, 9, 10 and an index), so a
"calibration.md Sec. 8.N" with N >= 5 anywhere in the repository's text names a section that is not there.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

HERE = Path(__file__).resolve()
ROOT = HERE.parent.parent
LINK = re.compile(r"\]\(([^)\s]+)\)")
# "calibration.md Sec. 8.N", "calibration.md`` Sec. 8.N", across a comment line break,
# "Sec. 8.N of calibration.md"
OLD_SECTION = re.compile(
    r"(?<![\w/])(?:docs/)?calibration\.md`{0,2},?\s*(?:#:?\s*)?(?:Secs?\.|Sections?)\s*(?:#:?\s*)?8\.(\d+)"
    r"|Secs?\.\s*8\.(\d+)\s+(?:#:?\s*)?of\s+(?:#:?\s*)?(?:docs/)?calibration\.md"
)


def slug(heading: str) -> str:
    """GitHub's anchor of a Markdown heading (without the duplicate suffix)."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _prose(text: str) -> str:
    text = re.sub(r"```.*?```", "", text, flags=re.S)
    return re.sub(r"`[^`\n]+`", "", text)


def anchors(path: Path) -> set[str]:
    """Every anchor the headings of a Markdown file make."""
    seen: dict[str, int] = {}
    out = set()
    for m in re.finditer(r"^#+ (.*)$", re.sub(r"```.*?```", "", path.read_text(), flags=re.S), re.M):
        s = slug(m.group(1))
        n = seen.get(s, 0)
        seen[s] = n + 1
        out.add(s if n == 0 else f"{s}-{n}")
    return out


def bad_links(files: list[Path]) -> list[str]:
    """``file -> target: why`` for every relative link that does not resolve."""
    cache: dict[Path, set[str]] = {}
    bad = []
    for f in files:
        for m in LINK.finditer(_prose(f.read_text())):
            target = m.group(1)
            if re.match(r"^[a-z]+:", target):  # http:, https:, mailto:
                continue
            path, _, anchor = target.partition("#")
            dest = (f.parent / path).resolve() if path else f
            if not dest.exists():
                bad.append(f"{f.name} -> {target}: no such file")
            elif anchor and dest.suffix == ".md":
                if dest not in cache:
                    cache[dest] = anchors(dest)
                if anchor not in cache[dest]:
                    bad.append(f"{f.name} -> {target}: no such heading")
    return bad


def _docs() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def test_the_check_finds_a_missing_file_and_a_missing_heading(tmp_path: Path) -> None:
    (tmp_path / "a.md").write_text(
        "# Title\n## 8.4 Results, now\n## Rows\n## Rows\n"
        "[ok](#title) [ok](#84-results-now) [ok](#rows-1) [ok](b.md#b-head) [ok](b.md)\n"
        "[bad](#rows-2) [bad](c.md) [bad](b.md#nope) `[not a link](x.md)`\n```\n[not a link](y.md)\n```\n"
    )
    (tmp_path / "b.md").write_text("# B head\n")
    assert bad_links([tmp_path / "a.md"]) == [
        "a.md -> #rows-2: no such heading",
        "a.md -> c.md: no such file",
        "a.md -> b.md#nope: no such heading",
    ]


def test_every_link_of_the_docs_resolves() -> None:
    files = _docs()
    assert len(files) > 15 and any(f.parent.name == "history" for f in files)
    bad = bad_links(files)
    assert not bad, "\n".join(bad)


def test_the_old_section_pattern_matches_the_forms_the_code_uses() -> None:
    hits = [
        "see docs/calibration.md Sec. 8.26.",
        "(``docs/calibration.md`` Sec. 8.9)",
        "#: docs/calibration.md\n    #: Sec. 8.21: with",
        "Sec. 8.41 of docs/calibration.md",
    ]
    misses = [
        "docs/calibration.md Sec. 8.4",
        "docs/history/calibration_sessions.md Sec. 8.26",
        "calibration_cwru.md",
    ]
    assert all(OLD_SECTION.search(s) for s in hits)
    assert not any(int(m.group(1) or m.group(2)) >= 5 for s in misses for m in OLD_SECTION.finditer(s))


def test_no_text_cites_a_moved_section_in_calibration_md() -> None:
    listed = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    old = []
    for name in listed:
        path = ROOT / name
        if path.suffix not in (".py", ".md", ".sh", ".yaml", ".txt") or not path.is_file() or path == HERE:
            continue
        for m in OLD_SECTION.finditer(path.read_text(errors="replace")):
            if int(m.group(1) or m.group(2)) >= 5:
                old.append(f"{name}: {m.group(0)!r}")
    assert not old, "Secs. 8.5+ are in docs/history/calibration_sessions.md:\n" + "\n".join(old)
