"""``segment_misfit(segment_fits=...)``: local fits taken over from an earlier call are the fits it would form.

The completeness test's local fits by segment are kept (:data:`~ema_rig.identification.noise.SegmentFits`) so
that ``_failing_locally`` (the modes' unchained cores against the test's variance) fits only the cores that
are no segment of the test (issue 18: speed). Oracle: the same test formed without any fit taken over, to the
bit (the same operations on the same lines), on the bundled rig file, whose cores split one chain of the test
(identify's use: ``test_failing_locally_takes_the_tests_fits_into_the_cores`` in ``tests/test_completeness.py``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ema_rig.config import load_rig
from ema_rig.frf import FORM_POWER
from ema_rig.identification import identify
from ema_rig.identification.criteria import CompletenessCriteria
from ema_rig.identification.noise import MisfitTest, SegmentFits, segment_edges, segment_misfit

DATA = Path(__file__).resolve().parent.parent / "data"


def _same(a: MisfitTest, b: MisfitTest) -> None:
    for name in ("freq_lower", "freq_upper", "ratio", "worst_ratio", "p_value", "dof", "failed", "edge", "variance"):
        x, y = getattr(a, name), getattr(b, name)
        assert (x is None and y is None) or np.array_equal(x, y, equal_nan=True), name
    assert (a.alpha, a.noise_source) == (b.alpha, b.noise_source)


def _rig():
    from ema_rig.io.uff import read_uff58

    d = read_uff58(DATA / "b6302_1000N_1200rpm.uff", rig=load_rig(DATA / "rig.toml"))
    return d.band(150.0, 1000.0)


def test_taken_over_fits_are_the_fits_formed_here():
    d = _rig()
    lam = identify(d, band=(150.0, 1000.0)).modes.poles
    cc = CompletenessCriteria()
    p = FORM_POWER[d.frf_form]
    fits: SegmentFits = {}
    first = segment_misfit(d.freq, d.frf, lam, power=p, criteria=cc, segment_fits=fits)
    _same(first, segment_misfit(d.freq, d.frf, lam, power=p, criteria=cc))
    assert len(fits) == first.failed.size
    # the unchained cores against the test's variance: those that are segments of the test are taken over
    fn, zeta = np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam)
    cores = segment_edges(d.freq, fn, zeta, criteria=cc, chained=False)
    chained = segment_edges(d.freq, fn, zeta, criteria=cc)
    assert not np.array_equal(cores, chained)  # the rig file's cores split a chain: both kinds of segment
    n_before = len(fits)
    taken = segment_misfit(d.freq, d.frf, lam, power=p, variance=first.variance, edges=cores, criteria=cc,
                           segment_fits=fits)
    _same(taken, segment_misfit(d.freq, d.frf, lam, power=p, variance=first.variance, edges=cores, criteria=cc))
    same = set(zip(cores[:-1].tolist(), cores[1:].tolist(), strict=True)) & set(
        zip(chained[:-1].tolist(), chained[1:].tolist(), strict=True))
    assert same and len(fits) - n_before == cores.size - 1 - len(same)  # only the new cores were fitted and added
    # other poles: nothing taken over (the key holds the poles)
    other = lam * (1 + 1e-9)
    _same(segment_misfit(d.freq, d.frf, other, power=p, criteria=cc, segment_fits=fits),
          segment_misfit(d.freq, d.frf, other, power=p, criteria=cc))
