"""Conformance of the UFF reader on the shared corpus of real files (``../shared/uff-corpus``).

Every dataset 58 of every file is either read with exactly the header's num_pts values, equal to
an independent parse, or refused with a reason. The independent parses are: pyuff where it is
right (bit-exact comparison), the ASCII twin of each binary SDRC case file, the LF twin of the
CR-only file, and a whitespace-split parse written here for the files pyuff cannot read.
"""

from __future__ import annotations

import contextlib
import io
import json
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import CORPUS  # noqa: E402

from ema_rig.errors import UFFError
from ema_rig.io.uff import inspect_uff, read_uff, read_uff58

MANIFEST = json.loads((CORPUS / "manifest.json").read_text()) if (CORPUS / "manifest.json").is_file() else []
# without the corpus one placeholder, skipped by the corpus_dir fixture with the ../shared reason
# (an empty parameter set would be skipped with a reason that says nothing)
NAMES = [e["short"] for e in MANIFEST] or ["(uff-corpus not found)"]

# the only datasets that must be refused, and a word of the reason
EXPECTED_REFUSED = {"pyuff_milestone_truncated.uff": {0: "truncated"}}
# files where pyuff 2.5.8 is wrong (DESIGN §5): float32 abscissa, zero padding, 2E20.12 doubles
PYUFF_WRONG = {
    "ufffiles_case6_binary.unv", "ufffiles_case8_binary.unv", "ufffiles_coh.unv", "ufffiles_frf.unv",
    "ufffiles_frf_utf8unit.unv", "ufffiles_time.unv", "maxb_windturbine_lf.uff", "maxb_windturbine_cr.uff",
    "pyuff_milestone_truncated.uff",
}
# FRF files that read_uff58 must assemble, with the form their codes/labels give
FRF_FILES = {
    "readuff_uff58b_frf.frf": "mobility",  # ordinate code 11
    "ufffiles_frf.unv": "mobility",  # label (m/s)/N, code 0
    "pyuff_non_ascii_frf.uff": "accelerance",  # Latin-1 label (1/N)*(m/s²)
    "ufffiles_151_164_58_55_inch.unv": "accelerance",  # code 12, dataset 164 inch/lbf
    "ufffiles_two_58b.ufb": "accelerance",
    **{f"ufffiles_case{i}_{k}.unv": "accelerance" for i in (3, 4, 7, 8) for k in ("ascii", "binary")},
}
# FRF files whose FRF is stored as real values (ordinate data type 2 or 4): the complex FRF of their
# complex twin (case 1 -> 3, 2 -> 4, 5 -> 7, 6 -> 8) as interleaved (Re, Im) pairs, twice num_pts
REAL_FRF_TWINS = {1: 3, 2: 4, 5: 7, 6: 8}


def _entry(name: str) -> dict:
    return next(e for e in MANIFEST if e["short"] == name)


def _pyuff_sets(path: Path) -> list[dict]:
    import pyuff

    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("ignore")
        sets = pyuff.UFF(str(path)).read_sets()
    sets = sets if isinstance(sets, list) else [sets]
    return [s for s in sets if s.get("type") == 58]


def _split_parse(path: Path) -> list[np.ndarray]:
    """Independent parse of simple ASCII files: blocks between -1 lines, values by whitespace."""
    text = path.read_bytes().decode("latin-1")
    lines = re.split(r"\r\n|\r|\n", text)
    out, i = [], 0
    while i < len(lines):
        if lines[i].strip() == "-1" and i + 1 < len(lines) and lines[i + 1].strip() == "58":
            j = i + 2
            while lines[j].strip() != "-1":
                j += 1
            out.append(np.array(" ".join(lines[i + 13 : j]).split(), dtype=float))
            i = j + 1
        else:
            i += 1
    return out


