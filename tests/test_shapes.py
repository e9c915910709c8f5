"""Mode shapes: JSON records, dataset 55 export (read back by pyuff), shape and AutoMAC plots.

Oracle: a 4-DOF spring-mass chain with proportional damping. Its mass-normalised shapes come
from ``scipy.linalg.eigh(K, M)`` and its residues are built from them
(``R_r = phi phi^T / (2 j w_d)``), so the shapes ema_rig derives from the residues must be the
eigenvectors again, and the shapes pyuff reads back from dataset 55 must be the same.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

from ema_rig.identification import ModalModel, mac
from ema_rig.io.geometry import Geometry
from ema_rig.io.uff55 import write_uff55
from ema_rig.mode_shapes import mode_shapes_records, real_shapes

OUT = ("1+Y", "2+Y", "3+Y", "4+Y")


@pytest.fixture(scope="module")
def chain():
    m = np.diag([2.0, 1.5, 1.0, 0.5])
    k = 1e5 * np.array([[2, -1, 0, 0], [-1, 2, -1, 0], [0, -1, 2, -1], [0, 0, -1, 1.0]])
    w2, phi = scipy.linalg.eigh(k, m)  # mass-normalised columns
    wn = np.sqrt(w2)
    c = 2e-4 * k + 1.0 * m  # proportional damping
    zeta = np.diag(phi.T @ c @ phi) / (2 * wn)
    wd = wn * np.sqrt(1 - zeta**2)
    poles = -zeta * wn + 1j * wd
    res = np.einsum("ir,jr->rij", phi, phi) / (2j * wd)[:, None, None]
    model = ModalModel(poles, res[:, :, [0, 2]], np.zeros((4, 2)), np.zeros((4, 2)), OUT, ("1+Y", "3+Y"))
    return model, phi.T, wn / (2 * np.pi), zeta


def _same_up_to_sign(a: np.ndarray, b: np.ndarray, rtol: float) -> None:
    for x, y in zip(a, b, strict=True):
        s = np.sign(np.real(np.vdot(y, x)))
        np.testing.assert_allclose(x, s * y, rtol=rtol, atol=rtol * np.abs(y).max())


def test_records_give_the_mass_normalised_eigenvectors(chain):
    model, phi, fn, zeta = chain
    recs = mode_shapes_records(model)
    assert len(recs) == 4
    assert [r["reference"] for r in recs] == ["1+Y"] * 4  # first driving point by default
    assert all(r["normalisation"] == "mass" and r["unit"] == "1/sqrt(kg)" for r in recs)
    np.testing.assert_allclose([r["natural_freq"] for r in recs], fn, rtol=1e-12)
    np.testing.assert_allclose([r["damping_ratio"] for r in recs], zeta, rtol=1e-12)
    got = np.array([[complex(s["re"], s["im"]) for s in r["shape"]] for r in recs])
    _same_up_to_sign(got, phi.astype(complex), rtol=1e-10)  # exact up to rounding
    real = np.array([[s["real"] for s in r["shape"]] for r in recs])
    _same_up_to_sign(real, phi, rtol=1e-10)
    assert [s["dof"] for s in recs[0]["shape"]] == list(OUT)
    # the other reference (also a driving point) gives the same mass-normalised shapes
    other = np.array([[complex(s["re"], s["im"]) for s in r["shape"]] for r in mode_shapes_records(model, ref="3+Y")])
    _same_up_to_sign(other, phi.astype(complex), rtol=1e-10)
    with pytest.raises(KeyError, match="9\\+Y"):
        mode_shapes_records(model, ref="9+Y")


def test_real_shapes_of_a_rotated_monophase_shape():
    phi = np.array([1.0, -0.5, 0.25]) * np.exp(1j * 1.1)
    np.testing.assert_allclose(real_shapes(phi)[0], [1.0, -0.5, 0.25], rtol=1e-12)


def test_dataset_55_read_back_by_pyuff(tmp_path: Path, chain):
    import pyuff

    model, phi, fn, _ = chain
    path = tmp_path / "modes.uff"
    write_uff55(path, model, name="chain")
    sets = pyuff.UFF(str(path)).read_sets()
    assert [s["type"] for s in sets] == [55] * 4
    assert [s["analysis_type"] for s in sets] == [3] * 4
    want = model.mode_shapes("1+Y")
    back = np.array([s["r2"] for s in sets])  # Y components per node 1..4
    np.testing.assert_array_equal(sets[0]["node_nums"], [1, 2, 3, 4])
    # E13.5: 6 significant digits; relative to each shape's largest entry
    np.testing.assert_allclose(back, want, rtol=0, atol=1e-5 * np.abs(want).max())
    assert np.all(np.diag(mac(back, want)) > 1 - 1e-9)
    np.testing.assert_array_equal(np.array([s["r1"] for s in sets]), 0)  # X, Z not measured
    eig = np.array([s["eig"] for s in sets])
    np.testing.assert_allclose(eig, model.poles, rtol=1e-5)
    np.testing.assert_allclose(np.abs(eig) / (2 * np.pi), fn, rtol=1e-5)
    # the modal constant A reproduces the residues: R = phi phi^T / A
    a = np.array([s["modal_a"] for s in sets])
    res = np.einsum("ri,rj->rij", back, back) / a[:, None, None]
    np.testing.assert_allclose(res[:, :, 0], model.residues[:, :, 0], rtol=0,
                               atol=3e-5 * np.abs(model.residues).max())
    b = np.array([s["modal_b"] for s in sets])
    np.testing.assert_allclose(-b / a, model.poles, rtol=1e-4)


def test_dataset_55_complex_shapes_without_driving_point(tmp_path: Path):
    import pyuff

    rng = np.random.default_rng(5)
    shapes = rng.standard_normal((2, 3)) + 1j * rng.standard_normal((2, 3))
    poles = np.array([-3 + 600j, -5 + 1200j])
    model = ModalModel(poles, shapes[:, :, None], np.zeros((3, 1)), np.zeros((3, 1)),
                       ("5+X", "5+Z", "6+Y"), ("7+Y",))
    recs = mode_shapes_records(model)
    assert recs[0]["normalisation"] == "unit_max" and recs[0]["unit"] is None
    path = tmp_path / "cplx.unv"
    write_uff55(path, model)
    sets = pyuff.UFF(str(path)).read_sets()
    want = model.mode_shapes("7+Y")
    np.testing.assert_array_equal(sets[0]["node_nums"], [5, 6])
    for r, s in enumerate(sets):
        got = np.array([s["r1"][0], s["r3"][0], s["r2"][1]])  # 5+X, 5+Z, 6+Y
        np.testing.assert_allclose(got, want[r], rtol=0, atol=1e-5)  # unit max: 6 digits
        assert s["r2"][0] == 0 and s["r1"][1] == 0


def test_dataset_55_refuses_rotations_and_empty_models(tmp_path: Path):
    model = ModalModel(np.array([-1 + 100j]), np.ones((1, 1, 1)), np.zeros((1, 1)), np.zeros((1, 1)),
                       ("1+RX",), ("1+RX",))
    with pytest.raises(ValueError, match="translations only"):
        write_uff55(tmp_path / "r.uff", model)
    empty = ModalModel(np.zeros(0), np.zeros((0, 1, 1)), np.zeros((1, 1)), np.zeros((1, 1)), ("1+Y",), ("1+Y",))
    with pytest.raises(ValueError, match="no mode"):
        write_uff55(tmp_path / "e.uff", empty)
    assert not (tmp_path / "r.uff").exists() and not (tmp_path / "e.uff").exists()


# ---------------------------------------------------------------------------------- plots
def test_shape_on_geometry(chain, mplcleanup):
    from ema_rig.plot.shapes import plot_mode_shape

    model, phi, _, _ = chain
    geo = Geometry([1, 2, 3, 4, 5], [[0, 0, 0], [0.1, 0, 0], [0.2, 0, 0], [0.3, 0, 0], [0.3, 0, 0.1]],
                   lines=[(1, 2), (2, 3), (3, 4), (4, 5)])
    p = plot_mode_shape(model, 1, geometry=geo, scale=0.2)
    assert p.ax.name == "3d"
    assert len(p.undeformed) == len(p.deformed) == 2  # one collection of the 4 trace lines + the nodes
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(p.figure).draw()  # 3D segments are projected when drawn
    assert len(p.undeformed[0].get_segments()) == len(p.deformed[0].get_segments()) == 4
    assert [t.get_text() for t in p.labels] == [" 1", " 2", " 3", " 4", " 5"]  # 5 nodes: all readable
    # drawn Y displacement: the real shape scaled to 0.2 x geometry size (0.3) at its largest
    ref = phi[1] * np.sign(phi[1][np.argmax(np.abs(phi[1]))])
    np.testing.assert_allclose(p.displacement[:4, 1], 0.2 * 0.3 * ref / np.abs(ref).max(), rtol=1e-9)
    np.testing.assert_array_equal(p.displacement[4], 0.0)  # node 5 not measured
    np.testing.assert_array_equal(p.displacement[:, [0, 2]], 0.0)
    assert p.unmapped == ()
    assert "mode 2" in p.ax.get_title() and "MPC 1.000" in p.ax.get_title()


def test_shape_bar_chart_without_geometry(chain, mplcleanup):
    from ema_rig.plot.shapes import plot_mode_shape

    model, phi, _, _ = chain
    p = plot_mode_shape(model, 0)
    heights = np.array([b.get_height() for b in p.bars[0]])
    ref = phi[0] * np.sign(phi[0][np.argmax(np.abs(phi[0]))])
    np.testing.assert_allclose(heights, ref / np.abs(ref).max(), rtol=1e-9)
    assert [t.get_text() for t in p.ax.get_xticklabels()] == list(OUT)
    with pytest.raises(IndexError):
        plot_mode_shape(model, 4)
    # geometry that holds none of the measured nodes falls back to bars and says so
    p2 = plot_mode_shape(model, 0, geometry=Geometry([9], [[0, 0, 0]]))
    assert p2.bars and p2.unmapped == OUT


def test_automac(chain, mplcleanup):
    from ema_rig.plot.shapes import plot_automac

    model, phi, _, _ = chain
    p = plot_automac(model)
    # mass-orthogonal, not orthogonal: the MAC of the eigenvectors themselves, computed here
    num = np.abs(phi @ phi.T) ** 2
    den = np.outer(np.sum(phi**2, 1), np.sum(phi**2, 1))
    np.testing.assert_allclose(p.values, num / den, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(np.diag(p.values), 1.0, rtol=1e-12)
    assert len(p.texts) == 16
    assert p.image.get_array().shape == (4, 4)
