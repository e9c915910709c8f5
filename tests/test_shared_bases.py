"""Work ``identify`` hands from one stage to the next gives the same numbers as forming it again.

* The judgement's last LSFD fit (:func:`~ema_rig.identification.judge.judge_clusters` with ``basis_out``)
  is of the accepted modes' PolyMAX poles: the LSFD at those poles in ``_fit_modes`` takes over its basis
  and SVD factor instead of forming them again.
* With the basis come the judgement's unknowns (its fit of the same FRFs): that LSFD takes them over too.
* The model's pole columns on every line, formed once for its completeness test (``_pole_columns``), are
  those :func:`~ema_rig.identification.noise.segment_misfit` forms itself.

Oracle: the same fit or test formed from scratch (no basis, no columns handed in), compared to the bit
(tolerance 0: the hand-over must not change an answer). Data: the bundled rig file at 150-1000 Hz (the
file of issue 18's timing point).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import ema_rig.identification.identification as idm
from ema_rig.config import load_rig
from ema_rig.identification import identify
from ema_rig.identification.criteria import COMPLETENESS_CRITERIA
from ema_rig.identification.lsfd import LsfdBasis, _lsfd_checked
from ema_rig.identification.plscf import check_data
from ema_rig.io.uff import read_uff58

REPO = Path(__file__).resolve().parent.parent
BAND = (150.0, 1000.0)


@pytest.fixture(scope="module")
def rig() -> Any:
    return read_uff58(REPO / "data" / "b6302_1000N_1200rpm.uff", rig=load_rig(REPO / "data" / "rig.toml"))


def test_judge_basis_taken_over_same_numbers(rig: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    handed: list[tuple[LsfdBasis, Any, Any]] = []
    frfs: list[Any] = []

    def spy(data: Any, poles: Any, **kw: Any) -> Any:
        out = _lsfd_checked(data, poles, **kw)
        if kw.get("basis") is not None:
            handed.append((kw["basis"], out, _lsfd_checked(data, poles, residuals=kw.get("residuals", True))))
            frfs.append(data.frf)
        return out

    monkeypatch.setattr(idm, "_lsfd_checked", spy)
    identify(rig, band=BAND)
    assert handed, "the judgement's basis was not handed to the LSFD at the accepted modes"
    basis, out, fresh = handed[0]
    assert np.array_equal(basis.poles, out.poles)  # it is the basis of these poles: it was used
    assert basis.unknowns is not None and basis.frf is frfs[0]  # with the judgement's unknowns of these FRFs
    for _, got, oracle in handed:
        for name in ("poles", "residues", "lower_residual", "upper_residual", "fit_error"):
            assert np.array_equal(getattr(got, name), getattr(oracle, name)), name


def test_pole_columns_same_test(rig: Any) -> None:
    data = check_data(rig, BAND)
    lam = identify(rig, band=BAND).modes.poles
    cols = idm._pole_columns(data, lam)
    assert cols is not None and cols.shape == (data.n_freq, 2 * lam.size)
    got = idm._misfit_at(data, lam, COMPLETENESS_CRITERIA, cols)
    oracle = idm._misfit_at(data, lam, COMPLETENESS_CRITERIA)
    for name in ("freq_lower", "freq_upper", "ratio", "worst_ratio", "p_value", "dof", "failed", "edge", "variance"):
        assert np.array_equal(getattr(got, name), getattr(oracle, name)), name
    assert idm._pole_columns(data, lam[:0]) is None
