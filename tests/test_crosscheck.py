"""``--crosscheck`` (issue 18 item 6): every mode where ema_rig and sdypy-EMA differ by more than
their combined sigma in f or in zeta is flagged; no matplotlib backend is selected and only
sdypy-EMA's public API is used."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from ema_rig.frf import FRFData
from ema_rig.identification import identify
from ema_rig.identification.crosscheck import (
    COMBINED_SIGMAS,
    PEER_MIN_ORDERS,
    CrossCheckRow,
    crosscheck,
)
from ema_rig.processing import ProcessingHistory

pytestmark = pytest.mark.crosscheck


def _row(**kw: float) -> CrossCheckRow:
    base = dict(natural_freq=11.7615, damping_ratio=0.00483, natural_freq_peer=11.7615, damping_ratio_peer=0.00483,
                n_orders_peer=30, natural_freq_std=0.01, damping_ratio_std=0.0004, natural_freq_std_peer=0.01,
                damping_ratio_std_peer=0.0004)
    base.update(kw)
    return CrossCheckRow(**base)  # type: ignore[arg-type]


def test_flags_follow_the_combined_sigma():
    assert COMBINED_SIGMAS == 1.0
    assert _row().flags == ()
    sig_z = np.hypot(0.0004, 0.0004)
    # dam0 at 11.76 Hz (1-12 Hz band): zeta 0.483 % vs sdypy-EMA 1.393 %, frequencies within sigma
    r = _row(damping_ratio_peer=0.01393, natural_freq_peer=11.7615 + 0.005)
    assert r.flags == ("zeta",) and r.flagged
    np.testing.assert_allclose(r.damping_sigma, sig_z, rtol=1e-12)
    assert _row(damping_ratio_peer=0.00483 + 0.99 * sig_z).flags == ()
    assert _row(damping_ratio_peer=0.00483 + 1.01 * sig_z).flags == ("zeta",)
    assert _row(natural_freq_peer=11.7615 + 1.01 * np.hypot(0.01, 0.01)).flags == ("f",)
    # an unknown sigma counts as 0: any difference is flagged, never silently accepted
    assert _row(natural_freq_std=float("nan"), natural_freq_std_peer=float("nan"),
                natural_freq_peer=11.7616).flags == ("f",)
    assert _row(n_orders_peer=0, natural_freq_peer=float("nan"), damping_ratio_peer=float("nan")).flags == ("missing",)


def _two_modes(f: np.ndarray, decay: float = 0.0) -> np.ndarray:
    poles = [-2.0 - decay + 2j * np.pi * 40.0, -3.0 - decay + 2j * np.pi * 90.0]
    return sum(1.0 / (2j * np.pi * f - p) + 1.0 / (2j * np.pi * f - np.conj(p)) for p in poles)


def test_library_crosscheck_has_no_side_effects_and_flags_a_wrong_mode(monkeypatch: pytest.MonkeyPatch):
    pytest.importorskip("sdypy.EMA")
    import matplotlib
    from sdypy.EMA import stabilization

    def boom(*a: object, **k: object) -> None:
        raise AssertionError("called")

    monkeypatch.setattr(matplotlib, "use", boom)  # the library must not select a backend
    monkeypatch.setattr(stabilization, "_stabilization", boom)  # nor use sdypy-EMA's private API
    f = np.linspace(0.0, 150.0, 1201)
    h = _two_modes(f)
    data = FRFData(f, np.stack([h, 0.5 * h])[:, None, :], ["2+Z", "3+Z"], ["1+Z"], frf_form="receptance")
    ident = identify(data)
    cc = crosscheck(data, ident)
    assert [r.found for r in cc.rows] == [True, True]
    # both tools on noise-free data: the same poles to 1e-6 (f) and 1e-4 (zeta, relative)
    for r in cc.rows:
        assert abs(r.freq_diff) < 1e-6 and abs(r.damping_ratio_peer / r.damping_ratio - 1) < 1e-4
    # the same identification with its 90 Hz damping doubled: flagged in zeta, with sigma well below
    p = ident.modes.poles.copy()
    wn, z = abs(p[1]), -p[1].real / abs(p[1])
    p[1] = wn * complex(-2 * z, np.sqrt(1 - 4 * z * z))  # same natural frequency, damping doubled
    bad = replace(ident, modes=replace(ident.modes, poles=p),
                  damping_ratio_std=np.full(2, 1e-4), natural_freq_std=np.full(2, 1e-3))
    rows = crosscheck(data, bad).rows
    assert "zeta" in rows[1].flags and "f" not in rows[1].flags and rows[0].flags == ()
    assert "zeta" in crosscheck(data, bad).table().splitlines()[-1]


def test_peer_poles_get_the_same_window_correction():
    """Exponentially windowed FRFs: sdypy-EMA's poles are corrected like ema_rig's before comparing."""
    pytest.importorskip("sdypy.EMA")
    f = np.linspace(0.0, 150.0, 1201)
    hist = ProcessingHistory(window="exponential", window_code=4, exp_decay=1.5, source="test")
    h = _two_modes(f, decay=1.5)  # as the window leaves them: every decay +1.5 rad/s
    data = FRFData(f, np.stack([h, 0.5 * h])[:, None, :], ["2+Z", "3+Z"], ["1+Z"], frf_form="receptance",
                   meta={"processing": hist})
    ident = identify(data)
    want = [2.0 / np.hypot(2.0, 2 * np.pi * 40.0), 3.0 / np.hypot(3.0, 2 * np.pi * 90.0)]
    np.testing.assert_allclose(ident.damping_ratio, want, rtol=1e-4)
    cc = crosscheck(data, ident)
    np.testing.assert_allclose([r.damping_ratio_peer for r in cc.rows], want, rtol=1e-4)


def test_dam0_flags_follow_the_combined_sigma_and_the_peer_only_modes_are_listed(real_frf_dir: Path):
    """The issue's case: dam0 in 1-12 Hz. At 11.76 Hz the default ML gave zeta 0.48 % against sdypy-EMA's
    1.39 %, unflagged; that estimate came from a rank-deficient ML background (issue 18 item 1, a value
    that also moved with the BLAS kernel). Now the two tools agree there in zeta, and the stable clusters
    only sdypy-EMA has are listed. The 10.21 Hz damping (ema_rig 1.64 %, sdypy-EMA 0.96 %, --refine
    1.47 %) was flagged at 2.9 combined sigma while its sigma (0.07 %) was the noise part alone: the
    segment's whole background basis gives 1.15 %, and that model-form part is now in its sigma
    (0.54 %), so the two tools differ by 1.3 combined sigma there (issue 18, e_bands)."""
    pytest.importorskip("sdypy.EMA")
    from ema_rig.io.uff import read_uff58

    data = read_uff58(real_frf_dir / "dam0.unv")
    ident = identify(data, band=(1.0, 12.0))
    cc = crosscheck(data, ident)
    row = min(cc.rows, key=lambda r: abs(r.natural_freq - 11.76))
    assert abs(row.natural_freq - 11.76) < 0.05
    # measured 1.377 % vs 1.393 %, combined sigma 0.16 %
    assert abs(row.damping_ratio_peer - row.damping_ratio) < row.damping_sigma and "zeta" not in row.flags
    r10 = min(cc.rows, key=lambda r: abs(r.natural_freq - 10.21))
    # its damping sigma holds the basis's model-form part: above the peers' spread's half (0.34 %),
    # below the spread itself (0.68 %)
    k10 = int(np.argmin(np.abs(ident.natural_freq - 10.21)))
    assert 0.0034 < ident.damping_ratio_std[k10] < 0.0068
    assert abs(r10.damping_ratio_peer - r10.damping_ratio) < 2 * r10.damping_sigma
    # every ema_rig mode has the peer's stable cluster beside it but the 7.28 Hz second mode of the 7.14 Hz pair
    # (CompletenessCriteria.split_misfit: F 9.8 against 1.79 with (54, 1244) dof on 6.66-7.56 Hz); there sdypy-EMA
    # has a stable pole at 0 or 1 orders, by the BLAS kernel and thread count (rounding): no evidence either way
    weak = [r.natural_freq for r in cc.rows if r.n_orders_peer < PEER_MIN_ORDERS]
    assert len(weak) == 1 and abs(weak[0] - 7.28) < 0.02, weak
    # every mode whose f or zeta differ by more than the combined sigma carries the flag, and no other
    for r in cc.rows:
        if not r.found:
            assert r.flags == ("missing",)
        else:
            # a sigma the peer cannot give (a cluster of one order: no spread) counts as 0, as documented;
            # with one BLAS thread sdypy-EMA has the 7.28 Hz pole at exactly one order (NaN sigma)
            big_f = abs(r.natural_freq_peer - r.natural_freq) > np.hypot(
                r.natural_freq_std, np.nan_to_num(r.natural_freq_std_peer))
            big_z = abs(r.damping_ratio_peer - r.damping_ratio) > np.hypot(
                r.damping_ratio_std, np.nan_to_num(r.damping_ratio_std_peer))
            assert ("f" in r.flags) == big_f and ("zeta" in r.flags) == big_z
        line = next(ln for ln in cc.table().splitlines() if ln.strip().startswith(f"{r.natural_freq:.4f}"))
        assert line.rstrip().endswith(",".join(r.flags) or "-")
    # sdypy-EMA's stable clusters away from every ema_rig mode (measured: 1.02, 5.13, 9.47, 10.51 Hz)
    assert any(abs(m.natural_freq - 5.13) < 0.05 for m in cc.peer_only)
    assert all(np.min(np.abs(ident.natural_freq - m.natural_freq)) > 0.01 * m.natural_freq for m in cc.peer_only)
    assert cc.table().rstrip().endswith("missed")


def test_a_mode_ema_rig_misses_is_listed():
    """Drop the 90 Hz mode from ema_rig's result: the cross-check lists it as found by sdypy-EMA only."""
    pytest.importorskip("sdypy.EMA")
    f = np.linspace(0.0, 150.0, 1201)
    h = _two_modes(f)
    data = FRFData(f, np.stack([h, 0.5 * h])[:, None, :], ["2+Z", "3+Z"], ["1+Z"], frf_form="receptance")
    ident = identify(data)
    assert crosscheck(data, ident).peer_only == ()
    mm = ident.modes
    one = replace(ident, modes=replace(mm, poles=mm.poles[:1], residues=mm.residues[:1]),
                  natural_freq_std=ident.natural_freq_std[:1], damping_ratio_std=ident.damping_ratio_std[:1])
    cc = crosscheck(data, one)
    assert len(cc.peer_only) == 1
    # the missed mode is the 90 Hz pole -3 + 2j pi 90 (noise-free: 1e-6 in f, 1e-4 in zeta)
    lam = -3.0 + 2j * np.pi * 90.0
    np.testing.assert_allclose(cc.peer_only[0].natural_freq, abs(lam) / (2 * np.pi), rtol=1e-6)
    np.testing.assert_allclose(cc.peer_only[0].damping_ratio, 3.0 / abs(lam), rtol=1e-4)
    assert cc.peer_only[0].n_orders >= 4 and cc.table().rstrip().endswith("missed")


