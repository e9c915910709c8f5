"""Study: candidates from the data's local misfits, tested by the local nested F test (issue 18).

Build point 3 of issue 18: "a local misfit around a peak is treated as a missing mode". The
completeness test (``noise.segment_misfit``) tests segments of up to ~400 lines; a narrow missing
mode's excess is diluted over them (ufffiles_frf band B, 522-719.5 Hz: ratio 1.59 < 2, while
band A adds 704.9 Hz). This study scans each band's final model with windows of the completeness
test's own minimum segment (``CompletenessCriteria.min_segment_lines`` lines, half-overlapping):

- a window fails when its chi-square test against the band's noise variance fails at
  ``CompletenessCriteria.p_value`` Bonferroni over the windows x (channels + 1) and its ratio is
  at least ``misfit_ratio`` (the segment test's own two criteria on the scan's windows);
- per run of failing windows, the candidate is the centre of the worst window, with the damping
  whose ``local_hbw`` half-power half-bandwidths span the window (the narrowest mode the window
  resolves: its own lines are then the window that failed); a place within ``MLCriteria.move_hbw``
  half-power half-bandwidths (at least two lines) of a model mode is that mode's (as
  ``identification._ml_features``);
- each candidate is tested by the existing local nested F test (``identification._nested_test``,
  ``local_p`` Bonferroni over the candidates on the same lines) and the peak-line jackknife
  (``_peak_line_out``); the study reports where the ML put it.

It also lists the data's own peaks (``peaks``: local maxima of the summed magnitude whose
prominence stands out of the noise, more than a half-power bandwidth from every model mode): the
candidates a peak detector would give, and whether it sees 657.5 and 704.9 Hz on ufffiles_frf.

Run: ``PYTHONPATH=. python benchmarks/study_peak_candidates.py``.
"""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from study_real_bands import CASES  # noqa: E402

SHARED = Path(os.environ.get("EMA_RIG_SHARED", "/work/shared"))


