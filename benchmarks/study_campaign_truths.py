"""Study: k_TB and c_TB through ``ema-rig campaign`` on a bearing whose stiffness and damping move with load.

A test engineer's campaign, not one file: per seed one bearing measured at eight radial loads
(log-spaced 100-3000 N) with a calibration disk, through the campaign command a user runs
(``python -m ema_rig.cli campaign campaign.toml -o OUT``, the rig file and the disk file given in
the campaign file). The truths come from ``benchmarks/study_unseen_truths.py``'s generator (a
lumped M, K, C of the rig solved directly; it imports nothing from ema_rig):

* k_TB ~ F^(1/3) (Hertz point contact) with a per-seed stiffness at 1000 N in 6e7-1.5e8 N/m, so
  that within one campaign k_TB spans x3.2 and the housing mode moves about 25 %;
* the bearing's dashpot falling with load (zeta of the housing on k_TB+MS from 8 % at 100 N to
  1.5 % at 3000 N, log-linear): strong load dependence of the damping too;
* the disk: k_TB infinite, k_MS per seed 0.85-1.15 x Table 1 (the campaign's calibration).

Per row: k_TB true vs the campaign table's, its sigma, z, warnings; c_TB printed vs the truth's
dashpot (a "measured" c_TB within 2 sigma, an "upper bound" holding to its 2 sigma).

Usage::

    nice -n 19 python benchmarks/study_campaign_truths.py [--seeds N] [--seed-offset S] [--tree TREE] [-o FILE]
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import study_unseen_truths as gen  # noqa: E402  (the independent truth generator)

LOADS = tuple(float(x) for x in np.geomspace(100.0, 3000.0, 8))  # N
EXTRA: list[float] = []  # --extra-load: measurements at loads outside 100-3000 N (r_truth13)


def truths(seed: int) -> tuple[list[gen.Truth], gen.Truth]:
    """The campaign's eight truths (one per load) and its disk truth."""
    r = np.random.default_rng(36_000 + seed)
    k_1000 = float(10 ** r.uniform(math.log10(6e7), math.log10(1.5e8)))
    k_ms = gen.TABLE1["k_MS"] * float(r.uniform(0.85, 1.15))
    rows = []
    for i, f in enumerate(_loads()):
        fz = min(max(f, 100.0), 3000.0)  # outside 100-3000 N the damping stays at its end's value
        zeta = math.exp(math.log(0.08) + (math.log(0.015) - math.log(0.08)) * math.log(fz / 100.0) / math.log(30.0))
        rows.append(gen.Truth(k_TB=k_1000 * (f / 1000.0) ** (1.0 / 3.0), k_MS=k_ms, zeta_H=zeta, seed=100 * seed + i))
    return rows, gen.Truth(k_TB=math.inf, k_MS=k_ms, seed=100 * seed + 99)


def _loads() -> tuple[float, ...]:
    """The campaign's loads [N]: the eight of :data:`LOADS` and any ``--extra-load``."""
    return LOADS + tuple(EXTRA)


