"""The same real measurement in two reasonable bands: a mode's change lies within its combined 2 sigma.

Issue 18 ("real data"): the default sigma held the noise part only. Where the ML background basis
of a segment is cut (the discrepancy level is decided with the band's noise estimate), two bands
over the same lines fit different local models, and the mode moves by more than that sigma. The
basis's model-form part is now in the sigma (``LocalML.basis_std``). Oracle: the other band (the
same lines, an independent order growth and selection), not the code's own sigma formula.
"""

from __future__ import annotations

import warnings

import numpy as np

from ema_rig.identification import identify


def _pair(path, band_a, band_b, f0):
    from ema_rig.io.uff import read_uff58

    d = read_uff58(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a, b = identify(d, band=band_a), identify(d, band=band_b)
    ka, kb = int(np.argmin(np.abs(a.natural_freq - f0))), int(np.argmin(np.abs(b.natural_freq - f0)))
    assert abs(a.natural_freq[ka] - f0) < 0.01 * f0 and abs(b.natural_freq[kb] - f0) < 0.01 * f0
    df = b.natural_freq[kb] - a.natural_freq[ka]
    sf = float(np.hypot(a.natural_freq_std[ka], b.natural_freq_std[kb]))
    dz = b.damping_ratio[kb] - a.damping_ratio[ka]
    sz = float(np.hypot(a.damping_ratio_std[ka], b.damping_ratio_std[kb]))
    return df, sf, dz, sz


def test_vt_case1_161_hz_same_in_two_bands(real_frf_dir):
    # measured: change -1.16 Hz; combined sigma 0.45 Hz before (2.6 sigma), 2.13 Hz with the basis's
    # model-form part (0.54 sigma); zeta -0.39 % within 2 x 0.39 %
    df, sf, dz, sz = _pair(real_frf_dir / "vt_case1_full.uff", (10.0, 300.0), (20.0, 400.0), 161.6)
    assert abs(df) <= 2 * sf and abs(dz) <= 2 * sz
    # no blanket: the combined sigma stays below the mode's half-power half-bandwidth (zeta 3 %:
    # 4.9 Hz), the distance over which the lines themselves locate the peak
    assert sf < 0.03 * 161.6


def test_ufffiles_frf_206_hz_in_both_bands(corpus_dir):
    # issue 18, "the same data in two overlapping bands give the same mode set on the overlap". In
    # 150-300 Hz the 206.8 Hz mode (a cluster stable at 20+ orders, a residual 10 x the noise around
    # it) was left out: its support was judged in the fit of the whole band, with a Bonferroni count
    # over all the band's candidates, and failed; in 120-260 Hz the same lines gave it. The missing
    # mode is now decided by a nested F test on the lines near it alone. Oracle: the other band (the
    # same lines, its own order growth and selection); measured 206.6 and 206.8 Hz (before: absent
    # from 150-300 Hz).
    from ema_rig.io.uff import read_uff58

    d = read_uff58(corpus_dir / "ufffiles_frf.unv")
    found = []
    for band in ((150.0, 300.0), (120.0, 260.0)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            x = identify(d, band=band)
        near = x.natural_freq[np.abs(x.natural_freq - 206.8) <= 0.01 * 206.8]
        assert near.size == 1, (band, x.natural_freq)
        found.append(float(near[0]))
    # the two estimates of the one mode agree within their combined 2 sigma-scale (its half-power
    # half-bandwidth, zeta 1 %: 2 Hz, bounds the distance over which the lines locate the peak)
    assert abs(found[0] - found[1]) < 0.01 * 206.8


def test_ufffiles_frf_one_line_is_no_missing_mode(corpus_dir, identified_at_defaults):
    # issue 18, "no mode that only one band supports": over the whole file (0-799.5 Hz) a 6-pole
    # cluster at 94.82 Hz, beside the 96.1 Hz mode (zeta 1.3 %, half-power half-bandwidth 1.3 Hz),
    # was added as a missing mode (local F = 12.6 >= 6.01 with 4, 32 dof) and reported at 94.99 Hz,
    # zeta 0.19 %: a half-power band of 0.36 Hz at 0.5 Hz lines. 79.95-719.55 Hz never had it. The
    # Nyquist plot of 92-98.5 Hz is one circle; the extra pole zeroes the 95.0 Hz line alone
    # (without that line F = 1.5 < 6.1): a distorted peak, not a mode. Oracle: the data's own lines
    # (the other band, and the test without the one line), not the ML estimate.
    x = identified_at_defaults(corpus_dir / "ufffiles_frf.unv")
    near = x.natural_freq[np.abs(x.natural_freq - 95.5) <= 1.5]
    assert near.size == 1 and abs(near[0] - 96.1) < 0.5, near  # the one mode of the circle, once
    (c,) = [c for c in x.candidates if abs(c.natural_freq - 94.82) < 0.1]
    assert not c.accepted and "rests on one line" in c.reason, c.reason
    # the earlier local decision of this band stays: 206.9 Hz, supported by many lines, is added
    assert np.sum(np.abs(x.natural_freq - 206.5) < 1.0) == 1


def test_ufffiles_frf_one_line_mode_not_accepted_either(corpus_dir):
    # The same 95 Hz feature reached the result by PolyMAX, not only as a missing mode: in 40-160 Hz a
    # cluster was accepted and its ML estimate was 94.99 Hz, zeta 0.2 % (half-power band 0.4 Hz, below
    # the 0.5 Hz lines), beside 96.09 Hz. A mode that narrow can rest on one line: it is tested on its
    # lines without the line nearest to it, and dropped. Oracle: the lines themselves (one Nyquist
    # circle on 92-98.5 Hz) and the whole-file result above (96.1 Hz alone).
    from ema_rig.io.uff import read_uff58

    d = read_uff58(corpus_dir / "ufffiles_frf.unv")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        x = identify(d, band=(40.0, 160.0))
    near = x.natural_freq[np.abs(x.natural_freq - 95.5) <= 1.5]
    assert near.size == 1 and abs(near[0] - 96.1) < 0.5, near
    assert any("not resolved by the lines" in c.reason and abs(c.natural_freq - 95.0) < 0.5 for c in x.candidates)


def test_ufffiles_frf_edge_mode_inside_band_b(corpus_dir, identified_at_defaults):
    # issue 18, band study, band B = 79.95-719.55 Hz: the 713.85 Hz mode (zeta 2 %, found by 0-799.5 Hz,
    # a 92-pole cluster there) lies 5.7 Hz inside B's upper edge; B's PolyMAX had no cluster for it,
    # the misfit of its last segment (522.5-719.5 Hz, 13x the noise) was put down to a mode beyond
    # the edge, and the local ML moved five of B's modes (373-687 Hz) to 709.8-716.1 Hz and held
    # them (poor fit, 24 %). With CompletenessCriteria.ml_features (default on) the place the ML moved
    # a pole to is a candidate, tested on its lines (F = 1.25e3 >= 4.8): B then holds the mode and
    # every mode is an ML estimate. Oracle: the other band (0-799.5 Hz: 713.85 Hz) and the data's
    # peak (|H| largest at 713 Hz). Fails with ml_features=False (no mode within 1 %).
    x = identified_at_defaults(corpus_dir / "ufffiles_frf.unv", (79.95, 719.55))
    near = x.natural_freq[np.abs(x.natural_freq - 713.85) <= 0.01 * 713.85]
    assert near.size == 1, x.natural_freq
    assert any("feature inside the band" in c.reason and c.accepted for c in x.candidates)
    assert not any(w.startswith("poor fit") for w in x.warnings)
    # the modes 373-687 Hz are ML estimates; the one held mode is 701.5 Hz (0-799.5 Hz: 704.9 Hz), which
    # the extra order step adds (a 6-pole cluster at zeta 0.13 %): the ML moved it to 703.9 Hz, beyond
    # its 0.94 Hz half-power half-bandwidth (test_ufffiles_frf_704_hz_in_both_bands)
    held = [f for f, k in zip(x.natural_freq, x.std_kind, strict=True) if k == "held"]
    assert all(abs(f - 704.9) <= 0.01 * 704.9 for f in held), held


def test_ufffiles_frf_two_bands_changes_inside_their_sigma(corpus_dir, identified_at_defaults):
    # issue 18, "a mode's change between two reasonable bands inside +-2 sigma for >= 90 % of the
    # modes". ufffiles_frf in 0-799.5 and 79.95-719.55 Hz: once band B fits (ml_features), its sigma
    # from blocks of 4-6 lines shrank 7-14x while its residual stays correlated over ~100 lines
    # (lag-1 autocorrelation of the weighted residual 0.9, Andrews bandwidth 100-110 lines on
    # 282-719 Hz): 20 of 31 changes inside their combined 2 sigma. With the sandwich's block length
    # from the scores (MLCriteria.block_from_scores) 28 of 31. Oracle: the other band (the same lines,
    # its own order growth and selection), not the code's sigma formula; fails with
    # block_from_scores=False (20/31).
    a = identified_at_defaults(corpus_dir / "ufffiles_frf.unv")
    b = identified_at_defaults(corpus_dir / "ufffiles_frf.unv", (79.95, 719.55))
    n = ok = 0
    for j, f in enumerate(b.natural_freq):
        k = int(np.argmin(np.abs(a.natural_freq - f)))
        if abs(a.natural_freq[k] - f) > 0.01 * f or not 90.0 <= f <= 700.0:  # away from B's edges
            continue
        n += 1
        ok += abs(a.natural_freq[k] - f) <= 2 * float(np.hypot(a.natural_freq_std[k], b.natural_freq_std[j]))
    assert n >= 28, n
    assert ok >= 0.9 * n, (ok, n)


def test_ufffiles_frf_704_hz_in_both_bands(corpus_dir, identified_at_defaults):
    # issue 18, "no mode that only one band supports, away from the edges": 0-799.5 Hz has 704.9 Hz
    # (zeta 0.5 %, a 58-pole cluster; sdypy-EMA's LSCF on the same lines has a pole at 704.7 Hz, zeta
    # 0.4 %, at every order 130-157), 79.95-719.55 Hz had none: its one pole at 689.5 Hz stood for
    # 684.7 and 704.9 Hz, and its residual on 686-714 Hz was 3.9 x the noise (chi-square, p 1e-33
    # with 100 dof) while the test's segment, 522-719.5 Hz (a chain of eight modes, 400 lines), was at
    # 1.59 x, below misfit_ratio, so the order growth stopped at 144 (no cluster there; at 160 one at
    # 701.7 Hz). The extra order step now also asks the modes' own cores (segment_edges
    # chained=False). Oracle: the other band (the same lines, its own order growth and selection) and
    # the data's lines; fails before (no mode of B within 1 % of 704.9 Hz).
    a = identified_at_defaults(corpus_dir / "ufffiles_frf.unv")
    b = identified_at_defaults(corpus_dir / "ufffiles_frf.unv", (79.95, 719.55))
    fa = a.natural_freq[np.abs(a.natural_freq - 704.9) <= 0.01 * 704.9]
    assert fa.size == 1, a.natural_freq
    near = b.natural_freq[np.abs(b.natural_freq - fa[0]) <= 0.01 * fa[0]]
    assert near.size == 1, b.natural_freq
    # and B still has the neighbours of A on either side, once each (no mode traded for another)
    for f0 in (684.7, 713.85):
        assert np.sum(np.abs(b.natural_freq - f0) <= 0.01 * f0) == 1, (f0, b.natural_freq)