def scan(dd, x, cc, w):  # type: ignore[no-untyped-def]
    """Failing ``w``-line windows of the band's final model: list of (centre Hz, ratio, zeta0)."""
    from ema_rig.identification.identification import _FORM_POWER
    from ema_rig.identification.noise import segment_misfit

    f = dd.freq
    n_chan = dd.n_out * dd.n_in
    y = dd.frf.reshape(n_chan, -1)
    var = x.residual_test.variance
    lam = np.asarray(x.modes.poles)
    starts = list(range(0, f.size - w + 1, w // 2))
    alpha = cc.p_value / max(len(starts) * (n_chan + 1), 1)
    rows = []
    for i0 in starts:
        sl = slice(i0, i0 + w)
        t = segment_misfit(f[sl], y[:, sl], lam, power=_FORM_POWER[dd.frf_form], variance=var[:, sl],
                           edges=[0, w], criteria=cc)
        fail = bool(t.p_value[0] < alpha and max(t.ratio[0], t.worst_ratio[0]) >= cc.misfit_ratio)
        rows.append((i0, fail, float(t.ratio[0])))
    df = float(np.median(np.diff(f)))
    fn_m = np.abs(lam) / (2 * np.pi)
    near = 0.1 * np.maximum(2 * (-lam.real) / (2 * np.pi), df)  # identification._complete's duplicate distance
    out = []
    k = 0
    while k < len(rows):
        if not rows[k][1]:
            k += 1
            continue
        j = k
        while j + 1 < len(rows) and rows[j + 1][1]:
            j += 1
        i0, _, r = max(rows[k: j + 1], key=lambda q: q[2])
        fc = float(f[i0 + w // 2])
        zeta0 = 0.5 * w * df / (cc.local_hbw * fc)
        if not np.any(np.abs(fn_m - fc) <= near):
            out.append((fc, r, zeta0))
        k = j + 1
    return out, sum(1 for q in rows if q[1]), len(rows)


def peaks(dd, x, cc, tag, show=()):  # type: ignore[no-untyped-def]
    """The data's own peaks: local maxima of the summed magnitude that stand out of the noise.

    A local maximum's prominence (its drop to the higher of the two minima before a higher point
    on either side) against the noise sd of the summed magnitude, ``sqrt(sum_c var_c / 2)`` (a
    complex error of variance ``v`` gives ``|H|`` a variance ``v / 2`` where ``|H| >> sd``): it stands
    out when above the normal quantile at ``CompletenessCriteria.p_value`` Bonferroni over the
    maxima. A peak is a candidate when no model mode lies within one half-power bandwidth
    (2 half-power half-bandwidths, ``ResultCriteria.edge_hbw``). ``show``: frequencies [Hz] whose
    nearest local maximum is described whatever it scores. Also the Kennedy-Pancu sweep rate
    ``sum_c |H(k+1) - H(k)|`` (the largest where the Nyquist circle turns fastest) there.
    """
    from scipy.stats import norm

    f = dd.freq
    h = dd.frf.reshape(-1, f.size)
    var = x.residual_test.variance
    mag = np.sum(np.abs(h), axis=0)
    sd = np.sqrt(np.sum(np.where(np.isfinite(var), var, 0.0), axis=0) / 2)
    k = np.flatnonzero((mag[1:-1] > mag[:-2]) & (mag[1:-1] >= mag[2:])) + 1
    z_need = float(norm.isf(cc.p_value / max(k.size, 1)))
    lam = np.asarray(x.modes.poles)
    fn, hb = np.abs(lam) / (2 * np.pi), np.maximum(-lam.real / (2 * np.pi), 1e-12)
    rows = []
    for j in k:
        a = j
        while a > 0 and mag[a - 1] <= mag[j]:
            a -= 1
        b = j
        while b < mag.size - 1 and mag[b + 1] <= mag[j]:
            b += 1
        z = (mag[j] - max(mag[a: j + 1].min(), mag[j: b + 1].min())) / sd[j] if sd[j] > 0 else np.inf
        i = int(np.argmin(np.abs(fn - f[j]))) if fn.size else -1
        dist = abs(fn[i] - f[j]) / hb[i] if i >= 0 else np.inf
        rows.append((float(f[j]), float(z), float(fn[i]) if i >= 0 else np.nan, float(dist)))
    cand = [r for r in rows if r[1] >= z_need and r[3] > 2]
    print(f"  band {tag}: {k.size} local maxima of the summed magnitude, {sum(r[1] >= z_need for r in rows)} stand out "
          f"(prominence >= {z_need:.2f} noise sd), {len(cand)} of them more than a half-power bandwidth from every "
          f"model mode: " + ", ".join(f"{r[0]:.4g} Hz ({r[1]:.3g} sd, {r[3]:.3g} hbw from {r[2]:.5g})" for r in cand))
    sweep = np.sum(np.abs(np.diff(h, axis=1)), axis=0)
    fm = 0.5 * (f[1:] + f[:-1])
    ks = np.flatnonzero((sweep[1:-1] > sweep[:-2]) & (sweep[1:-1] >= sweep[2:])) + 1
    for fc in show:
        if not (f[0] < fc < f[-1]) or not rows:
            continue
        r = min(rows, key=lambda q: abs(q[0] - fc))
        js = ks[int(np.argmin(np.abs(fm[ks] - fc)))] if ks.size else None
        sw = "" if js is None else (f"; nearest sweep-rate maximum {fm[js]:.2f} Hz, "
                                    f"{abs(fn - fm[js]).min() / hb[int(np.argmin(abs(fn - fm[js])))]:.3g} hbw from the "
                                    f"nearest model mode")
        print(f"    near {fc:g} Hz: the nearest magnitude maximum is {r[0]:.2f} Hz, prominence {r[1]:.3g} noise sd "
              f"(needs {z_need:.2f}), {r[3]:.3g} half-power half-bandwidths from the model mode at {r[2]:.5g} Hz{sw}")


def main() -> None:
    from ema_rig.identification import identification as idm
    from ema_rig.identification import identify
    from ema_rig.identification.criteria import COMPLETENESS_CRITERIA as cc
    from ema_rig.io.uff import read_uff58

    widths = (cc.min_segment_lines, 2 * cc.min_segment_lines)
    tally = {w: [0, 0] for w in widths}  # supported candidates, of them in one band only
    for rel, band_a, band_b in CASES:
        d = read_uff58(SHARED / rel)
        if band_a is None:
            lo, hi = float(d.freq[0]), float(d.freq[-1])
            band_a, band_b = (lo, hi), (lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo))
        idents = {}
        for tag, b in (("A", band_a), ("B", band_b)):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                x = identify(d, band=b)
            b0, b1 = x.band
            sel = (d.freq >= b0) & (d.freq <= b1)
            idents[tag] = (x, d.replace(freq=d.freq[sel], frf=d.frf[:, :, sel],
                                        coherence=None if d.coherence is None else d.coherence[:, :, sel]))
        print(f"{rel}: the data's peaks")
        for tag, (x, dd) in idents.items():
            peaks(dd, x, cc, tag, (657.5, 704.9) if "ufffiles" in rel else ())
        for w in widths:
            found = {}
            for tag, (x, dd) in idents.items():
                cands, n_fail, n_win = scan(dd, x, cc, w)
                print(f"{rel} band {tag} {x.band[0]:.4g}-{x.band[1]:.4g} Hz, {w}-line windows: {x.natural_freq.size} "
                      f"modes; {n_fail} of {n_win} windows fail; {len(cands)} candidate(s) away from the model's modes")
                lam = list(np.asarray(x.modes.poles))
                looks = [c[0] for c in cands]
                acc = []
                for fc, r, z0 in cands:
                    wn = 2 * np.pi * fc
                    p = complex(-z0 * wn, wn * np.sqrt(1 - z0**2))
                    half = max(cc.local_hbw * z0 * fc, 0.5 * cc.min_segment_lines * float(np.median(np.diff(dd.freq))))
                    sl = (dd.freq >= fc - half) & (dd.freq <= fc + half)
                    res = idm._nested_test(dd, lam, p, sl, x.residual_test.variance, cc, looks)
                    if res is None:
                        print(f"    {fc:9.5g} Hz (window ratio {r:.3g}): the fit failed")
                        continue
                    ok = res[0] >= res[1]
                    extra = ""
                    if ok:
                        refit = idm._refit_on(dd, np.asarray([*lam, p]), sl)
                        if refit is not None:
                            # the ML re-estimates every pole on the lines: report the one set the null lacks
                            f0 = np.abs(np.asarray(lam)) / (2 * np.pi)
                            f1 = np.abs(refit) / (2 * np.pi)
                            on = (f1 >= dd.freq[sl][0]) & (f1 <= dd.freq[sl][-1])
                            new_k = max(np.flatnonzero(on), key=lambda q: float(np.min(np.abs(f0 - f1[q]))))
                            fe = float(f1[new_k])
                            extra = (f"; ML: {', '.join(f'{a:.5g}' for a in np.sort(f1[on]))} Hz on its lines (null: "
                                     f"{', '.join(f'{a:.5g}' for a in np.sort(f0[(f0 >= dd.freq[sl][0]) & (f0 <= dd.freq[sl][-1])]))}), "
                                     f"the new one {fe:.5g} Hz, zeta {100 * -refit[new_k].real / abs(refit[new_k]):.3g} %")
                            acc.append(fe)
                    print(f"    {fc:9.5g} Hz (window ratio {r:.3g}): F = {res[0]:.4g} vs {res[1]:.3g} with {res[2]:.0f}, "
                          f"{res[3]:.0f} dof -> {'SUPPORTED' if ok else 'not'}{extra}")
                found[tag] = (x, acc)
            (xa, fa), (xb, fb) = found["A"], found["B"]
            lo, hi = max(xa.band[0], xb.band[0]), min(xa.band[1], xb.band[1])
            for tag, mine, other in (("A", fa, found["B"]), ("B", fb, found["A"])):
                oth = np.concatenate([other[0].natural_freq, np.asarray(other[1])])
                for fe in mine:
                    tally[w][0] += 1
                    if lo < fe < hi and not np.any(np.abs(oth - fe) <= 0.01 * fe):
                        tally[w][1] += 1
                        print(f"    supported candidate {fe:.5g} Hz of band {tag}: in neither the other band's modes nor "
                              f"its supported candidates")
    for w, (n, one) in tally.items():
        print(f"{w}-line windows: {n} supported candidates over the 10 identifications, {one} of them in one band only")


if __name__ == "__main__":
    main()
