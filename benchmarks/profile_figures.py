"""Profile: CPU time per report figure kind, building (the plot function) and rendering (PNG bytes).

The bundled demo's first ``--warm + --n`` measurements are computed once (as the campaign's
worker computes them, k_MS from the rig file); the figures of the first ``--warm`` are drawn to
warm the caches a campaign's worker has after a few measurements (kept figures, layouts, glyphs),
then those of the next ``--n`` (not drawn before) are timed: CPU milliseconds per figure, by kind.
With ``--profile KIND`` the rendering of that kind is also profiled (cumulative, top 40).

Run from a tree's root (this one, or an older worktree to compare)::

    PYTHONPATH=$PWD MPLBACKEND=Agg python benchmarks/profile_figures.py [--warm 2] [--n 6] [--profile synthesis]
"""

from __future__ import annotations

import argparse
import collections
import cProfile
import pstats
import sys
import time
from typing import Any


def main() -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--warm", type=int, default=2, help="measurements drawn first, not timed (default 2)")
    ap.add_argument("--n", type=int, default=6, help="measurements timed (default 6)")
    ap.add_argument("--profile", choices=["stabilization", "model", "synthesis"], help="profile this kind's rendering")
    args = ap.parse_args()

    import ema_rig.plot.rig as rig_plot
    import ema_rig.plot.stabilization as stab_plot
    import ema_rig.plot.synthesis as syn_plot
    from ema_rig.campaign import MeasurementTask, drilldown, load_campaign, runner

    cfg = load_campaign("data/campaign.toml")
    computed = []
    for m in cfg.measurements[: args.warm + args.n]:
        task = MeasurementTask(kind="measurement", file=m.file, rig=cfg.rig, k_ms=cfg.rig.model.k_MS, k_ms_std=None,
                               speed_hz=m.speed / 60.0 if m.speed > 0 else None, band=cfg.band,
                               max_order=cfg.max_order, selection=None)
        row, comp = runner._process(task)
        if comp is not None:
            computed.append((m, row, comp))
    spent: dict[tuple[str, str], float] = collections.defaultdict(float)
    current = {"kind": ""}
    prof = cProfile.Profile()
    timing = {"on": False}

    def timed(module: Any, name: str, kind: str) -> None:
        fn = getattr(module, name)

        def wrapper(*a: Any, **k: Any) -> Any:
            current["kind"] = kind
            t = time.process_time()
            try:
                return fn(*a, **k)
            finally:
                spent[(kind, "build")] += time.process_time() - t

        setattr(module, name, wrapper)

    timed(stab_plot, "plot_stabilization", "stabilization")
    timed(rig_plot, "plot_rig_fit", "model")
    timed(syn_plot, "plot_synthesis", "synthesis")
    png = drilldown.png_bytes

    def png_timed(fig: Any, dpi: int = drilldown.DPI) -> bytes:
        on = timing["on"] and current["kind"] == args.profile
        t = time.process_time()
        if on:
            prof.enable()
        try:
            return png(fig, dpi)
        finally:
            if on:
                prof.disable()
            spent[(current["kind"], "render")] += time.process_time() - t

    drilldown.png_bytes = png_timed  # type: ignore[assignment]

    def draw(items: list[Any]) -> None:
        for m, row, comp in items:
            drilldown.measurement_figures(m, row, cfg, k_ms=cfg.rig.model.k_MS, k_ms_std=None, computed=comp)

    draw(computed[: args.warm])
    spent.clear()
    timing["on"] = True
    timed_items = computed[args.warm:]
    draw(timed_items)
    n = max(len(timed_items), 1)
    total = 0.0
    print(f"CPU ms per figure over {len(timed_items)} measurements not drawn before ({args.warm} drawn first):")
    for kind in ("stabilization", "model", "synthesis"):
        b, r = 1000 * spent[(kind, "build")] / n, 1000 * spent[(kind, "render")] / n
        total += b + r
        print(f"  {kind:14s} build {b:5.0f}, render {r:5.0f}, total {b + r:5.0f}")
    print(f"  per measurement (3 figures): {total:.0f} ms")
    if args.profile:
        pstats.Stats(prof, stream=sys.stdout).sort_stats("cumulative").print_stats(40)
    return 0


if __name__ == "__main__":
    sys.exit(main())
