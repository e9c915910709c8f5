"""Benchmark: the bundled demo with every figure, this tree against an older one, paired.

Each run is ``ema-rig demo -o <fresh dir> --jobs J`` in a fresh interpreter (what a user waits
for: imports, calibration, 19 measurements, the campaign figures, 57 per-measurement figures and
the HTML report), from the tree's own root with ``PYTHONPATH`` set to it. The two trees alternate
(new old, old new, ...) for each ``--jobs`` setting, so a busy period on the shared machine hits
both. Per run: the wall time, the CPU time of the run and its worker processes (``getrusage`` of
the children: unlike the wall time it hardly depends on what else runs on the machine), the
1-minute load average before the run, and the wall time of the output phase (``write_outputs``:
table, figures and report; with ``--jobs 2`` the measurement figures are drawn by the pool within
it) as a share of the run (it includes the identification each measurement's figures need),
and the time spent on the figures proper (building them, making their PNG bytes and, with a pool, the
figures' one-time work done before it forks (``warm_up``): CPU seconds summed over every process) as a share of the run's CPU time.
A measurement's figures drawn from the computation just made count as the whole call
(``measurement_figures(..., computed=...)``: its kept figures, views and the collector's pass over the
drawing's garbage when its pause ends, which the plot functions and ``png_bytes`` alone left to the
rest of the run); every function is timed under each module's name for it (the runner imports
``write_outputs`` and ``measurement_figures`` by name: the output phase read 0 s before). Reported: medians with min-max, and the median of the per-round
ratios new/old.

Run from the repository root::

    git worktree add /tmp/old5424261 5424261
    python benchmarks/bench_demo.py --old /tmp/old5424261 [--rounds 3] [--jobs 1 2] [--savefig-rounds 2]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# runs in the child: time write_outputs (the output phase) inside the demo command
_DRIVER = r"""
import functools, json, os, sys, threading, time
t0 = time.perf_counter()
import ema_rig.campaign.outputs as outputs
spent = []
_orig = outputs.write_outputs
@functools.wraps(_orig)
def timed(*a, **k):
    t = time.perf_counter()
    try:
        return _orig(*a, **k)
    finally:
        spent.append(time.perf_counter() - t)
def rebind(orig, new):
    # every module's name for the function (the runner imports write_outputs and measurement_figures by name)
    for mod in list(sys.modules.values()):
        if getattr(mod, "__name__", "").startswith("ema_rig"):
            for k, v in list(vars(mod).items()):
                if v is orig:
                    setattr(mod, k, new)
import ema_rig.campaign.runner  # noqa: F401 (bound its names)
rebind(_orig, timed)
# the figures proper: building a figure (the plot functions) and turning it into PNG bytes, the
# outermost call only, in every process (forked workers inherit the wrappers; each call appends
# its seconds to a file, as a pool worker never runs atexit)
import importlib
_log = sys.argv[3]
_depth = {"all": threading.local(), "parts": threading.local()}
def drawing(fn, given=None):
    # "all": what is counted; "parts": the plot functions and PNG bytes alone (the count before
    # measurement_figures was timed whole), for comparison with earlier results
    books = ("all",) if given is not None else ("all", "parts")
    # the original's name and module: pickled by reference (a pool task) it is the wrapper bound there
    @functools.wraps(fn)
    def wrapper(*a, **k):
        if given is not None and k.get(given) is None:  # not figures only: not counted as a whole
            return fn(*a, **k)
        outer = [b for b in books if getattr(_depth[b], "n", 0) == 0]
        for b in books:
            _depth[b].n = getattr(_depth[b], "n", 0) + 1
        t = time.process_time()  # CPU seconds of this process: a loaded machine does not count
        try:
            return fn(*a, **k)
        finally:
            dt = time.process_time() - t
            for b in books:
                _depth[b].n -= 1
            if outer:
                with open(_log, "a") as fh:
                    fh.write("".join(f"{b} {dt}\n" for b in outer))
    return wrapper
# a measurement's figures drawn from the computation just made (``computed=``): the whole call
# (kept figures, the views drawn, the collector's pass over the drawing's garbage as its pause ends);
# without it (an older tree, a reused row) it identifies first: only its figure functions count
for mod, name, given in [("ema_rig.plot.stabilization", "plot_stabilization", None),
                         ("ema_rig.plot.rig", "plot_rig_fit", None), ("ema_rig.plot.synthesis", "plot_synthesis", None),
                         ("ema_rig.plot.campaign", "campaign_figures", None), ("ema_rig.campaign.drilldown", "png_bytes", None),
                         ("ema_rig.plot._render", "render_png", None), ("ema_rig.plot._render", "warm_up", None),
                         ("ema_rig.campaign.drilldown", "measurement_figures", "computed")]:
    try:
        m = importlib.import_module(mod)
    except ImportError:  # the older tree has no renderer
        continue
    if hasattr(m, name):  # an older tree has no warm_up
        orig = getattr(m, name)
        rebind(orig, drawing(orig, given))
from matplotlib.figure import Figure
Figure.savefig = drawing(Figure.savefig)
from ema_rig.cli import main
code = main(["demo", "-o", sys.argv[1], "--jobs", sys.argv[2]])
print(json.dumps({"code": code, "inside": time.perf_counter() - t0, "outputs": sum(spent)}))
"""


# prepended to the driver for "this tree with savefig": matplotlib's savefig and an adaptive palette
# (the path before issue 22) in place of the renderer, the same figures
_SAVEFIG = r"""
import io
import ema_rig.plot._render as _render
def _savefig_png(fig, *, dpi, colors=128, optimize=True, reuse_layout=True):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    if colors is None:
        return buf.getvalue()
    from PIL import Image
    buf.seek(0)
    with Image.open(buf) as img:
        out = io.BytesIO()
        img.convert("RGB").quantize(colors=colors).save(out, format="PNG", optimize=True)
    return out.getvalue()
