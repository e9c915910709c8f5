"""Coverage of the ML refinement's confidence intervals, and damping bias, on seeded lumped systems.

The data sets come from ``tests/_mck_truth.py`` (numpy/scipy only, nothing from ema_rig): a
six-coordinate M, C, K system with five modes in the band 60-520 Hz, two of them 1 % apart,
a sixth far above the band; proportional or non-proportional damping (two local dashpots, complex
shapes); one or two references; complex Gaussian noise ``sqrt(p^2 |H|^2 + floor^2)``; the
matching coherence for 30 averages where a configuration uses it. The truth is the state-space
eigenvalues of (M, C, K).

Every data set goes through ``identify`` (PolyMAX, automatic selection, LSFD) and then ``refine``.
For every (configuration, mode) it prints:

* coverage: the fraction of seeds whose ``+-2 sigma`` interval holds the true frequency / damping;
* ``sigma/scatter``: the median reported sigma divided by the standard deviation of the estimates
  over the seeds (1 is ideal; an interval that covers because it is huge shows up here);
* the same two numbers for the PolyMAX cluster spread, for comparison;
* the damping bias of PolyMAX and of the refinement (mean of (zeta - zeta_true) / zeta_true).

With ``--real`` it prints instead, for the real measurements in ``$EMA_RIG_SHARED/real-frf``
(dam0.unv; vt_case1_full.uff without and with its coherence record), each mode's refined
frequency in two reasonable bands, the change and the change in units of the larger sigma.

Run: ``python benchmarks/coverage_refine.py [--seeds N] [--real]`` (default 20 seeds x 8
configurations = 160 data sets, a minute or two).
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

import _mck_truth as mt  # noqa: E402


@dataclass(frozen=True)
class Config:
    name: str
    noise: float
    floor_rel: float = 0.0
    proportional: bool = True
    n_in: int = 1
    coherence: str = "none"  # "none", "with-averages", "shape-only"


CONFIGS = (
    Config("prop 1ref 1%", 0.01),
    Config("prop 1ref 5% coh", 0.05, coherence="with-averages"),
    Config("prop 1ref 10%", 0.10),
    Config("prop 2ref 5% +floor", 0.05, floor_rel=0.005, n_in=2),
    Config("nonprop 1ref 3% coh", 0.03, proportional=False, coherence="with-averages"),
    Config("nonprop 2ref 5%", 0.05, proportional=False, n_in=2),
    Config("nonprop 2ref 10% +floor coh", 0.10, floor_rel=0.01, proportional=False, n_in=2, coherence="with-averages"),
    Config("nonprop 1ref 5% coh-shape", 0.05, proportional=False, coherence="shape-only"),
)


@dataclass
class Estimate:
    found: bool
    f: float = np.nan
    z: float = np.nan
    f_std: float = np.nan
    z_std: float = np.nan
    f_pl: float = np.nan
    z_pl: float = np.nan
    f_std_pl: float = np.nan
    z_std_pl: float = np.nan
    converged: bool = False
    misfit: bool = False  # the refinement warned that the model does not fit to the noise level


def run_one(cfg: Config, seed: int, df: float = 0.5, outputs: tuple[int, ...] = (0, 1, 2, 3, 4, 5)):
    """Identify + refine one data set; per true mode an :class:`Estimate`, and the truth."""
    from ema_rig.frf import FRFData
    from ema_rig.identification import identify
    from ema_rig.identification.refine import refine

    t = mt.make(seed, noise=cfg.noise, floor_rel=cfg.floor_rel, proportional=cfg.proportional, n_in=cfg.n_in,
                df=df, outputs=outputs)
    data = FRFData(t.freq, t.frf, t.out_dofs, t.in_dofs)
    ident = identify(data)
    kw = {}
    if cfg.coherence != "none":
        kw["coherence"] = t.coherence
    if cfg.coherence == "with-averages":
        kw["n_averages"] = t.n_averages
    ref = refine(data, ident.modes, **kw)
    if not ref.converged or ref.warnings:
        print(f"  warned: {cfg.name} seed {seed}: converged={ref.converged} {ref.reason}; {'; '.join(ref.warnings)}")
    out = []
    for lam in t.poles:
        f0 = abs(lam) / (2 * np.pi)
        k = int(np.argmin(np.abs(ident.natural_freq - f0)))
        if abs(ident.natural_freq[k] - f0) > 0.004 * f0:
            out.append(Estimate(False))
            continue
        out.append(
            Estimate(
                True,
                f=float(ref.natural_freq[k]), z=float(ref.damping_ratio[k]),
                f_std=float(ref.natural_freq_std[k]), z_std=float(ref.damping_ratio_std[k]),
                f_pl=float(ident.natural_freq[k]), z_pl=float(ident.damping_ratio[k]),
                f_std_pl=float(ident.natural_freq_std[k]), z_std_pl=float(ident.damping_ratio_std[k]),
                converged=bool(ref.converged and np.isfinite(ref.natural_freq_std[k])),
                misfit=any("times the stated noise" in w or "kept at its PolyMAX" in w for w in ref.warnings),
            )
        )
    return out, t


@dataclass
class ModeStats:
    n: int
    missed: int
    fallback: int
    cover_f: float
    cover_z: float
    ratio_f: float
    ratio_z: float
    cover_f_pl: float
    cover_z_pl: float
    ratio_f_pl: float
    ratio_z_pl: float
    bias_z: float
    bias_z_pl: float
    bias_z_se: float
    bias_z_pl_se: float
    n_cov: int
    hits_f: int
    hits_z: int
    clean_f: float = np.nan
    clean_z: float = np.nan


def mode_stats(est: list[Estimate], f_true: float, z_true: float) -> ModeStats:
    ok = [e for e in est if e.found and e.converged]
    found = [e for e in est if e.found]

    def arr(name: str, rows: list[Estimate]) -> np.ndarray:
        return np.array([getattr(e, name) for e in rows], float)

    f, z, sf, sz = (arr(n, ok) for n in ("f", "z", "f_std", "z_std"))
    fp, zp, sfp, szp = (arr(n, found) for n in ("f_pl", "z_pl", "f_std_pl", "z_std_pl"))
    hit_f = np.abs(f - f_true) <= 2 * sf
    hit_z = np.abs(z - z_true) <= 2 * sz
    with np.errstate(invalid="ignore", divide="ignore"):
        return ModeStats(
            n=len(est), missed=len(est) - len(found), fallback=len(found) - len(ok),
            cover_f=float(np.mean(hit_f)) if ok else np.nan,
            cover_z=float(np.mean(hit_z)) if ok else np.nan,
            ratio_f=float(np.median(sf) / np.std(f, ddof=1)) if len(ok) > 2 else np.nan,
            ratio_z=float(np.median(sz) / np.std(z, ddof=1)) if len(ok) > 2 else np.nan,
            cover_f_pl=float(np.mean(np.abs(fp - f_true) <= 2 * sfp)) if found else np.nan,
            cover_z_pl=float(np.mean(np.abs(zp - z_true) <= 2 * szp)) if found else np.nan,
            ratio_f_pl=float(np.median(sfp) / np.std(fp, ddof=1)) if len(found) > 2 else np.nan,
            ratio_z_pl=float(np.median(szp) / np.std(zp, ddof=1)) if len(found) > 2 else np.nan,
            bias_z=float(np.mean(z - z_true) / z_true) if ok else np.nan,
            bias_z_pl=float(np.mean(zp - z_true) / z_true) if found else np.nan,
            bias_z_se=float(np.std(z, ddof=1) / np.sqrt(len(ok)) / z_true) if len(ok) > 2 else np.nan,
            bias_z_pl_se=float(np.std(zp, ddof=1) / np.sqrt(len(found)) / z_true) if len(found) > 2 else np.nan,
            n_cov=len(ok), hits_f=int(np.sum(hit_f)), hits_z=int(np.sum(hit_z)),
            clean_f=_ratio([e for e in ok if not e.misfit], "f"),
            clean_z=_ratio([e for e in ok if not e.misfit], "z"),
        )


def _ratio(rows: list[Estimate], q: str) -> float:
    """Median reported sigma / standard deviation of the estimates over the seeds."""
    if len(rows) < 3:
        return np.nan
    x = np.array([getattr(e, q) for e in rows])
    s = np.array([getattr(e, q + "_std") for e in rows])
    return float(np.median(s) / np.std(x, ddof=1))


def study(configs, seeds: list[int], **kw) -> list[tuple[Config, int, float, float, ModeStats]]:
    """Run every configuration on every seed (offset by 1000 x the configuration's index)."""
    rows = []
    for i, cfg in enumerate(configs):
        per_mode: list[list[Estimate]] | None = None
        truth = None
        for s in seeds:
            est, truth = run_one(cfg, 1000 * i + s, **kw)
            if per_mode is None:
                per_mode = [[] for _ in est]
            for k, e in enumerate(est):
                per_mode[k].append(e)
        assert per_mode is not None and truth is not None
        for k, est in enumerate(per_mode):
            rows.append((cfg, k, float(truth.natural_freq[k]), float(truth.damping_ratio[k]),
                         mode_stats(est, truth.natural_freq[k], truth.damping_ratio[k])))
    return rows


def real_table() -> None:
    """Refined frequencies of real measurements in two bands: the change against +-2 sigma."""
    import os
    import warnings

    from ema_rig.identification import identify
    from ema_rig.identification.refine import refine
    from ema_rig.io.uff import read_uff, read_uff58

    root = Path(os.environ.get("EMA_RIG_SHARED", Path(__file__).resolve().parents[2] / "shared")) / "real-frf"
    vt = root / "vt_case1_full.uff"
    coh = np.asarray(read_uff(vt).records[3].y, float)[None, None, :]
    cases = [
        ("dam0.unv", read_uff58(root / "dam0.unv"), [(1.5, 6.0), (2.0, 6.0)], {}),
        ("vt_case1 (noise estimated)", read_uff58(vt), [(150.0, 260.0), (180.0, 240.0)], {}),
        ("vt_case1 (coherence, n_avg unknown)", read_uff58(vt), [(150.0, 260.0), (180.0, 240.0)], {"coherence": coh}),
        ("vt_case1 (noise estimated)", read_uff58(vt), [(100.0, 300.0), (180.0, 240.0)], {}),
    ]
    print(f"{'file':36s} {'bands [Hz]':>22s} {'f_A [Hz]':>10s} {'sigma_A':>8s} {'f_B [Hz]':>10s} {'sigma_B':>8s} "
          f"{'|df|':>8s} {'|df|/max sigma':>14s} {'z_A':>8s} {'z_B':>8s} {'|dz|/max sigma':>14s}")
    for name, data, (ba, bb), kw in cases:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ra = refine(data, identify(data, band=ba).modes, **kw)
            rb = refine(data, identify(data, band=bb).modes, **kw)
        for k in range(ra.model.n_modes):
            j = int(np.argmin(np.abs(rb.natural_freq - ra.natural_freq[k])))
            fa, fb = ra.natural_freq[k], rb.natural_freq[j]
            if abs(fa - fb) > 0.01 * fa:
                continue  # no counterpart in the other band
            sa, sb = ra.natural_freq_std[k], rb.natural_freq_std[j]
            if np.isnan(sa) or np.isnan(sb):
                print(f"{name:36s} {str(ba) + ' ' + str(bb):>22s} {fa:10.4f} {'kept':>8s} {fb:10.4f} {'':>8s}  "
                      "(kept at its PolyMAX pole in one band)")
                continue
            za, zb = ra.damping_ratio[k], rb.damping_ratio[j]
            sza, szb = ra.damping_ratio_std[k], rb.damping_ratio_std[j]
            print(f"{name:36s} {str(ba) + ' ' + str(bb):>22s} {fa:10.4f} {sa:8.4f} {fb:10.4f} {sb:8.4f} "
                  f"{abs(fa - fb):8.4f} {abs(fa - fb) / max(sa, sb):14.2f} {za:8.5f} {zb:8.5f} "
                  f"{abs(za - zb) / max(sza, szb):14.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--real", action="store_true", help="the real-data band table instead of the study")
    args = ap.parse_args()
    if args.real:
        real_table()
        return
    seeds = list(range(args.seeds))
    t0 = time.perf_counter()
    rows = study(CONFIGS, seeds)
    dt = time.perf_counter() - t0
    print(f"{len(CONFIGS)} configurations x {len(seeds)} seeds = {len(CONFIGS) * len(seeds)} data sets, {dt:.0f} s\n")
    hdr = (f"{'configuration':30s} {'mode':>4s} {'f_true':>8s} {'z_true':>7s} {'miss':>4s} {'fb':>3s} "
           f"{'cov f':>6s} {'cov z':>6s} {'s/sc f':>6s} {'s/sc z':>6s} | {'PolyMAX: cov f':>14s} {'cov z':>6s} "
           f"{'s/sc f':>6s} {'s/sc z':>6s}")
    print(hdr)
    print("-" * len(hdr))
    n_pairs = hits_f = hits_z = 0
    n_pl = hits_f_pl = hits_z_pl = 0
    ratios = []
    clean = []
    for cfg, k, f0, z0, st in rows:
        print(f"{cfg.name:30s} {k + 1:4d} {f0:8.2f} {z0:7.4f} {st.missed:4d} {st.fallback:3d} "
              f"{st.cover_f:6.2f} {st.cover_z:6.2f} {st.ratio_f:6.2f} {st.ratio_z:6.2f} | "
              f"{st.cover_f_pl:14.2f} {st.cover_z_pl:6.2f} {st.ratio_f_pl:6.2f} {st.ratio_z_pl:6.2f}")
        n_pairs += st.n_cov
        hits_f += st.hits_f
        hits_z += st.hits_z
        n_found = st.n - st.missed
        n_pl += n_found
        hits_f_pl += round(st.cover_f_pl * n_found) if n_found else 0
        hits_z_pl += round(st.cover_z_pl * n_found) if n_found else 0
        ratios += [st.ratio_f, st.ratio_z]
        clean += [st.clean_f, st.clean_z]
    r = np.array(ratios)
    rc = np.array(clean)
    missed = sum(st.missed for *_, st in rows)
    fallback = sum(st.fallback for *_, st in rows)
    print(f"\nrefinement: {n_pairs} (mode, seed) pairs; +-2 sigma covers the true frequency in "
          f"{hits_f / n_pairs:.1%}, the true damping in {hits_z / n_pairs:.1%}")
    print(f"            median sigma / scatter over seeds: {np.nanmin(r):.2f} .. {np.nanmax(r):.2f} "
          f"(median {np.nanmedian(r):.2f}); within 2x for {np.mean((r >= 0.5) & (r <= 2.0)):.0%} of "
          "(configuration, mode, quantity)")
    print(f"            without the data sets whose refinement warned of a misfit (model error: a mode missed by "
          f"PolyMAX ...): {np.nanmin(rc):.2f} .. {np.nanmax(rc):.2f} (median {np.nanmedian(rc):.2f}); within 2x for "
          f"{np.mean((rc >= 0.5) & (rc <= 2.0)):.0%}")
    print(f"            {missed} true modes not found by PolyMAX, {fallback} (mode, seed) pairs not refined "
          "(fall-back or mode kept at its PolyMAX pole; column fb)")
    print(f"PolyMAX cluster spread: covers frequency in {hits_f_pl / n_pl:.1%}, damping in {hits_z_pl / n_pl:.1%}")

    print("\nDamping bias, mean (zeta - zeta_true) / zeta_true over seeds (+- standard error), in %:")
    print(f"{'configuration':30s} {'mode':>4s} {'PolyMAX':>16s} {'refined':>16s}")
    for cfg, k, _, _, st in rows:
        if cfg.name in ("prop 1ref 1%", "prop 1ref 5% coh", "prop 1ref 10%"):
            print(f"{cfg.name:30s} {k + 1:4d} {100 * st.bias_z_pl:+8.2f} +- {100 * st.bias_z_pl_se:4.2f} "
                  f"{100 * st.bias_z:+8.2f} +- {100 * st.bias_z_se:4.2f}")


if __name__ == "__main__":
    main()
