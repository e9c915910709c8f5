"""The local refits of the split and completeness tests: the ML's poles only, each refit made once per stage.

``identification._refit_on`` re-estimates the poles on a mode's own lines by the local ML; the
callers use its poles alone, so the ML's uncertainties (segment scores, covariances, the
whole-basis fits) are not formed there, and a refit the same stage already made (the null's refit
of every nested test on the same lines, each start's refit of ``_split_start`` repeated by its
nested test) is taken from the stage's memo (benchmarks/results/split_refit_cost.txt: dam0 and
disk.uff). Oracles: the true poles of a simulated pair (physics), and the full local ML
(``local_ml_staged(...).finish()``, with its uncertainties) on the same lines for "the same numbers".
"""

from __future__ import annotations

import numpy as np
import pytest

import ema_rig.identification.identification as ident
import ema_rig.identification.ml as ml_mod
from ema_rig._blas import single_threaded
from ema_rig.frf import FRFData
from ema_rig.identification.lsfd import _lsfd_checked

TRUE = ((400.0, 0.012, 1.0), (409.0, 0.010, 0.8))
SHAPES = ((1.0, 0.6, -0.4), (0.5, -0.9, 1.0))


def _pole(fn: float, z: float) -> complex:
    w = 2 * np.pi * fn
    return complex(-z * w, w * np.sqrt(1 - z * z))


def _pair(seed: int = 3) -> FRFData:
    """Mobility FRFs, 3 outputs x 1 reference, of two close modes; 0.5 % complex noise."""
    f = np.arange(360.0, 450.0, 0.25)
    jw = 2j * np.pi * f
    h = np.zeros((3, f.size), complex)
    for (fn, z, a), phi in zip(TRUE, SHAPES, strict=True):
        lam = _pole(fn, z)
        r = a * np.asarray(phi)[:, None] / (2j * lam.imag)
        h += r / (jw - lam) + np.conj(r) / (jw - np.conj(lam))
    h = jw * h
    rng = np.random.default_rng(seed)
    h = h + 0.005 * np.median(np.abs(h), axis=1, keepdims=True) * (rng.standard_normal(h.shape)
                                                                    + 1j * rng.standard_normal(h.shape))
    return FRFData(f, h[:, None], ["1+Y", "2+Y", "3+Y"], ["1+Y"], frf_form="mobility")


def _count_calls(monkeypatch: pytest.MonkeyPatch, module: object, name: str) -> list[int]:
    """A list that grows by one at each call of ``module.name`` (the function itself still runs)."""
    calls: list[int] = []
    real = getattr(module, name)

    def counting(*a, **k):  # type: ignore[no-untyped-def]
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(module, name, counting)
    return calls


# start values off the truth by about half a half-power bandwidth, as a PolyMAX pole or a split start is
START = np.array([_pole(401.5, 0.014), _pole(407.5, 0.009)])


def test_refit_gives_the_ml_poles_without_its_uncertainties(monkeypatch: pytest.MonkeyPatch) -> None:
    d = _pair()
    sl = (d.freq >= 385.0) & (d.freq <= 425.0)
    tails = _count_calls(monkeypatch, ml_mod, "_segment_tail")
    got = ident._refit_on(d, START, sl)
    assert got is not None
    # no segment scores or covariances formed: the refit needs the poles only
    assert tails == []
    # physics: the pair's true poles, to well inside a half-power half-bandwidth (0.5 % noise: the ML is
    # within ~0.05 Hz and 1e-3 damping; the starts were 1.5 Hz and 2e-3 off)
    fn, z = np.abs(got) / (2 * np.pi), -got.real / np.abs(got)
    for k, (f_t, z_t, _a) in enumerate(TRUE):
        assert fn[k] == pytest.approx(f_t, abs=0.1)
        assert z[k] == pytest.approx(z_t, abs=1e-3)
    # the same numbers as the full local ML (with its uncertainties) on the same lines
    part = d.replace(freq=d.freq[sl], frf=d.frf[:, :, sl])
    with single_threaded():
        full = ident._local_ml_staged(part, _lsfd_checked(part, START, residuals=True)).finish()
    assert tails, "the full local ML forms the segment tails"
    np.testing.assert_array_equal(got, full.poles)


def test_refit_memo_serves_repeats_only(monkeypatch: pytest.MonkeyPatch) -> None:
    d = _pair()
    sl = (d.freq >= 385.0) & (d.freq <= 425.0)
    sl2 = (d.freq >= 386.0) & (d.freq <= 425.0)  # one line less at the lower end: another problem
    plain, plain2 = ident._refit_on(d, START, sl), ident._refit_on(d, START, sl2)
    assert plain is not None and plain2 is not None
    calls = _count_calls(monkeypatch, ident, "_local_ml_staged")
    memo: ident._Refits = {}
    first = ident._refit_on(d, START, sl, memo)
    assert first is not None and len(calls) == 1
    first[0] = 0j  # the caller's copy: the memo keeps its own
    again = ident._refit_on(d, START, sl, memo)
    assert len(calls) == 1, "a repeated refit is taken from the memo"
    np.testing.assert_array_equal(again, plain)
    # other lines or other start poles are other problems: fitted, not taken from the memo
    other = ident._refit_on(d, START, sl2, memo)
    moved = ident._refit_on(d, START * (1 + 1e-3), sl, memo)
    assert len(calls) == 3
    np.testing.assert_array_equal(other, plain2)
    assert moved is not None
