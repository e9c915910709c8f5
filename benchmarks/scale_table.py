"""Markdown table of two ``bench_scale.py --json`` runs side by side (before -> after).

For every grid row: the data size, then for ``identify``, ``plscf`` and ``lsfd`` the first-call
time in a fresh process and the peak memory / data (warm peak when the row had a warm round, else
the first call's, marked ``*``), and the modes found within 0.1 % (with the order the adaptive
identification reached, when the run recorded it).

Run from the repository root::

    python benchmarks/scale_table.py BEFORE.json AFTER.json [AFTER_RERUN.json ...]

Several ``after`` files are merged row by row, a later file's row replacing an earlier one's
(a re-run of some rows with ``bench_scale.py --only``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

STEPS = ("identify", "plscf", "lsfd")


def _key(rec: dict[str, Any]) -> tuple[int, int, int, int]:
    r = rec["row"]
    return (r["n_out"], r["n_in"], r["n_lines"], r["order"])


def _cell(rec: dict[str, Any] | None, step: str) -> tuple[str, str]:
    """(first-call seconds, peak / data) of one step, or dashes."""
    if rec is None or "skipped" in rec:
        return "–", "–"
    st = rec["steps"].get(step) or {}
    if st.get("first") is None:
        return "error", "–"
    star = "*" if st.get("peak_source") == "first" else ""
    return f"{st['first']:.2f}", f"{st['peak'] / rec['data_bytes']:.2f}{star}"


def _modes(rec: dict[str, Any] | None) -> str:
    if rec is None or "skipped" in rec:
        return "–" if rec is None else f"skipped ({rec['skipped']})"
    out = f"{rec.get('found', '–')}/6"
    if rec.get("order_reached") is not None:
        out += f" @{rec['order_reached']}"
    return out


def table(before: list[dict[str, Any]], after: list[dict[str, Any]]) -> str:
    """The markdown table (one line per grid row, ``before → after`` in every cell)."""
    b = {_key(r): r for r in before}
    a = {_key(r): r for r in after}
    keys = sorted(set(b) | set(a), key=lambda k: (k[0] * k[1] * k[2], k[3], k[1]))
    head = ("| outputs × refs × lines, order | data MB | "
            + " | ".join(f"{s} first s | {s} peak/data" for s in STEPS) + " | modes |")
    lines = [head, "|" + "---|" * (2 + 2 * len(STEPS) + 1)]
    for k in keys:
        rb, ra = b.get(k), a.get(k)
        size = (ra or rb or {}).get("data_bytes", k[0] * k[1] * k[2] * 16) / 1e6
        cells = []
        for s in STEPS:
            (tb, pb), (ta, pa) = _cell(rb, s), _cell(ra, s)
            cells += [f"{tb} → {ta}", f"{pb} → {pa}"]
        lines.append(f"| {k[0]} × {k[1]} × {k[2]}, P={k[3]} | {size:.1f} | " + " | ".join(cells)
                     + f" | {_modes(rb)} → {_modes(ra)} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path, nargs="+")
    args = ap.parse_args(argv)
    merged: dict[tuple[int, int, int, int], dict[str, Any]] = {}
    for path in args.after:
        merged.update({_key(r): r for r in json.loads(path.read_text())})
    print(table(json.loads(args.before.read_text()), list(merged.values())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
