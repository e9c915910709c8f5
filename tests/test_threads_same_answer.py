"""Issue 18 (speed of the default identify): work handed to a second thread gives the one-thread answer.

The local ML hands a segment's scores, covariances and whole-basis fit to a second thread while the
next segment is fitted, and the completeness test fits its segments in two threads. Oracle: the
same call with those threads switched off (their work-size thresholds raised above the data), to
the bit, so neither the load nor the scheduling of the threads changes a result (the contract of
``test_same_answer_any_load``, here checked stage by stage on data large enough to use the threads).
"""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from ema_rig.frf import FRFData


def _frf(n_out: int, seed: int) -> tuple[FRFData, np.ndarray, np.ndarray]:
    """Three modes (one pair 2 % apart), accelerance, 1 % proportional noise: data, true poles,
    noise-free FRFs."""
    rng = np.random.default_rng(seed)
    fn = np.array([210.0, 320.0, 326.4])
    zeta = np.array([0.012, 0.015, 0.01])
    lam = 2 * np.pi * fn * (-zeta + 1j * np.sqrt(1 - zeta**2))
    freq = np.arange(150.0, 450.0 + 0.25, 0.25)
    jw = 2j * np.pi * freq
    phi = rng.uniform(-1.0, 1.0, (fn.size, n_out))
    h = np.zeros((n_out, 1, freq.size), complex)
    for r in range(fn.size):
        res = phi[r] * phi[r, 0] / (2j * lam[r].imag)
        h[:, 0] += res[:, None] / (jw - lam[r]) + np.conj(res)[:, None] / (jw - lam[r].conj())
    h *= jw**2
    clean = h.copy()
    h = h + 0.01 * np.abs(h) * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)) / np.sqrt(2)
    dofs = [f"{i + 1}+Y" for i in range(n_out)]
    return FRFData(freq, h, dofs, [dofs[0]]), lam, clean


def _same(a: object, b: object) -> bool:
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.shape == b.shape and np.array_equal(a, b, equal_nan=True)
    return a == b


def test_segment_misfit_in_two_threads_is_the_one_thread_test(monkeypatch: pytest.MonkeyPatch):
    import ema_rig.identification.noise as noise

    data, lam, _ = _frf(96, 3)
    # the threads are used: the data hold more values than the threshold (off by default: set here)
    monkeypatch.setattr(noise, "_MISFIT_THREAD_MIN_VALUES", 100_000)
    assert data.frf.size >= noise._MISFIT_THREAD_MIN_VALUES
    two = noise.segment_misfit(data.freq, data.frf, lam)
    assert two.freq_lower.size >= 4  # several segments to share between the threads
    monkeypatch.setattr(noise, "_MISFIT_THREAD_MIN_VALUES", 10**12)
    one = noise.segment_misfit(data.freq, data.frf, lam)
    for name in ("freq_lower", "freq_upper", "ratio", "worst_ratio", "p_value", "dof", "failed", "edge", "variance"):
        assert _same(getattr(two, name), getattr(one, name)), name


def test_local_ml_with_a_second_thread_is_the_one_thread_estimate(monkeypatch: pytest.MonkeyPatch):
    import ema_rig.identification.ml as ml
    from ema_rig.identification.lsfd import lsfd

    data, lam, _ = _frf(48, 4)
    rng = np.random.default_rng(7)
    start = lam * (1.0 + 2e-3 * (rng.standard_normal(lam.size) + 1j * rng.standard_normal(lam.size)))
    model = lsfd(data, start).synthesize(data.freq).frf  # the start model, as identify passes it
    # every segment's tasks to the second thread (threshold 1 equation), then none (threshold above the data)
    monkeypatch.setattr(ml, "_THREAD_MIN_EQUATIONS", 1)
    two = ml.local_ml(data, start, model)
    monkeypatch.setattr(ml, "_THREAD_MIN_EQUATIONS", 10**12)
    one = ml.local_ml(data, start, model)
    assert "ml" in one.kind and np.all(np.isfinite(one.natural_freq_std))
    # both tasks ran: the segments' scores and their whole-basis fits (a model-form part > 0)
    assert one.basis_std is not None and np.any(one.basis_std > 0)
    for name in ("poles", "pole_cov", "natural_freq_std", "damping_ratio_std", "kind", "chi2_red", "warnings",
                 "n_eval", "robust_std", "fisher_std", "basis_std"):
        assert _same(getattr(two, name), getattr(one, name)), name


def test_a_job_the_second_thread_has_not_started_runs_in_the_caller():
    from ema_rig._threads import Job

    gate = threading.Event()
    with ThreadPoolExecutor(1) as pool:
        pool.submit(gate.wait, 10.0)  # the one worker is busy: the job stays queued
        job = Job(threading.get_ident, pool)
        assert job.result() == threading.get_ident()  # taken back and run here
        assert job.result() == threading.get_ident()  # once: the same value again
        gate.set()
    with ThreadPoolExecutor(1) as pool:
        job = Job(threading.get_ident, pool)
        pool.shutdown(wait=True)  # the worker has run it
        assert job.result() != threading.get_ident()
    assert Job(threading.get_ident, None).result() == threading.get_ident()  # no pool: run at once


