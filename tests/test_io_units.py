"""The unit grammar (ema_rig.io.units) and its use by the FRF reader (issue 17).

Oracle: the unit definitions themselves (1 mm = 1e-3 m, g = 9.80665 m/s^2 exactly by CGPM 1901,
1 in = 0.0254 m, 1 lbf = 4.4482216152605 N), written out here by hand, not taken from the module.
A label the grammar cannot read must be an error naming file, dataset and label, never m/s^2.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ema_rig.errors import UFFError
from ema_rig.frf import FRFData
from ema_rig.io.uff import read_uff58, write_uff58
from ema_rig.io.units import UnitLabelError, parse_unit_label

REPO = Path(__file__).resolve().parent.parent
G = 9.80665
IN, LBF = 0.0254, 4.4482216152605

_LABELS = [
    # label, (length, time, force) exponents, factor to SI
    ("m/s^2", (1, -2, 0), 1.0), ("mm/s^2", (1, -2, 0), 1e-3), ("mm s^-2", (1, -2, 0), 1e-3),
    ("m.s^-2", (1, -2, 0), 1.0), ("m s**-2", (1, -2, 0), 1.0), ("mm*s-2", (1, -2, 0), 1e-3),
    ("m/s2", (1, -2, 0), 1.0), ("m/s²", (1, -2, 0), 1.0), ("m s⁻²", (1, -2, 0), 1.0),
    ("g", (1, -2, 0), G), ("mg", (1, -2, 0), 1e-3 * G), ("milli-g", (1, -2, 0), 1e-3 * G),
    ("µg", (1, -2, 0), 1e-6 * G), ("G", (1, -2, 0), G), ("MM/S^2", (1, -2, 0), 1e-3),
    ("in/s^2", (1, -2, 0), IN), ("IN/S2", (1, -2, 0), IN), ("mm/s", (1, -1, 0), 1e-3), ("µm", (1, 0, 0), 1e-6),
    ("μm", (1, 0, 0), 1e-6), ("N", (0, 0, 1), 1.0), ("kN", (0, 0, 1), 1e3), ("lbf", (0, 0, 1), LBF),
    ("(m/s)/N", (1, -1, -1), 1.0), ("(1/N)*(m/s²)", (1, -2, -1), 1.0), ("in/s2/lbf", (1, -2, -1), IN / LBF),
    ("g/N", (1, -2, -1), G), ("N/µm", (-1, 0, 1), 1e6), ("N/μm", (-1, 0, 1), 1e6), ("MN/m", (-1, 0, 1), 1e6),
    ("s", (0, 1, 0), 1.0), ("ms", (0, 1, 0), 1e-3), ("(Sec)", (0, 1, 0), 1.0), ("Hz", (0, -1, 0), 1.0),
    ("kHz", (0, -1, 0), 1e3), ("rad/s", (0, -1, 0), 1 / (2 * math.pi)), ("1/s", (0, -1, 0), 1.0),
]


@pytest.mark.parametrize(("label", "dims", "factor"), _LABELS)
def test_grammar_against_the_unit_definitions(label: str, dims: tuple[int, int, int], factor: float) -> None:
    u = parse_unit_label(label)
    assert u.dims == dims
    assert u.factor == pytest.approx(factor, rel=1e-15)  # products of exact decimal definitions: 1 ulp


@pytest.mark.parametrize("label", ["furlong/s^2", "m/s≤", "(m/s", "m^", "Nm", "MN", "mm^120*m^-119", "", "NONE",
                                   "m//s", "m/s^2x", "kg2m"])
def test_unreadable_labels_are_refused_with_the_label_quoted(label: str) -> None:
    with pytest.raises(UnitLabelError) as exc:
        parse_unit_label(label)
    assert repr(label.strip()) in str(exc.value)


def test_both_micro_signs_are_the_same_unit() -> None:
    # U+00B5 MICRO SIGN and U+03BC GREEK SMALL LETTER MU look alike: the same factor (the old
    # parser refused one of them beside the other)
    assert "\u00b5" != "\u03bc"
    assert parse_unit_label("N/\u00b5m") == parse_unit_label("N/\u00b5m")
    assert parse_unit_label("N/\u03bcm").factor == parse_unit_label("N/\u00b5m").factor


# ------------------------------------------------------------------------- the FRF reader
FREQ = np.arange(5) * 10.0
TRUTH = (np.arange(1, 11).reshape(2, 1, 5) * (0.25 + 0.1j)).astype(np.complex128)


def _file(tmp_path: Path, labels: tuple[str, str]) -> Path:
    """Two FRF datasets with TRUTH's numbers, the ordinate unit labels replaced by ``labels``."""
    p = tmp_path / "u.uff"
    write_uff58(p, FRFData(FREQ, TRUTH, ["1+Y", "2+Y"], ["1+Y"]))
    buf = p.read_bytes()
    old = b"m/s^2".ljust(20)
    assert buf.count(old) == 2
    head, mid, tail = buf.split(old)
    p.write_bytes(head + labels[0].encode().ljust(20) + mid + labels[1].encode().ljust(20) + tail)
    return p


