"""Every figure the README shows, made from the bundled data in ``data/`` (headless).

One script, so the committed images always match the bundled campaign and today's code; CI runs it
into a temporary folder. Figure titles carry file names, never a path.

Writes into ``--out`` (default ``examples/figures``):

- ``validation_dummy.png``, ``k_vs_load_6302.png``, ``rotating_vs_static_6302.png``,
  ``speed_6302.png``: the campaign figures of ``data/campaign.toml``;
- ``stabilization_chart.png``, ``fig7_frf_vs_model.png``, ``synthesis_overlay.png``: one
  measurement of it, ``data/b6302_1000N_1200rpm.uff``, with the campaign's calibrated k_MS.

Run::

    python examples/make_readme_figures.py [--out examples/figures]
"""

from __future__ import annotations

import argparse
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
#: The measurement of the single-file figures (a 6302 at 1 kN and 1200 rpm).
MEASUREMENT = "b6302_1000N_1200rpm"
#: The campaign figures the README shows or names.
CAMPAIGN_FIGURES = ("validation_dummy", "k_vs_load_6302", "rotating_vs_static_6302", "speed_6302")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(REPO / "examples" / "figures"), help="output folder")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    from ema_rig.campaign import load_campaign, run
    from ema_rig.io.uff import read_uff58
    from ema_rig.plot.campaign import campaign_figures
    from ema_rig.plot.rig import plot_rig_fit, save_figure
    from ema_rig.plot.stabilization import plot_stabilization
    from ema_rig.plot.synthesis import plot_synthesis
    from ema_rig.rig.stiffness import estimate_stiffness

    cfg = load_campaign(REPO / "data" / "campaign.toml")
    result = run(cfg, report=False)  # no output folder: the rows only
    figs = campaign_figures(result)
    missing = [n for n in CAMPAIGN_FIGURES if n not in figs]
    if missing:
        raise SystemExit(f"the bundled campaign no longer gives {', '.join(missing)}")
    written = []
    for name in CAMPAIGN_FIGURES:
        save_figure(figs[name], out / f"{name}.png", dpi=110)
        written.append(name)

    m = next(x for x in cfg.measurements if x.id == MEASUREMENT)
    data = read_uff58(m.file, rig=cfg.rig).with_meta(file=m.file.name)  # the name only, never a path
    res = estimate_stiffness(data, cfg.rig, k_ms=result.k_MS, k_ms_std=result.k_MS_std, speed_hz=m.speed / 60.0,
                             band=cfg.band, max_order=cfg.max_order)
    ident = res.identification
    lo, hi = ident.band
    chart = plot_stabilization(ident.stabilization, data.band(lo - 50.0, hi + 50.0), selection=ident.selection,
                               title=f"{m.file.name}: PolyMAX {lo:.0f}-{hi:.0f} Hz, {data.n_out} outputs")
    save_figure(chart.figure, out / "stabilization_chart.png", dpi=110)
    save_figure(plot_rig_fit(data, res, cfg.rig).figure, out / "fig7_frf_vs_model.png", dpi=110)
    syn = plot_synthesis(data, ident.modes, max_channels=8,
                         title=f"{m.file.name}: measured vs synthesised FRFs, {lo:.0f}-{hi:.0f} Hz")
    save_figure(syn.figure, out / "synthesis_overlay.png", dpi=110)
    written += ["stabilization_chart", "fig7_frf_vs_model", "synthesis_overlay"]
    print(f"{MEASUREMENT}: housing mode {res.housing_mode['natural_freq']:.2f} Hz, "
          f"k_TB = {res.k_TB / 1e6:.2f} ± {res.k_TB_std / 1e6:.2f} MN/m")
    for name in written:
        print(f"wrote {out / (name + '.png')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