def test_identify_with_its_second_threads_is_the_one_thread_identification(monkeypatch: pytest.MonkeyPatch):
    """identify runs the LSFD at the ML poles and the completeness test in a second thread while the
    caller joins the ML's scores, covariances and whole-basis fits (themselves in the ML's second
    thread here: thresholds 1 equation, 1 value). Oracle: the same call with every task run by the caller, in
    the order it is joined (no pool; the thresholds above the data), to the bit."""
    import ema_rig._threads as threads
    import ema_rig.identification.identification as idm
    import ema_rig.identification.ml as ml
    import ema_rig.identification.noise as noise
    from ema_rig.identification import identify

    data, _, _ = _frf(8, 5)
    monkeypatch.setattr(ml, "_THREAD_MIN_EQUATIONS", 1)
    monkeypatch.setattr(idm, "_AT_POLES_THREAD_MIN_VALUES", 1)
    two = identify(data)
    # the ML's model-form part ran (its whole-basis fit), so both of its deferred tasks are compared
    assert two.residual_test is not None and two.natural_freq.size == 3
    monkeypatch.setattr(ml, "_THREAD_MIN_EQUATIONS", 10**12)
    monkeypatch.setattr(noise, "_MISFIT_THREAD_MIN_VALUES", 10**12)
    monkeypatch.setattr(noise, "_NOISE_THREADS", 1)

    def here(task, pool, *, later=False):  # type: ignore[no-untyped-def]
        return threads.Job(task, None, later=later)

    monkeypatch.setattr(idm, "Job", here)
    one = identify(data)
    for name in ("natural_freq_std", "damping_ratio_std", "natural_freq_spread", "damping_ratio_spread", "std_kind",
                 "warnings", "notes"):
        assert _same(getattr(two, name), getattr(one, name)), name
    for name in ("poles", "residues", "lower_residual", "upper_residual", "fit_error"):
        assert _same(getattr(two.modes, name), getattr(one.modes, name)), name
    for name in ("ratio", "p_value", "failed", "variance"):
        assert _same(getattr(two.residual_test, name), getattr(one.residual_test, name)), name


@pytest.mark.parametrize("threshold", [1, 10**12])
def test_the_completeness_test_formed_beside_the_lsfd_is_the_test_of_the_fitted_model(
        monkeypatch: pytest.MonkeyPatch, threshold: int):
    """_fit_modes forms the completeness test from the ML poles alone (in the order the LSFD model will
    hold them) while the LSFD at those poles is fitted in the other thread, or by the caller (threshold
    1: both tasks handed to a second thread; above the data: run by the caller). Oracle: the definition,
    the test of the fitted model (:func:`_misfit` of the LSFD model at the ML poles), to the bit; the
    returned model is the LSFD at the ML poles (not at the PolyMAX start)."""
    import ema_rig.identification.identification as idm
    from ema_rig.identification.criteria import COMPLETENESS_CRITERIA
    from ema_rig.identification.lsfd import lsfd, model_order
    from ema_rig.identification.stabilization import SelectedMode

    data, lam, _ = _frf(8, 5)
    rng = np.random.default_rng(11)
    start = lam * (1.0 + 2e-3 * (rng.standard_normal(lam.size) + 1j * rng.standard_normal(lam.size)))
    # the start poles in an order that is not |pole|'s: the model (and the test) hold them sorted
    modes = [SelectedMode(order=40, index=0, pole=complex(p), natural_freq=abs(p) / (2 * np.pi),
                          damping_ratio=-p.real / abs(p), natural_freq_std=0.01, damping_ratio_std=1e-4, n_poles=20,
                          participation=(1 + 0j,)) for p in start[::-1]]
    monkeypatch.setattr(idm, "_AT_POLES_THREAD_MIN_VALUES", threshold)
    (model, ml, *_), test = idm._fit_tested(data, modes, True, COMPLETENESS_CRITERIA)
    assert np.any(ml.poles != model_order(start)) and "ml" in ml.kind  # the ML moved the poles
    fitted = lsfd(data, ml.poles)
    oracle = idm._misfit(data, fitted, COMPLETENESS_CRITERIA)
    assert _same(model.poles, fitted.poles) and _same(model.residues, fitted.residues)
    for name in ("freq_lower", "freq_upper", "ratio", "worst_ratio", "p_value", "dof", "failed", "edge", "variance"):
        assert _same(getattr(test, name), getattr(oracle, name)), name


def test_model_order_is_the_order_of_the_lsfd_models_poles():
    """The poles a task takes before the LSFD fit (``model_order``, ``_model_poles``) are the fitted model's,
    element by element, for poles given in any order (oracle: ``lsfd``'s model)."""
    from ema_rig.identification.identification import _lsfd_at, _model_poles
    from ema_rig.identification.lsfd import lsfd, model_order

    data, lam, _ = _frf(4, 6)
    start = lsfd(data, lam)
    for order in ([2, 0, 1], [1, 2, 0], [0, 1, 2]):
        assert _same(model_order(lam[order]), lsfd(data, lam[order]).poles), order
        moved = lam[order] * (1.0 + 1e-4j)
        assert _same(_model_poles(start, moved), _lsfd_at(data, start, None, moved, True)[0].poles), order
    assert _model_poles(start, start.poles) is start.poles  # the start model's own poles: no fit