@pytest.mark.parametrize("name", NAMES)
def test_corpus_file_read_or_refused(corpus_dir: Path, name: str) -> None:
    path = corpus_dir / name
    entry = _entry(name)
    recs = [r for r in read_uff(path) if r.type == 58]
    # framing: as many dataset-58 blocks as the independent header scan found
    assert len(recs) == entry["n58"]
    refused = EXPECTED_REFUSED.get(name, {})
    for k, r in enumerate(recs):
        if k in refused:
            assert r.status == "refused" and refused[k] in r.reason
            assert r.x is None and r.y is None and r.num_pts is None
            continue
        assert r.status == "read", r.reason
        # exactly the header's num_pts, as the manifest's independent scan counts them
        assert r.num_pts == r.num_pts_header == entry["npts_per_set"][k]
        assert r.x.shape == r.y.shape == (r.num_pts,)
        assert r.header["ord_data_type"] in entry["odt"]  # the scan lists each file's types once
        assert bool(np.iscomplexobj(r.y)) == (r.header["ord_data_type"] in (5, 6))
        assert np.all(np.isfinite(r.y)) and np.all(np.diff(r.x) > 0)
    read = [r for r in recs if r.status == "read"]
    if read and entry["npts_mismatch"] == 0:
        # abscissa range over the file equals the scan's (printed with 11 digits -> rtol 1e-9)
        lo = min(r.x[0] for r in read)
        hi = max(r.x[-1] for r in read)
        np.testing.assert_allclose([lo, hi], entry["x_range"], rtol=1e-9, atol=1e-12)
    if name not in PYUFF_WRONG:
        # pyuff parses these correctly: the same doubles, bit for bit
        for r, s in zip(recs, _pyuff_sets(path), strict=True):
            np.testing.assert_array_equal(r.y, s["data"])
            np.testing.assert_array_equal(r.x, s["x"])


@pytest.mark.parametrize("case", range(1, 9))
def test_binary_case_equals_ascii_twin(corpus_dir: Path, case: int) -> None:
    a = read_uff(corpus_dir / f"ufffiles_case{case}_ascii.unv")[0]
    b = read_uff(corpus_dir / f"ufffiles_case{case}_binary.unv")[0]
    single = a.header["ord_data_type"] in (2, 5)
    # ASCII E13.5 holds 6 significant digits, E20.12 13; the binary twin holds the full value
    rtol = 5e-6 if single else 5e-13
    scale = np.max(np.abs(b.y))
    np.testing.assert_allclose(a.y, b.y, rtol=0, atol=rtol * scale)
    # the uneven abscissa is E13.5 in ASCII and float32 in binary: 6 digits
    np.testing.assert_allclose(a.x, b.x, rtol=5e-6)


def test_cr_only_equals_lf_and_2e20_doubles(corpus_dir: Path) -> None:
    lf = read_uff(corpus_dir / "maxb_windturbine_lf.uff")
    cr = read_uff(corpus_dir / "maxb_windturbine_cr.uff")
    ind = _split_parse(corpus_dir / "maxb_windturbine_lf.uff")
    assert [r.num_pts for r in lf] == [1, 1, 40, 20]
    for a, b, v in zip(lf, cr, ind, strict=True):
        np.testing.assert_array_equal(a.y, b.y)  # same text, only line ends differ
        np.testing.assert_array_equal(a.x, b.x)
        if a.header["abscissa_spacing"] == 0:  # uneven doubles written 2E20.12
            np.testing.assert_array_equal(a.x, v[0::2])
            np.testing.assert_array_equal(a.y, v[1::2])
        else:
            np.testing.assert_array_equal(a.y, v)


@pytest.mark.parametrize(
    ("name", "n", "complex_", "pad"),
    [
        ("ufffiles_frf.unv", 1600, True, 4),
        ("ufffiles_frf_utf8unit.unv", 1600, True, 4),
        ("ufffiles_coh.unv", 1600, False, 2),
        ("ufffiles_time.unv", 4096, False, 2),
    ],
)
def test_zero_padded_last_line_trimmed(corpus_dir: Path, name: str, n: int, complex_: bool, pad: int) -> None:
    r = read_uff(corpus_dir / name)[0]
    v = _split_parse(corpus_dir / name)[0]
    k = 2 if complex_ else 1
    assert v.size == k * n + pad and not np.any(v[k * n :])  # the file pads its last line with zeros
    want = v[0 : k * n : 2] + 1j * v[1 : k * n : 2] if complex_ else v[:n]
    np.testing.assert_array_equal(r.y, want)
    assert any(f"{pad} trailing zero(s)" in note for note in r.notes)


