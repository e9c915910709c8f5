"""Study: is a mode that a Hann window's leakage splits into two poles reported as one? (x_split13)

The r13 Hann families of ``study_unseen_truths.py`` (its independent truth generator; the lines are
the expected H1 of a Hann-windowed random test, 2-4, 3-5 and 5-10 lines across the housing mode's
half-power band). Per truth: the reference housing mode from ``ema-rig modes`` on the same truth's
exact FRF at an eighth of the line spacing (no window), the modes ``ema-rig modes`` reports within
three lines of it on the windowed lines (f and zeta against the reference), and ``ema-rig stiffness``
(k_TB error, sigma, z). The CLI runs from ``TREE`` (a checkout; default this one) at its defaults.

Run: ``python benchmarks/study_leakage_split.py [TREE] [--seeds 8]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import study_unseen_truths as su  # noqa: E402

FAMILIES = tuple(f"r13 Hann-windowed random test, {n} lines across the half-power band (leakage)"
                 for n in ("2-4", "3-5", "5-10"))


def _files(tmp: Path, t: su.Truth, name: str) -> tuple[str, str]:
    rig = tmp / f"{name}.toml"
    rig.write_text(t.rig_text(), encoding="utf-8")
    uff = tmp / f"{name}.uff"
    su.write_uff(uff, t.freq, t.frf(t.freq), t.coherence(t.freq), t.n_avg if t.shaker_mass > 0 else 0)
    return str(uff), str(rig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("tree", nargs="?", default=str(su.TREE[0]))
    ap.add_argument("--seeds", type=int, default=8)
    args = ap.parse_args()
    su.TREE[0] = Path(args.tree)
    fam = su.families()
    print(f"ema_rig tree: {args.tree}; seeds 60..{59 + args.seeds}")
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for name in FAMILIES:
            for s in range(60, 60 + args.seeds):
                t, _ = fam[name](s)
                ref = dataclasses.replace(t, hann=False, df=t.df / 8)
                _, rm, _ = su.cli("modes", *_files(tmp, ref, f"r{s}")[:1], "--rig", str(tmp / f"r{s}.toml"))
                md = rm["modes"] if rm else []  # type: ignore[index]
                ih = int(np.argmin([m["modal_mass"].get("11+Y", np.inf) for m in md]))  # the housing mode
                f0, z0 = md[ih]["natural_freq"], md[ih]["damping_ratio"]
                uff, rig = _files(tmp, t, f"h{s}")
                _, hm, _ = su.cli("modes", uff, "--rig", rig)
                got = hm["modes"] if hm else []  # type: ignore[index]
                near = [(m["natural_freq"], m["damping_ratio"]) for m in got if abs(m["natural_freq"] - f0) < 3 * t.df]
                row = su.run(tmp, f"s{s}", name, t)
                print(f"{name.split(', ')[1].split(' across')[0]} s{s} df {t.df:.3f} Hz | ref {f0:.2f} Hz zeta "
                      f"{100 * z0:.3f}% ({len(md)} modes) | windowed: {len(got)} modes; at the housing mode "
                      + ", ".join(f"{a:.2f} Hz ({100 * (a / f0 - 1):+.2f}%) zeta {100 * b:.3f}% ({100 * (b / z0 - 1):+.0f}%)"
                                  for a, b in near)
                      + f" | k_TB err {100 * (row.k / t.k_TB - 1):+.2f}% sigma {100 * row.sigma / row.k:.2f}% "
                      f"z {(row.k - t.k_TB) / row.sigma:+.2f}", flush=True)


if __name__ == "__main__":
    main()
