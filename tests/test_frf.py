"""FRFData: validation, selection, form conversion, summaries."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from ema_rig.frf import FRFData


def _sdof(freq: np.ndarray, fn: float = 50.0, zeta: float = 0.02, m: float = 2.0) -> np.ndarray:
    """Receptance of a single-DOF oscillator [m/N]."""
    w, wn = 2 * np.pi * freq, 2 * np.pi * fn
    return 1.0 / (m * (wn**2 - w**2 + 2j * zeta * wn * w))


@pytest.fixture
def data() -> FRFData:
    f = np.linspace(0.0, 200.0, 401)
    h = _sdof(f)
    frf = np.stack([np.stack([h, 2 * h]), np.stack([-h, 3 * h])])  # (2 out, 2 in, n)
    return FRFData(f, frf, ["1+Y", "2+Y"], ["1+Y", "2+Y"], frf_form="receptance",
                   roles=["housing", "spindle"], axes=["radial", "radial"])


def test_immutable_and_copies(data: FRFData) -> None:
    arr = np.zeros((1, 1, 3), complex)
    d = FRFData([0.0, 1.0, 2.0], arr, ["1+Y"], ["1+Y"])
    arr[0, 0, 0] = 5.0  # the caller's array changes; the object must not
    assert d.frf[0, 0, 0] == 0.0
    with pytest.raises(ValueError):
        d.frf[0, 0, 0] = 1.0  # read-only
    with pytest.raises(AttributeError):
        d.frf_form = "mobility"  # type: ignore[misc]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"freq": [0.0, 2.0, 1.0]}, "increasing"),
        ({"freq": [0.0, np.nan, 2.0]}, "NaN"),
        ({"frf": np.zeros((1, 1, 2))}, "frequency lines"),
        ({"out_dofs": ["1+Y", "2+Y"]}, "out_dofs"),
        ({"frf_form": "inertance"}, "frf_form"),
    ],
)
def test_validation(kwargs: dict, match: str) -> None:
    base = {"freq": [0.0, 1.0, 2.0], "frf": np.zeros((1, 1, 3)), "out_dofs": ["1+Y"], "in_dofs": ["1+Y"]}
    base.update(kwargs)
    with pytest.raises(ValueError, match=match):
        FRFData(**base)


def test_form_conversion_round_trip(data: FRFData) -> None:
    acc = data.to_form("accelerance")
    w = 2 * np.pi * data.freq
    # accelerance = -w^2 receptance exactly; 0 Hz gives exactly 0
    assert_allclose(acc.frf, -(w**2) * data.frf, rtol=1e-12)
    assert acc.unit_str == "m/s^2/N"
    back = acc.to_form("receptance")
    assert np.all(np.isnan(back.frf[..., 0]))  # undefined at 0 Hz, never a division by zero
    assert_allclose(back.frf[..., 1:], data.frf[..., 1:], rtol=1e-12)
    dropped = acc.to_form("mobility", at_zero="drop")
    assert dropped.n_freq == data.n_freq - 1 and dropped.freq[0] > 0


def test_selection(data: FRFData) -> None:
    s = data.sel(role="spindle")
    assert s.out_dofs == data.out_dofs[1:] and s.roles == ("spindle",)
    assert_allclose(s.frf, data.frf[1:])
    t = data.sel(out="2+Y", inp=["2+Y"])
    assert_allclose(t.frf[0, 0], data.frf[1, 1])
    with pytest.raises(KeyError, match="9\\+Y"):
        data.sel(out="9+Y")
    b = data.band(40.0, 60.0)
    assert b.freq[0] >= 40.0 and b.freq[-1] <= 60.0 and b.n_freq == 41
    with pytest.raises(ValueError, match="holds no line"):
        data.band(500.0, 600.0)


def test_sum_and_cmif(data: FRFData) -> None:
    assert_allclose(data.sum_frf(), np.abs(data.frf).sum(axis=(0, 1)))
    cm = data.cmif()
    assert cm.shape == (2, data.n_freq)
    # the largest singular value is the 2-norm of each 2x2 matrix
    k = 100
    assert_allclose(cm[0, k], np.linalg.norm(data.frf[:, :, k], 2), rtol=1e-12)


# ------------------------------------------------------------------------------ coherence
def _with_coherence(data: FRFData) -> FRFData:
    coh = np.empty(data.shape)
    for i in range(data.n_out):
        for j in range(data.n_in):
            coh[i, j] = 0.1 * (1 + 2 * i + j) + 0.001 * np.arange(data.n_freq) / data.n_freq
    return data.replace(coherence=coh, n_averages=20)


def test_coherence_follows_band_sel_and_form(data: FRFData) -> None:
    d = _with_coherence(data)
    assert d.coherence.dtype == np.float64 and not d.coherence.flags.writeable and d.n_averages == 20
    b = d.band(50.0, 100.0)
    keep = (data.freq >= 50.0) & (data.freq <= 100.0)
    np.testing.assert_array_equal(b.coherence, d.coherence[:, :, keep])
    s = d.sel(out="2+Y", inp=["2+Y", "1+Y"])
    np.testing.assert_array_equal(s.coherence[0], d.coherence[1, ::-1])
    r = d.sel(role="spindle")
    np.testing.assert_array_equal(r.coherence, d.coherence[1:2])
    m = d.to_form("accelerance").to_form("mobility", at_zero="drop")  # dividing by jw: 0 Hz goes, with its coherence
    np.testing.assert_array_equal(m.coherence, d.coherence[:, :, 1:])
    assert data.coherence is None and data.band(50.0, 100.0).coherence is None and data.n_averages is None


@pytest.mark.parametrize(
    ("coh", "match"),
    [
        (np.full((2, 2, 401), 1.01), "0..1"),
        (np.full((2, 2, 401), -0.01), "0..1"),
        (np.full((2, 2, 401), np.inf), "NaN or inf"),
        (np.full((2, 1, 401), 0.5), "FRF shape"),
        (np.full((2, 2, 401), 0.5 + 0.1j), "real"),
    ],
)
def test_coherence_validated(data: FRFData, coh: np.ndarray, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        data.replace(coherence=coh)


def test_coherence_nan_rejected_and_n_averages_checked(data: FRFData) -> None:
    coh = np.full(data.shape, 0.5)
    coh[1, 0, 3] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        data.replace(coherence=coh)
    for bad in (0, -3, 0.5, np.nan, np.inf, True, "10"):
        with pytest.raises(ValueError, match="n_averages"):
            data.replace(n_averages=bad)
    # an effective (overlapped) number of averages need not be an integer; an integral one stays an int
    assert data.replace(n_averages=12.5).n_averages == 12.5
    assert type(data.replace(n_averages=10.0).n_averages) is int