def test_modes_json_carries_the_crosscheck_flags_and_no_wall_time(tmp_path: Path):
    """``modes --crosscheck --json``: the per-mode flags and the peer-only modes go into the JSON (for
    scripts), the wall time of sdypy-EMA does not (the same file gives the same bytes)."""
    pytest.importorskip("sdypy.EMA")
    import json

    from ema_rig.cli import main
    from ema_rig.io.uff import write_uff58

    f = np.linspace(0.0, 150.0, 1201)
    h = _two_modes(f)
    data = FRFData(f, np.stack([h, 0.5 * h])[:, None, :], ["2+Z", "3+Z"], ["1+Z"], frf_form="receptance")
    src = tmp_path / "two.uff"
    write_uff58(src, data)
    outs = [tmp_path / "a.json", tmp_path / "b.json"]
    for out in outs:
        assert main(["modes", str(src), "--crosscheck", "--json", str(out)]) == 0
    assert outs[0].read_bytes() == outs[1].read_bytes()
    doc = json.loads(outs[0].read_text())["crosscheck"]
    assert "seconds" not in doc and doc["peer_only"] == [] and doc["n_flagged"] == 0
    assert [m["flags"] for m in doc["modes"]] == [[], []]
    np.testing.assert_allclose([m["natural_freq_peer"] for m in doc["modes"]],
                               [abs(-2 + 2j * np.pi * 40) / (2 * np.pi), abs(-3 + 2j * np.pi * 90) / (2 * np.pi)],
                               rtol=1e-6)