def campaign_text(ids: list[str]) -> str:
    text = 'rig = "rig.toml"\ncalibration = "disk.uff"\ntitle = "load-dependent bearing"\n\n[bearings.b]\nlabel = "b"\n'
    for i, (mid, f) in enumerate(zip(ids, _loads(), strict=True)):
        text += (f'\n[[measurement]]\nid = "{mid}"\nfile = "{mid}.uff"\nbearing = "b"\nradial_load = {f!r}\n'
                 f"speed = 0.0\nshaft_position = 0.0\nrepeat = {i + 1}\n")
    return text


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--seed-offset", type=int, default=36)
    ap.add_argument("--tree", type=Path, default=gen.ROOT)
    ap.add_argument("-o", "--out", type=Path, default=None)
    ap.add_argument("--extra-load", type=float, action="append", default=[],
                    help="a further measurement at this load [N] (repeatable; k_TB ~ F^1/3 extrapolated)")
    a = ap.parse_args(argv)
    EXTRA[:] = a.extra_load
    tree = a.tree.resolve()
    lines = ["| seed | load N | k_TB true | k_TB table | err % | sigma % | z | c_TB table vs true | warnings |",
             "|---|---|---|---|---|---|---|---|---|"]
    zs: list[float] = []
    silent = broken = warned = failed = 0
    for seed in range(a.seed_offset, a.seed_offset + a.seeds):
        rows, disk = truths(seed)
        with tempfile.TemporaryDirectory() as tmpd:
            tmp = Path(tmpd)
            ids = [f"s{seed}_{int(f)}N" for f in _loads()]
            (tmp / "rig.toml").write_text(rows[0].rig_text(), encoding="utf-8")
            gen.write_uff(tmp / "disk.uff", gen.FREQ, disk.frf(gen.FREQ))
            for mid, t in zip(ids, rows, strict=True):
                gen.write_uff(tmp / f"{mid}.uff", gen.FREQ, t.frf(gen.FREQ))
            (tmp / "campaign.toml").write_text(campaign_text(ids), encoding="utf-8")
            env = dict(os.environ, PYTHONPATH=str(tree))
            r = subprocess.run([sys.executable, "-m", "ema_rig.cli", "campaign", str(tmp / "campaign.toml"), "-o",
                                str(tmp / "out"), "--jobs", "1"], capture_output=True, text=True, env=env, cwd=tree,
                               check=False)
            table = tmp / "out" / "campaign.csv"
            if not table.exists():
                lines.append(f"| {seed} | - | - | - | - | - | - | - | campaign failed: {r.stderr.strip()[-300:]} |")
                failed += len(rows)
                continue
            got = {row["id"]: row for row in csv.DictReader(table.open(encoding="utf-8"))}
        for mid, f, t in zip(ids, _loads(), rows, strict=True):
            row = got.get(mid)
            if row is None or row["status"] != "ok" or not row["k_TB [N/m]"]:
                lines.append(f"| {seed} | {f:.0f} | {t.k_TB:.4g} | - | - | - | - | - | "
                             f"refused: {(row or {}).get('error', 'missing')[:200]} |")
                failed += 1
                continue
            k, s = float(row["k_TB [N/m]"]), float(row["k_TB_std [N/m]"])
            z = (k - t.k_TB) / s
            w = row["warnings"].strip()
            c_txt = ""
            if row["c_TB [N s/m]"]:
                c, cs, kind = float(row["c_TB [N s/m]"]), float(row["c_TB_std [N s/m]"]), row["c_TB_kind"]
                if kind == "measured":
                    ok = abs(c - t.c_TB) <= 2 * cs
                    c_txt = f"{c:.4g} +- {cs:.3g} vs {t.c_TB:.4g} (measured, z {(c - t.c_TB) / cs:+.2f})"
                else:
                    ok = t.c_TB <= c + 2 * cs
                    c_txt = f"<= {c:.4g} vs {t.c_TB:.4g} (bound {'holds' if ok else 'BROKEN'}, x{c / t.c_TB:.2f})"
                broken += not ok
            if w:
                warned += 1
            elif abs(z) > 2:
                silent += 1
            zs.append(abs(z))
            lines.append(f"| {seed} | {f:.0f} | {t.k_TB:.4g} | {k:.4g} | {100 * (k / t.k_TB - 1):+.2f} | "
                         f"{100 * s / k:.2f} | {z:+.2f} | {c_txt} | {w[:300].replace('|', '/')} |")
            print(lines[-1], flush=True)
    head = (f"ema_rig tree: {tree}; seeds {a.seed_offset}..{a.seed_offset + a.seeds - 1}, loads "
            f"{', '.join(f'{f:.0f}' for f in _loads())} N; python -m ema_rig.cli campaign at its defaults\n"
            f"rows {len(zs) + failed}: refused/failed {failed}, warned {warned}, SILENT (no warning, |z| > 2) {silent}, "
            f"max |z| {max(zs) if zs else math.nan:.2f}, c_TB wrong (bound broken or measured outside 2 sigma) {broken}\n\n")
    text = head + "\n".join(lines) + "\n"
    print(head)
    if a.out is not None:
        a.out.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