_render.render_png = _savefig_png
"""


def one_run(tree: Path, jobs: int, savefig: bool = False) -> dict[str, float]:
    env = {**os.environ, "PYTHONPATH": str(tree), "MPLBACKEND": "Agg"}
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        log = Path(tmp) / "drawing.txt"
        driver = (_SAVEFIG if savefig else "") + _DRIVER
        out = subprocess.run([sys.executable, "-c", driver, str(Path(tmp) / "demo"), str(jobs), str(log)], cwd=tree,
                             env=env, capture_output=True, text=True, check=False)
        if out.returncode != 0:
            raise RuntimeError(f"demo in {tree} failed ({out.returncode}): {out.stderr[-3000:]}")
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        n_png = len(list((Path(tmp) / "demo").rglob("*.png")))
        books = [line.split() for line in log.read_text().splitlines()] if log.exists() else []
        drawing = sum(float(t) for b, t in books if b == "all")
        parts = sum(float(t) for b, t in books if b == "parts")
    doc = json.loads(out.stdout.strip().splitlines()[-1])
    if doc["code"] != 0:
        raise RuntimeError(f"demo in {tree} exited with {doc['code']}: {out.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall": wall, "cpu": cpu, "load": load, "outputs": doc["outputs"], "share": doc["outputs"] / wall,
            "png": n_png, "drawing": drawing, "draw_share": drawing / cpu, "parts_share": parts / cpu}


def spread(xs: list[float], fmt: str = "{:.1f}") -> str:
    return f"{fmt.format(statistics.median(xs))} ({fmt.format(min(xs))}-{fmt.format(max(xs))})"


def main() -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--old", type=Path, required=True, help="root of the older tree (a git worktree)")
    ap.add_argument("--rounds", type=int, default=3, help="pairs per --jobs setting (default 3)")
    ap.add_argument("--jobs", type=int, nargs="*", default=[1, 2], help="--jobs settings (none: only --savefig-rounds)")
    ap.add_argument("--savefig-rounds", type=int, default=0,
                    help="also pair this tree against itself with savefig in place of the renderer (--jobs 1)")
    args = ap.parse_args()
    trees = {"new": ROOT, "old": args.old.resolve()}
    head = {k: subprocess.run(["git", "-C", str(t), "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True).stdout.strip() for k, t in trees.items()}
    print(f"bundled demo, paired: new = {ROOT} ({head['new']}), old = {trees['old']} ({head['old']}) - "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} CPUs")
    for jobs in args.jobs:
        runs: dict[str, list[dict[str, float]]] = {"new": [], "old": []}
        for i in range(args.rounds):
            for name in (("new", "old") if i % 2 == 0 else ("old", "new")):
                r = one_run(trees[name], jobs)
                runs[name].append(r)
                print(f"  jobs {jobs} round {i + 1} {name}: wall {r['wall']:.1f} s, cpu {r['cpu']:.1f} s, "
                      f"outputs {r['outputs']:.1f} s ({r['share']:.0%}), figures {r['drawing']:.1f} s "
                      f"({r['draw_share']:.0%} of cpu; plot functions and PNG bytes alone {r['parts_share']:.0%}), "
                      f"load {r['load']:.1f}, {r['png']:.0f} PNG",
                      flush=True)
        n, o = runs["new"], runs["old"]
        ratio = [a["wall"] / b["wall"] for a, b in zip(n, o, strict=True)]
        cpu_ratio = [a["cpu"] / b["cpu"] for a, b in zip(n, o, strict=True)]
        loads = [r["load"] for r in n + o]
        print(f"jobs {jobs}: wall new {spread([r['wall'] for r in n])} s, old {spread([r['wall'] for r in o])} s, "
              f"new/old {spread(ratio, '{:.2f}')}; CPU new {spread([r['cpu'] for r in n])} s, "
              f"old {spread([r['cpu'] for r in o])} s, new/old {spread(cpu_ratio, '{:.2f}')}; output phase "
              f"new {spread([100 * r['share'] for r in n], '{:.0f}')} %, old {spread([100 * r['share'] for r in o], '{:.0f}')} % "
              f"of the run; figures (building + PNG, all processes) new {spread([100 * r['draw_share'] for r in n], '{:.0f}')} %, "
              f"old {spread([100 * r['draw_share'] for r in o], '{:.0f}')} % of the CPU time (plot functions and PNG "
              f"bytes alone: new {spread([100 * r['parts_share'] for r in n], '{:.0f}')} %, "
              f"old {spread([100 * r['parts_share'] for r in o], '{:.0f}')} %); load {min(loads):.1f}-{max(loads):.1f}",
              flush=True)
    if args.savefig_rounds:
        runs = {"render": [], "savefig": []}
        for i in range(args.savefig_rounds):
            for name in (("render", "savefig") if i % 2 == 0 else ("savefig", "render")):
                r = one_run(ROOT, 1, savefig=name == "savefig")
                runs[name].append(r)
                print(f"  this tree, jobs 1, {name}: wall {r['wall']:.1f} s, cpu {r['cpu']:.1f} s, figures "
                      f"{r['drawing']:.1f} s ({r['draw_share']:.0%} of cpu), load {r['load']:.1f}", flush=True)
        fig_ratio = [a["drawing"] / b["drawing"] for a, b in zip(runs["render"], runs["savefig"], strict=True)]
        print(f"this tree, renderer vs savefig: figures CPU {spread([r['drawing'] for r in runs['render']])} s vs "
              f"{spread([r['drawing'] for r in runs['savefig']])} s, ratio {spread(fig_ratio, '{:.2f}')}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