@pytest.mark.parametrize(("label", "factor"), [("mg", 1e-3 * G), ("milli-g", 1e-3 * G), ("mm s^-2", 1e-3),
                                               ("m.s^-2", 1.0), ("mm/s^2", 1e-3), ("µg", 1e-6 * G)])
def test_labels_the_old_parser_dropped_are_applied(tmp_path: Path, label: str, factor: float) -> None:
    # the old reader noted "not understood; ignored" and took the numbers as m/s^2 (mg: 1000x off)
    d = read_uff58(_file(tmp_path, (label, label)))
    np.testing.assert_allclose(d.frf, TRUTH * factor, rtol=1e-12)  # 13 digits written


def test_mixed_spellings_in_one_file_are_consistent(tmp_path: Path) -> None:
    # 'mm/s^2' and 'mm s^-2' are the same unit: both datasets x 1e-3 (was: 1000x inconsistent shapes)
    d = read_uff58(_file(tmp_path, ("mm/s^2", "mm s^-2")))
    np.testing.assert_allclose(d.frf, TRUTH * 1e-3, rtol=1e-12)


@pytest.mark.parametrize("label", ["furlong/s^2", "m/s^2/Hz", "mm s^-2x"])
def test_unknown_ordinate_label_is_refused_naming_file_dataset_label(tmp_path: Path, label: str) -> None:
    p = _file(tmp_path, ("m/s^2", label))
    with pytest.raises(UFFError) as exc:
        read_uff58(p)
    assert exc.value.dataset == 1 and str(p) in str(exc.value) and repr(label) in str(exc.value)


@pytest.mark.parametrize(("label", "factor"), [("kHz", 1e3), ("Hz", 1.0), ("rad/s", 1 / (2 * math.pi))])
def test_abscissa_labels_use_the_same_grammar(tmp_path: Path, label: str, factor: float) -> None:
    p = _file(tmp_path, ("m/s^2", "m/s^2"))
    buf = p.read_bytes()
    p.write_bytes(buf.replace(b"Hz".ljust(20), label.encode().ljust(20)))
    np.testing.assert_allclose(read_uff58(p).freq, FREQ * factor, rtol=1e-12)


@pytest.mark.parametrize(("label", "match"), [("ms", "abscissa is time"), ("furlong", "not understood")])
def test_abscissa_time_or_unknown_label_refused(tmp_path: Path, label: str, match: str) -> None:
    p = _file(tmp_path, ("m/s^2", "m/s^2"))
    p.write_bytes(p.read_bytes().replace(b"Hz".ljust(20), label.encode().ljust(20)))
    with pytest.raises(UFFError, match=match) as exc:
        read_uff58(p)
    assert exc.value.dataset == 0 and repr(label) in str(exc.value)


def test_stiffness_on_mg_equals_stiffness_on_m_per_s2(tmp_path: Path) -> None:
    # the same measurement written in m/s^2 and in mg (values x 1/(9.80665e-3), labelled mg) must
    # give the same k_TB: the old reader dropped 'mg' and returned a k_TB from data 102x too small
    from ema_rig.config import load_rig
    from ema_rig.rig.stiffness import estimate_stiffness

    src = REPO / "data" / "b6302_1000N_1200rpm_r2.uff"
    if not src.is_file():
        pytest.skip("bundled data absent")
    rig = load_rig(REPO / "data" / "rig.toml")
    ref = read_uff58(src, rig=rig)
    mg = tmp_path / "mg.uff"
    # 'g' writes values / 9.80665; x 1000 first, so the numbers are in mg; then relabel g -> mg
    scaled = FRFData(ref.freq, ref.frf * 1e3, ref.out_dofs, ref.in_dofs, ref.frf_form)
    write_uff58(mg, scaled, accel_unit="g", rig=rig)
    buf = mg.read_bytes()
    field = b" Accelerance          " + b"g".ljust(20)
    assert buf.count(field) == ref.n_out * ref.n_in
    mg.write_bytes(buf.replace(field, b" Accelerance          " + b"mg".ljust(20)))
    got = read_uff58(mg, rig=rig)
    np.testing.assert_allclose(got.frf, ref.frf, rtol=1e-11)  # 13 digits written, two factors
    k_ref = estimate_stiffness(ref, rig).k_TB
    k_mg = estimate_stiffness(got, rig).k_TB
    assert k_mg == pytest.approx(k_ref, rel=1e-6)  # same data to 1e-11: identification agrees far inside 1e-6
