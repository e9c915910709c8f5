"""``ema_rig._blas.single_threaded``: one BLAS thread inside, the previous setting after, nesting free."""

from __future__ import annotations

import threading

from threadpoolctl import threadpool_info

from ema_rig import _blas


def _blas_threads() -> set[int]:
    return {int(i["num_threads"]) for i in threadpool_info() if i["user_api"] == "blas"}


def test_nested_blocks_keep_one_thread_and_set_it_once(monkeypatch):
    controller = _blas._controller()
    calls = []

    def counted():
        calls.append(1)
        return controller

    monkeypatch.setattr(_blas, "_controller", counted)
    before = _blas_threads()
    with _blas.single_threaded():
        assert _blas_threads() <= {1}
        with _blas.single_threaded():
            assert _blas_threads() <= {1}
        assert _blas_threads() <= {1}  # the inner block did not restore the outer's starting state
    assert _blas_threads() == before
    assert len(calls) == 1  # only the outer block went through threadpoolctl


def test_a_block_in_another_thread_sets_its_own_limit(monkeypatch):
    controller = _blas._controller()
    calls = []

    def counted():
        calls.append(threading.get_ident())
        return controller

    monkeypatch.setattr(_blas, "_controller", counted)

    def work():
        with _blas.single_threaded():
            pass

    with _blas.single_threaded():
        t = threading.Thread(target=work)
        t.start()
        t.join()
    # the worker thread's block is not nested in the main thread's: it sets (and restores) the
    # limit itself
    assert len(calls) == 2 and len(set(calls)) == 2
