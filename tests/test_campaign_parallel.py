"""--jobs 2 with the report: the pool also draws the per-measurement figures; same outputs as --jobs 1."""

from __future__ import annotations

from pathlib import Path

import pytest
from _campaigns import simulated_6302_campaign

from ema_rig.campaign import run


@pytest.fixture(scope="module")
def campaign_dir(tmp_path_factory: pytest.TempPathFactory, rig_toml_text: str) -> Path:
    """Two simulated 6302 measurements with the per-measurement figures on (the default)."""
    return simulated_6302_campaign(tmp_path_factory.mktemp("par"), rig_toml_text, {"p400": 6.1e7, "p800": 6.8e7},
                                   seed=50)


def test_jobs_2_outputs_match_jobs_1(campaign_dir: Path, tmp_path: Path) -> None:
    serial = run(campaign_dir / "campaign.toml", out_dir=tmp_path / "j1", jobs=1)
    par = run(campaign_dir / "campaign.toml", out_dir=tmp_path / "j2", jobs=2)
    assert [r["k_TB"] for r in par.rows] == [r["k_TB"] for r in serial.rows]  # the same bits
    assert sorted(par.files) == sorted(serial.files)
    drawn = sorted(k for k in par.files if "/" in k)  # "<id>/<kind>": drawn by the pool's workers
    assert len(drawn) >= 4, drawn  # two measurements, at least two figures each
    for k in drawn:
        # the same drawing in another process: the same PNG
        assert par.files[k].read_bytes() == serial.files[k].read_bytes(), k
    # the report embeds them all: the same length (it also carries the run's date and times)
    html1 = (tmp_path / "j1" / "report.html").read_text()
    html2 = (tmp_path / "j2" / "report.html").read_text()
    assert html2.count("data:image/png;base64,") == html1.count("data:image/png;base64,") >= len(drawn)


@pytest.mark.usefixtures("mpl_texts_on_whole_pixels")  # savefig: texts at whole pixels, as drawn
def test_a_pool_draws_every_other_campaign_figure(campaign_dir: Path, tmp_path: Path) -> None:
    # write_outputs with an idle pool: one task, the 2nd, 4th ... campaign figure, drawn in its
    # worker (a thread here: its own canvases, as a forked worker); every figure written once
    import io
    from concurrent.futures import ThreadPoolExecutor

    import numpy as np
    from PIL import Image

    from ema_rig.campaign.outputs import _campaign_pngs, write_outputs
    from ema_rig.plot.campaign import campaign_figure_names, campaign_figures

    result = run(campaign_dir / "campaign.toml", out_dir=tmp_path / "a", jobs=1)
    names = campaign_figure_names(result)
    assert len(names) >= 2, names  # the premise: there is a share for the pool
    tasks: list = []

    class Recording(ThreadPoolExecutor):
        def submit(self, fn, /, *args, **kwargs):  # type: ignore[no-untyped-def, override]
            tasks.append((fn, args[1:]))
            return super().submit(fn, *args, **kwargs)

    with Recording(1) as pool:
        files = write_outputs(result, tmp_path / "b", executor=pool)
    assert tasks == [(_campaign_pngs, (names[1::2],))]
    built = campaign_figures(result)
    assert sorted(k for k in files if k in names) == sorted(built) == sorted(k for k in result.files if k in names)
    for name, fig in built.items():
        # oracle: matplotlib's own savefig of the figure built anew (measured: identical, both
        # figures); 2 levels of 255 leave room for an anti-aliased edge rounded the other way. A
        # figure drawn with another's data, or a layout of another figure, changes far more
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=120)
        want = np.asarray(Image.open(buf).convert("RGB")).astype(int)
        got = np.asarray(Image.open(files[name]).convert("RGB")).astype(int)
        assert got.shape == want.shape, name
        diff = np.abs(got - want).max(axis=2)
        assert (diff > 2).sum() == 0, (name, int((diff > 2).sum()))
