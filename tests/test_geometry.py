"""Test geometry from UFF datasets 15, 2411 and 82 (ema_rig.io.geometry, read through pyuff).

The files are written with pyuff's own writers (prepare_15 / prepare_2411 / prepare_82), so
the expected coordinates and lines are the values put in, not anything ema_rig computed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import pyuff

from ema_rig.errors import UFFError
from ema_rig.io.geometry import Geometry, read_geometry


def _frf58(node: int) -> dict:
    f = np.linspace(0, 100, 11)
    return pyuff.prepare_58(
        func_type=4, rsp_node=node, rsp_dir=2, ref_node=node, ref_dir=2, binary=0, data=np.ones(11, complex),
        x=f, id1="frf", abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=10.0, num_pts=11, ord_data_type=6,
        abscissa_spec_data_type=18, ordinate_spec_data_type=12, orddenom_spec_data_type=13)


def _write(path: Path, sets: list[dict]) -> Path:
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return path


def test_dataset_15_and_82(tmp_path: Path):
    ids = np.array([1, 2, 3, 4])
    xyz = np.array([[0.0, 0.0, 0.0], [0.25, 0.0, 0.0], [0.25, 0.125, 0.0], [0.0, 0.125, 0.5]])
    path = _write(tmp_path / "geo.uff", [
        pyuff.prepare_15(node_nums=ids.tolist(), def_cs=[0] * 4, disp_cs=[0] * 4, color=[1] * 4,
                         x=xyz[:, 0].tolist(), y=xyz[:, 1].tolist(), z=xyz[:, 2].tolist()),
        # a closed loop 1-2-3-4-1, then pen up (0) and a separate segment 2-4
        pyuff.prepare_82(trace_num=1, n_nodes=8, color=1, id="frame",
                         nodes=np.array([1, 2, 3, 4, 1, 0, 2, 4])),
    ])
    g = read_geometry(path)
    np.testing.assert_array_equal(g.node_ids, ids)
    np.testing.assert_allclose(g.coords, xyz, rtol=1e-6)  # pyuff writes 6 significant digits
    assert g.lines == ((1, 2), (2, 3), (3, 4), (4, 1), (2, 4))
    np.testing.assert_allclose(g.coord(3), [0.25, 0.125, 0.0], rtol=1e-6)
    assert g.size == pytest.approx(0.5)
    with pytest.raises(KeyError, match="node 9"):
        g.coord(9)


def test_dataset_2411_alongside_frf_datasets(tmp_path: Path):
    ids = np.array([11, 12, 13])
    xyz = np.array([[0.0, 0.1, 0.0], [0.0, -0.1, 0.0], [0.05, 0.0, 0.2]])
    path = _write(tmp_path / "mixed.uff", [
        _frf58(11),
        pyuff.prepare_2411(node_nums=ids.tolist(), def_cs=[0] * 3, disp_cs=[0] * 3, color=[1] * 3,
                           x=xyz[:, 0].tolist(), y=xyz[:, 1].tolist(), z=xyz[:, 2].tolist()),
    ])
    g = read_geometry(path)
    np.testing.assert_array_equal(g.node_ids, ids)
    np.testing.assert_allclose(g.coords, xyz, rtol=1e-12)  # 2411 holds doubles
    assert g.lines == ()


def test_no_geometry_is_a_clear_error(tmp_path: Path):
    path = _write(tmp_path / "frf_only.uff", [_frf58(1)])
    with pytest.raises(UFFError, match=r"frf_only.uff: no node dataset \(15 or 2411\)"):
        read_geometry(path)
    with pytest.raises(UFFError, match="file not found"):
        read_geometry(tmp_path / "missing.uff")


def test_geometry_validation():
    with pytest.raises(ValueError, match="unique"):
        Geometry([1, 1], np.zeros((2, 3)))
    with pytest.raises(ValueError, match="not defined"):
        Geometry([1, 2], np.zeros((2, 3)), lines=[(1, 3)])
    with pytest.raises(ValueError, match="shape"):
        Geometry([1, 2], np.zeros((2, 2)))


# ------------------------------------------------------------------------- issue 17
def _grid15(ids: list[int], xyz: np.ndarray) -> dict:
    n = len(ids)
    return pyuff.prepare_15(node_nums=ids, def_cs=[0] * n, disp_cs=[0] * n, color=[1] * n,
                            x=xyz[:, 0].tolist(), y=xyz[:, 1].tolist(), z=xyz[:, 2].tolist())


def test_duplicate_missing_and_unmatched_nodes_reported(tmp_path: Path):
    from ema_rig.dof import DOF
    from ema_rig.io.geometry import match_notes

    xyz = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]])
    path = _write(tmp_path / "g.uff", [_grid15([1, 2, 3], xyz), _grid15([2], np.array([[5.0, 5, 5]]))])
    g = read_geometry(path)
    np.testing.assert_array_equal(g.node_ids, [1, 2, 3])  # order of first definition
    np.testing.assert_allclose(g.coord(2), [5, 5, 5], rtol=1e-6)  # the last definition wins
    notes = match_notes(g, [DOF(1, 2), DOF(2, 2), DOF(7, 2), DOF(8, -3)])
    text = " | ".join(notes)
    assert "1 duplicate node definition(s) of 1 node(s) (e.g. [2])" in text
    assert "2 response node(s) not in the geometry" in text and "[7, 8]" in text
    assert "1 of 3 geometry node(s) carry no measured DOF" in text
    assert match_notes(Geometry([1, 2], np.zeros((2, 3))), [DOF(1, 1), DOF(2, 1)]) == ()


def test_nan_coordinates_blamed_on_the_geometry_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]):
    from ema_rig.cli import main

    xyz = np.array([[0.0, 0, 0], [np.nan, 0, 0]])
    geo = _write(tmp_path / "geo.uff", [_grid15([1, 2], xyz)])
    with pytest.raises(UFFError, match=r"dataset 0: dataset 15: 1 node\(s\) with NaN or inf coordinates") as exc:
        read_geometry(geo)
    assert exc.value.file == str(geo)
    data = Path(__file__).resolve().parent.parent / "data"
    if not (data / "disk.uff").is_file():
        pytest.skip("bundled data absent")
    code = main(["modes", str(data / "disk.uff"), "--rig", str(data / "rig.toml"), "--geometry", str(geo),
                 "--shapes", str(tmp_path / "s")])
    err = capsys.readouterr().err
    assert code == 1 and err.startswith(f"error: {geo}: dataset 0:"), err  # not the FRF file
