"""Coherence datasets (UFF58 function type 6) attached to the FRFs of the same file (issue 10, item 1).

Oracles: the analyser's own coherence record in the vibration_toolbox ``.mat`` files (read with
scipy.io), pyuff's reading of the corpus coherence file, and values chosen per pair in fixtures
written with pyuff.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from _pyuff_files import write_with_pyuff

from ema_rig.cli import main
from ema_rig.config import load_rig
from ema_rig.errors import UFFError, UnitWarning
from ema_rig.frf import FRFData
from ema_rig.io.uff import read_uff58, write_uff58

FREQ = np.arange(16) * 0.5  # Hz
# pyuff writes ASCII doubles with %20.11e: 12 significant digits
RTOL_PYUFF = 1e-11


def _set(node: int, direction: int, ref: int, ref_dir: int, data: np.ndarray, *, coherence: bool = False,
         x: np.ndarray = FREQ, **kw) -> dict:
    import pyuff

    args = dict(
        binary=0, func_type=6 if coherence else 4, rsp_node=node, rsp_dir=direction, ref_node=ref, ref_dir=ref_dir,
        ord_data_type=4 if coherence else 6, abscissa_spacing=1, abscissa_spec_data_type=18,
        abscissa_axis_units_lab="Hz", ordinate_spec_data_type=0 if coherence else 12,
        ordinate_axis_units_lab="NONE" if coherence else "m/s^2", orddenom_spec_data_type=0 if coherence else 13,
        orddenom_axis_units_lab="NONE" if coherence else "N", data=data, x=x,
        id1="fixture", id2="NONE", id3="NONE", id4="NONE", id5="NONE",
    )
    args.update(kw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pyuff.prepare_58(**args)


_write = write_with_pyuff


def _frf(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.standard_normal(FREQ.size) + 1j * rng.standard_normal(FREQ.size)


# ------------------------------------------------------------------------- real files
def _mat_coherence(real_frf_dir: Path, case: int) -> np.ndarray:
    from scipy.io import loadmat

    m = loadmat(real_frf_dir / f"vt_case{case}.mat")
    return np.real(m["Hf_coh_chan_2"].ravel()).astype(float)


def test_vt_case1_coherence_above_one_clipped_and_flagged(real_frf_dir: Path) -> None:
    truth = _mat_coherence(real_frf_dir, 1)  # the analyser's record, independent of the UFF
    n_high = int((truth > 1).sum())
    assert n_high > 0  # the README's analyser quirk
    d = read_uff58(real_frf_dir / "vt_case1_full.uff")  # a caveat in meta, no Python warning (suite: error)
    assert d.meta["warnings"][0].startswith(f"dataset 3: coherence 2+Z / 1+Z above 1 at {n_high} of 1601 lines")
    assert d.coherence is not None and d.coherence.shape == (1, 1, 1601) and d.coherence.dtype == np.float64
    assert not d.coherence.flags.writeable
    # pyuff wrote the record with 12 significant digits; clipping is the only change
    np.testing.assert_allclose(d.coherence[0, 0], np.clip(truth, 0.0, 1.0), rtol=RTOL_PYUFF, atol=0)
    assert d.meta["coherence_datasets"] == [3]
    assert len(d.meta["warnings"]) == 1 and "clipped to 1" in d.meta["warnings"][0]
    assert d.n_averages is None  # the id lines are NONE: not in the file
    assert not any("function type 6" in s for s in d.meta["ignored_datasets"])
    # the time histories are still listed as not-FRF datasets, as before
    assert [s.split(":")[0] for s in d.meta["ignored_datasets"]] == ["dataset 0", "dataset 1"]
    # the band keeps the matching coherence lines
    b = d.band(200.0, 220.0)
    np.testing.assert_array_equal(b.coherence[0, 0], d.coherence[0, 0][(d.freq >= 200) & (d.freq <= 220)])


def test_vt_case2_coherence_in_range_no_warning(real_frf_dir: Path) -> None:
    truth = _mat_coherence(real_frf_dir, 2)
    assert truth.max() <= 1.0
    d = read_uff58(real_frf_dir / "vt_case2_full.uff")
    np.testing.assert_allclose(d.coherence[0, 0], truth, rtol=RTOL_PYUFF, atol=0)
    assert d.meta["warnings"] == []
    # the README: coherence at the 192.6 Hz peak is 0.07-0.5, a poor measurement
    k = int(np.argmin(np.abs(d.freq - 192.59)))
    assert d.coherence[0, 0, k] < 0.6


def test_corpus_coherence_attached_to_matching_frf(corpus_dir: Path, tmp_path: Path) -> None:
    import pyuff

    src = corpus_dir / "ufffiles_coh.unv"
    with pytest.raises(UFFError, match="no FRF dataset.*coherence"):
        read_uff58(src)  # coherence alone is not an FRF file
    ref = pyuff.UFF(str(src)).read_sets(0)  # the independent reader
    n = int(ref["num_pts"])  # pyuff also returns the zero padding of the last line: cut to num_pts
    x = np.asarray(ref["x"], float)[:n]
    y = np.asarray(ref["data"], float)[:n]
    # an FRF for the same pair (1-Z / 56+Z as in the file) on the same 1600 lines, then the coherence
    frf = FRFData(x, np.ones((1, 1, x.size), complex), ["1-Z"], ["56+Z"])
    write_uff58(tmp_path / "frf.uff", frf)
    both = tmp_path / "both.uff"
    both.write_bytes((tmp_path / "frf.uff").read_bytes() + src.read_bytes())
    d = read_uff58(both)
    assert [str(o) for o in d.out_dofs] == ["1+Z"] and d.coherence is not None
    np.testing.assert_allclose(d.coherence[0, 0], y, rtol=1e-5, atol=0)  # E13.5 in the file: 6 digits
    assert d.meta["coherence_datasets"] == [1]


# --------------------------------------------------------------------------- fixtures
def test_pairs_missing_ignored_and_mismatched(tmp_path: Path) -> None:
    sets = [_set(o, 2, r, 2, _frf(10 * o + r)) for o in (1, 2) for r in (1, 5)]
    sets += [
        _set(1, 2, 1, 2, np.full(FREQ.size, 0.9), coherence=True),
        _set(2, -2, 5, 2, np.full(FREQ.size, 0.7), coherence=True),  # 2-Y: sign-free match to 2+Y
        _set(1, 2, 5, 2, np.full(FREQ.size, 0.8), coherence=True),
        _set(9, 2, 1, 2, np.full(FREQ.size, 0.5), coherence=True),  # no FRF for 9+Y
        _set(2, 2, 1, 2, np.full(FREQ.size, 0.6), coherence=True, x=FREQ * 1.01),  # other lines
        _set(1, 2, 1, 2, np.full(FREQ.size, 0.3), coherence=True),  # duplicate of dataset 4
    ]
    d = read_uff58(_write(tmp_path / "c.uff", sets))
    # 2+Y / 1+Y has no usable coherence: a partial array is not attached
    assert d.coherence is None and d.meta["coherence_datasets"] == []
    notes = " | ".join(d.meta["notes"])
    assert "dataset 7: coherence 9+Y / 1+Y ignored: no FRF for this pair" in notes
    assert "dataset 8: coherence ignored: frequency lines differ" in notes
    assert "dataset 9: coherence 1+Y / 1+Y ignored: already given by dataset 4" in notes
    assert "coherence not attached: only 3 of 4 FRFs have one (none for 2+Y / 1+Y)" in notes
    assert sum("function type 6 (coherence), not attached" in s for s in d.meta["ignored_datasets"]) == 6
    # with the fourth coherence on the right lines, all four are attached in the FRF order
    sets.append(_set(2, 2, 1, 2, np.full(FREQ.size, 0.6), coherence=True))
    d = read_uff58(_write(tmp_path / "c4.uff", sets))
    np.testing.assert_array_equal(d.coherence[:, :, 3], [[0.9, 0.8], [0.6, 0.7]])  # exact in 12 digits
    assert d.meta["coherence_datasets"] == [4, 5, 6, 10]
    # selections carry it along
    s = d.sel(out="2+Y", inp=["5+Y", "1+Y"])
    np.testing.assert_array_equal(s.coherence[0, :, 0], [0.7, 0.6])


def test_negative_and_above_one_clipped(tmp_path: Path) -> None:
    c = np.linspace(-0.1, 1.2, FREQ.size)
    p = _write(tmp_path / "c.uff", [_set(1, 2, 1, 2, _frf(1)), _set(1, 2, 1, 2, c, coherence=True)])
    d = read_uff58(p)
    msgs = list(d.meta["warnings"])
    assert any("above 1 at 3 of 16 lines (max 1.2," in m for m in msgs)  # 1.0267, 1.1133, 1.2
    assert any("below 0 at 2 lines (min -0.1)" in m for m in msgs)  # -0.1, -0.0133
    np.testing.assert_allclose(d.coherence[0, 0], np.clip(c, 0, 1), rtol=RTOL_PYUFF, atol=1e-15)
    assert d.coherence.min() == 0.0 and d.coherence.max() == 1.0


def test_with_rig_order_and_dropped_channel(tmp_path: Path, rig_file: Path) -> None:
    rig = load_rig(rig_file)
    outs = [(11, 2), (12, 2), (13, -2), (14, 3), (15, 1), (21, 2), (22, 2), (23, 1)]
    refs = [(11, 2), (15, 1)]
    sets = []
    value = {}
    for k, (n, dr) in enumerate(outs):
        for m, (r, rd) in enumerate(refs):
            sets.append(_set(n, dr, r, rd, _frf(k * 2 + m)))
            value[(k, m)] = 0.05 + 0.01 * (k * 2 + m)
            # coherence written with 13+Y although the FRF says 13-Y: coherence is sign-free
            sets.append(_set(n, abs(dr), r, rd, np.full(FREQ.size, value[(k, m)]), coherence=True))
    sets.append(_set(99, 2, 11, 2, _frf(99)))  # a response without a rig sensor
    sets.append(_set(99, 2, 11, 2, np.full(FREQ.size, 0.5), coherence=True))
    with pytest.warns(UnitWarning, match="99"):  # channel 99 has no rig sensor
        d = read_uff58(_write(tmp_path / "rig.uff", sets), rig=rig)
    assert d.meta["warnings"] == []
    want = np.array([[value[(k, m)] for m in range(2)] for k in range(8)])
    np.testing.assert_allclose(d.coherence[:, :, 0], want, rtol=RTOL_PYUFF)
    assert any("coherence 99+Y / 11+Y ignored: no FRF for this pair" in n for n in d.meta["notes"])


def test_n_averages_from_id_line(tmp_path: Path) -> None:
    sets = [_set(1, 2, 1, 2, _frf(1), id4="Averages: 20"),
            _set(1, 2, 1, 2, np.full(FREQ.size, 0.9), coherence=True, id4="20 avg")]
    assert read_uff58(_write(tmp_path / "a.uff", sets)).n_averages == 20
    sets[1] = _set(1, 2, 1, 2, np.full(FREQ.size, 0.9), coherence=True, id4="avg 10")
    d = read_uff58(_write(tmp_path / "b.uff", sets))
    assert d.n_averages is None and any("different numbers of averages [10, 20]" in n for n in d.meta["notes"])


def test_inspect_shows_coherence(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    c = np.linspace(0.2, 1.05, FREQ.size)
    p = _write(tmp_path / "c.uff", [_set(1, 2, 1, 2, _frf(1)), _set(1, 2, 1, 2, c, coherence=True)])
    assert main(["inspect", str(p), "--json", str(tmp_path / "i.json")]) == 0
    cap = capsys.readouterr()
    assert "coherence: attached for 1 of 1 FRFs (dataset(s) 1), 0.2..1 after clipping" in cap.out
    assert "warning: dataset 1: coherence 1+Y / 1+Y above 1 at 1 of 16 lines" in cap.out
    assert cap.err == ""  # a caveat of the data, shown in the table and the JSON
    rep = json.loads((tmp_path / "i.json").read_text())["frf"]
    assert rep["coherence"] == {"attached": True, "datasets": [1], "pairs": 1, "of_pairs": 1, "min": 0.2, "max": 1.0}
    assert rep["n_averages"] is None and len(rep["warnings"]) == 1


def test_rounding_excess_clipped_silently(tmp_path: Path) -> None:
    # 1 + 1e-9 is rounding of an estimate that is 1 (one average): clipped, not flagged
    c = np.full(FREQ.size, 1.0 + 1e-9)
    p = _write(tmp_path / "c.uff", [_set(1, 2, 1, 2, _frf(1)), _set(1, 2, 1, 2, c, coherence=True)])
    d = read_uff58(p)
    assert d.meta["warnings"] == [] and np.all(d.coherence == 1.0)
