"""A figure kept per worker and drawn again for the next measurement is the figure drawn anew."""

from __future__ import annotations

import io
import threading
from pathlib import Path

import numpy as np
import pytest
from _campaigns import simulated_6302_campaign

pytest.importorskip("PIL")

from PIL import Image  # noqa: E402

from ema_rig.campaign import load_campaign  # noqa: E402
from ema_rig.campaign.drilldown import measurement_figures  # noqa: E402


def _pixels(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def _in_new_thread(fn):
    """``fn()`` in a thread of its own: its own kept figures and canvases (none yet), as a new worker."""
    out: list = []
    t = threading.Thread(target=lambda: out.append(fn()))
    t.start()
    t.join()
    assert out, "the drawing thread failed"
    return out[0]


def test_a_reused_figure_draws_what_a_new_one_draws(tmp_path: Path, rig_toml_text: str) -> None:
    # two measurements far apart in k_TB (housing mode, limits, tick labels, titles all differ);
    # oracle: matplotlib drawing the second measurement on figures built for it alone
    d = simulated_6302_campaign(tmp_path, rig_toml_text, {"a300": 4.0e7, "b900": 9.0e7}, seed=41)
    cfg = load_campaign(d / "campaign.toml")
    first, second = cfg.measurements
    row = {"status": "ok"}

    def draw(m):
        return measurement_figures(m, row, cfg, k_ms=cfg.rig.model.k_MS, k_ms_std=None)

    reused = _in_new_thread(lambda: (draw(first), draw(second))[1])  # on the figures of the first
    fresh = _in_new_thread(lambda: draw(second))
    assert set(reused.png) == set(fresh.png) == {"stabilization", "model", "synthesis"}
    assert reused.warnings == fresh.warnings
    for kind in fresh.png:
        a, b = _pixels(reused.png[kind]), _pixels(fresh.png[kind])
        assert a.shape == b.shape, kind
        diff = np.abs(a - b).max(axis=2)
        # the same pixels (measured: identical, all three kinds); 2 levels of 255 leave room for
        # an anti-aliased edge rounded the other way. A leftover of the first measurement (a line,
        # a label, a legend entry, a limit, a tick) or a shifted panel changes hundreds of pixels
        # by far more
        assert (diff > 2).sum() == 0, (kind, int((diff > 2).sum()))
    # and the premise: the two measurements' figures differ
    first_only = _in_new_thread(lambda: draw(first))
    assert any((np.abs(_pixels(first_only.png[k]) - _pixels(fresh.png[k])) > 16).sum() > 1000 for k in fresh.png)