def test_dof_from_entity_names(corpus_dir: Path) -> None:
    r = read_uff(corpus_dir / "ufffiles_frf.unv")[0]
    # DOF only in the entity names '.1.Z-' and '.56.Z'
    assert str(r.response) == "1-Z" and str(r.reference) == "56+Z"


def test_run_together_numbers(corpus_dir: Path) -> None:
    r = read_uff(corpus_dir / "dt9837_nospacing_time.uff")[0]
    # first data line: -3.09944E-004-2.74181E-004  -0.00115633-6.31809E-004 ...
    np.testing.assert_array_equal(r.y[:4], [-3.09944e-4, -2.74181e-4, -0.00115633, -6.31809e-4])
    assert r.num_pts == 66


def test_labels_latin1_and_utf8(corpus_dir: Path) -> None:
    lat = read_uff(corpus_dir / "pyuff_non_ascii_frf.uff")[0]
    utf = read_uff(corpus_dir / "hbm_catman_time.uff")[0]
    assert lat.units["ordinate"]["label"] == "(1/N)*(m/s²)"
    assert utf.units["ordinate"]["label"] == "m/s²"


def test_inch_lbf_dataset_164(corpus_dir: Path) -> None:
    path = corpus_dir / "ufffiles_151_164_58_55_inch.unv"
    raw = read_uff(path)[2]
    d = read_uff58(path)
    # in/s^2 per lbf to m/s^2 per N: x 0.0254 / 4.4482216152605 (exact definitions)
    np.testing.assert_allclose(d.frf[0, 0], raw.y * 0.0254 / 4.4482216152605, rtol=1e-12)
    assert "164" in d.meta["unit_decisions"][0]
    assert [x["type"] for x in inspect_uff(path)["datasets"]] == [151, 164, 58, 55]


@pytest.mark.parametrize("name", sorted(FRF_FILES))
def test_corpus_frf_assembly(corpus_dir: Path, name: str) -> None:
    d = read_uff58(corpus_dir / name)
    assert d.frf_form == FRF_FILES[name]
    entry = _entry(name)
    assert d.n_freq == entry["npts_per_set"][0]
    assert len(d.meta["unit_decisions"]) == d.n_out * d.n_in == entry["n58"]


@pytest.mark.parametrize("case", sorted(REAL_FRF_TWINS))
def test_corpus_real_valued_frf_is_refused(corpus_dir: Path, case: int) -> None:
    """4ff7088 read these as accelerance FRFs of 1602 real lines with zero imaginary part, up to twice the
    frequency of the data (0-400 Hz for 0-200 Hz): the values are the complex twin's (Re, Im) pairs."""
    name = f"ufffiles_case{case}_ascii.unv"
    real = read_uff(corpus_dir / name)[0]
    twin = read_uff(corpus_dir / f"ufffiles_case{REAL_FRF_TWINS[case]}_ascii.unv")[0]
    # the independent reading of what the values are: the twin's complex FRF, pair by pair (same digits)
    np.testing.assert_array_equal(real.y[0::2] + 1j * real.y[1::2], twin.y)
    for kind in ("ascii", "binary"):
        with pytest.raises(UFFError, match=r"dataset 0: FRF stored as real values"):
            read_uff58(corpus_dir / f"ufffiles_case{case}_{kind}.unv")


def test_corpus_utf8_unit_garbled_is_refused(corpus_dir: Path) -> None:
    # '(m/s≤)/N' with code 0 says no quantity: refused rather than guessed
    with pytest.raises(UFFError, match=r"dataset 0: ordinate unit label .* not understood"):
        read_uff58(corpus_dir / "ufffiles_frf_utf8unit.unv")


def test_corpus_non_frf_file_refused_for_frf(corpus_dir: Path) -> None:
    with pytest.raises(UFFError, match="no FRF dataset .* found coherence"):
        read_uff58(corpus_dir / "ufffiles_coh.unv")


def test_corpus_manifest_lists_files(corpus_dir: Path) -> None:
    """The parametrised tests above run on every corpus file, not on an empty list."""
    assert len(NAMES) >= 30, f"manifest in {corpus_dir} lists {len(NAMES)} files"
