"""A campaign killed with ``kill -9`` again and again, resumed: same results as a clean run.

Run from the repository root::

    python benchmarks/bench_kill_resume.py [--n 200] [--kills 10] [--jobs 2] [--keep DIR]

What it does (issue 17, "Must show"):

1. Writes ``n`` simulated 6302 measurements (ema_rig's own simulator: 150-1200 Hz every 2 Hz,
   no extra modes, max order 16, so that each one is cheap) and a steel-disk calibration, with
   the per-measurement figures of the report on (the figure phase is most of a run).
2. A clean run: ``ema-rig campaign C -o clean --jobs 2``.
3. A run killed ``kills`` times: ``ema-rig campaign C -o killed --jobs 2`` is started, and its
   parent process gets SIGKILL once the run has written ``step`` new files since its start
   (results, then figures: progress, not a clock, decides when), then it is started again; half
   the kills land in the measurement phase, half in the figure phase. After every kill it checks:
   the pool workers the parent had are gone within 5 s (no orphan), every output file there is
   complete (each JSON parses, each PNG decodes, the CSV parses; an unfinished temporary file may
   stay until the next run removes it), and no figure finished before the kill is written again
   later (same inode and mtime to the end).
4. The last start runs to the end; then the table is compared with the clean run's (every
   numeric column with rtol 1e-9: the same code on the same data, only the order of the runs
   differs), the status and error columns exactly, and the set of figures.

Prints one line per kill and a summary; exit code 0 when every check passed.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
TEMP = re.compile(r"^\..+\.[A-Za-z0-9_]{8}\.tmp(\.[^.]*)?$")


def make_campaign(d: Path, n: int) -> Path:
    """``n`` cheap simulated measurements (k_TB 50-90 MN/m, loads 100-2000 N) and a disk."""
    import numpy as np

    sys.path.insert(0, str(REPO))
    from ema_rig.config import load_rig
    from ema_rig.simulate import simulate_measurement, write_measurement

    rig_text = (REPO / "data" / "rig.toml").read_text(encoding="utf-8")
    (d / "rig.toml").write_text(rig_text, encoding="utf-8")
    rig = load_rig(d / "rig.toml")
    freq = np.arange(150.0, 1200.0, 2.0)
    write_measurement(simulate_measurement(rig, k_tb=math.inf, freq=freq, noise=0.002, seed=1, extra_modes=False),
                      d / "disk.uff", rig=rig)
    lines = ['rig = "rig.toml"', 'calibration = "disk.uff"', "[defaults]", "max_order = 16"]
    for i in range(n):
        k = 5.0e7 + 4.0e7 * i / max(n - 1, 1)
        sim = simulate_measurement(rig, k_tb=k, freq=freq, noise=0.002, seed=10 + i, extra_modes=False,
                                   speed_hz=10.0)
        write_measurement(sim, d / f"m{i:03d}.uff", rig=rig)
        lines += ["[[measurement]]", f'file = "m{i:03d}.uff"', f'id = "m{i:03d}"', "bearing = '6302'",
                  f"radial_load = {100.0 + 1900.0 * (i % 20) / 19:.1f}", "speed = 600.0"]
    (d / "campaign.toml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return d / "campaign.toml"


def _cmd(campaign: Path, out: Path, jobs: int) -> list[str]:
    return [sys.executable, "-m", "ema_rig.cli", "campaign", str(campaign), "-o", str(out), "--jobs", str(jobs)]


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(REPO), "MPLBACKEND": "Agg"}


def _children(pid: int) -> list[int]:
    kids = []
    for p in Path("/proc").iterdir():
        if p.name.isdigit():
            try:
                ppid = int((p / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            if ppid == pid:
                kids.append(int(p.name))
    return kids


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state not in ("Z", "X")


def _files(out: Path) -> dict[str, tuple[int, int]]:
    """Output files (no temporaries, no lock) -> (inode, mtime_ns)."""
    got = {}
    for p in out.rglob("*"):
        if p.is_file() and not TEMP.match(p.name) and p.name != ".ema-rig.lock":
            st = p.stat()
            got[str(p.relative_to(out))] = (st.st_ino, st.st_mtime_ns)
    return got


def _complete(out: Path) -> list[str]:
    """Output files that are not complete (a JSON that does not parse, a PNG that does not decode)."""
    from PIL import Image

    bad = []
    for rel in _files(out):
        p = out / rel
        try:
            if p.suffix == ".json":
                json.loads(p.read_text(encoding="utf-8"))
            elif p.suffix == ".png":
                with Image.open(p) as img:
                    img.load()
            elif p.suffix == ".csv":
                list(csv.DictReader(p.read_text(encoding="utf-8").splitlines()))
            elif p.suffix == ".html":
                if not p.read_text(encoding="utf-8").rstrip().endswith("</html>"):
                    bad.append(rel)
        except Exception as exc:  # noqa: BLE001 - any failure to read is a half-written file
            bad.append(f"{rel} ({type(exc).__name__})")
    return bad


def _progress(out: Path) -> int:
    n = 0
    for sub in ("results", "measurements"):
        d = out / sub
        if d.is_dir():
            n += sum(1 for p in d.iterdir() if not TEMP.match(p.name))
    return n


def killed_run(campaign: Path, out: Path, jobs: int, kills: int, n: int) -> dict:
    """Start, kill -9 at progress steps, restart; the last start runs to the end."""
    step = max(2, (n * 4) // (kills + 1))  # a result and 3 figures per measurement, spread over the kills
    finished: dict[str, tuple[int, int]] = {}
    rewritten: set[str] = set()
    log = []
    for k in range(kills + 1):
        start_files = _progress(out)
        t0 = time.perf_counter()
        proc = subprocess.Popen(_cmd(campaign, out, jobs), env=_env(), stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE, text=True)
        if k == kills:
            _, err = proc.communicate()
            log.append({"start": k + 1, "killed": False, "exit": proc.returncode, "seconds": time.perf_counter() - t0,
                        "stderr_traceback": "Traceback" in err})
            break
        kids: set[int] = set()
        while proc.poll() is None and _progress(out) < start_files + step:
            kids.update(_children(proc.pid))
            time.sleep(0.02)
        kids.update(_children(proc.pid))
        if proc.poll() is not None:
            log.append({"start": k + 1, "killed": False, "exit": proc.returncode, "note": "finished before the kill"})
            break
        phase = "figures" if (out / "measurements").is_dir() and any((out / "measurements").iterdir()) else "measurements"
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        deadline = time.monotonic() + 5
        while any(_alive(c) for c in kids) and time.monotonic() < deadline:
            time.sleep(0.05)
        orphans = [c for c in kids if _alive(c)]
        for c in orphans:
            os.kill(c, signal.SIGKILL)
        now = _files(out)
        for rel, ident in finished.items():
            if rel.endswith(".png") and rel in now and now[rel] != ident:
                rewritten.add(rel)
        finished.update({r: v for r, v in now.items() if r.endswith(".png") and r not in finished})
        temps = [str(p.relative_to(out)) for p in out.rglob("*") if TEMP.match(p.name)]
        log.append({"start": k + 1, "killed": True, "phase": phase, "seconds": time.perf_counter() - t0,
                    "progress": _progress(out), "workers": len(kids), "orphans": len(orphans),
                    "half_written": _complete(out), "temporaries_left": len(temps)})
        print(f"kill {k + 1}: {phase:<12} after {log[-1]['seconds']:.1f} s, {log[-1]['progress']} files, "
              f"{len(kids)} worker(s), orphans {len(orphans)}, incomplete {len(log[-1]['half_written'])}, "
              f"temporaries {len(temps)}", flush=True)
    now = _files(out)
    rewritten |= {rel for rel, ident in finished.items() if rel in now and now[rel] != ident}
    return {"log": log, "figures_rewritten_after_finishing": sorted(rewritten)}


def compare(clean: Path, killed: Path) -> list[str]:
    """Differences between the two tables (numbers with rtol 1e-9) and figure sets."""
    a = list(csv.DictReader((clean / "campaign.csv").read_text(encoding="utf-8").splitlines()))
    b = list(csv.DictReader((killed / "campaign.csv").read_text(encoding="utf-8").splitlines()))
    diffs = []
    if len(a) != len(b):
        return [f"{len(a)} rows against {len(b)}"]
    for ra, rb in zip(a, b, strict=True):
        for col in ra:
            if col.startswith("elapsed"):
                continue
            x, y = ra[col], rb.get(col)
            try:
                fx, fy = float(x), float(y)
            except (TypeError, ValueError):
                if x != y:
                    diffs.append(f"{ra.get('id')}.{col}: {x!r} != {y!r}")
                continue
            if not (math.isnan(fx) and math.isnan(fy)) and not math.isclose(fx, fy, rel_tol=1e-9, abs_tol=0.0):
                diffs.append(f"{ra.get('id')}.{col}: {x} != {y}")
    figs = lambda d: sorted(str(p.relative_to(d)) for p in d.rglob("*.png"))  # noqa: E731
    if figs(clean) != figs(killed):
        diffs.append(f"figure sets differ: {len(figs(clean))} against {len(figs(killed))}")
    return diffs


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--kills", type=int, default=10)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--keep", default=None, help="work in this folder and keep it")
    ap.add_argument("--reuse-clean", action="store_true",
                    help="with --keep: reuse the campaign and the clean run already there (their code must "
                         "compute the same table) and start the killed run afresh")
    a = ap.parse_args()
    work = Path(a.keep) if a.keep else Path(tempfile.mkdtemp(prefix="ema-kill-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        t0 = time.perf_counter()
        if a.reuse_clean and (work / "clean" / "campaign.csv").is_file():
            campaign = work / "campaign.toml"
            clean = subprocess.CompletedProcess([], 0)
            shutil.rmtree(work / "killed", ignore_errors=True)
            print("campaign and clean run reused", flush=True)
        else:
            campaign = make_campaign(work, a.n)
            print(f"{a.n} measurements written in {time.perf_counter() - t0:.1f} s", flush=True)
            t0 = time.perf_counter()
            clean = subprocess.run(_cmd(campaign, work / "clean", a.jobs), env=_env(), capture_output=True,
                                   text=True)
            print(f"clean run: exit {clean.returncode} in {time.perf_counter() - t0:.1f} s", flush=True)
        res = killed_run(campaign, work / "killed", a.jobs, a.kills, a.n)
        diffs = compare(work / "clean", work / "killed")
        kills = [e for e in res["log"] if e.get("killed")]
        last = res["log"][-1]
        temps_end = [str(p) for p in (work / "killed").rglob("*") if TEMP.match(p.name)]
        lock_end = (work / "killed" / ".ema-rig.lock").exists()
        summary = {
            "measurements": a.n, "jobs": a.jobs, "kills": len(kills),
            "kills_in_measurement_phase": sum(e["phase"] == "measurements" for e in kills),
            "kills_in_figure_phase": sum(e["phase"] == "figures" for e in kills),
            "orphans": sum(e["orphans"] for e in kills),
            "half_written_files": sum(len(e["half_written"]) for e in kills),
            "figures_rewritten_after_finishing": len(res["figures_rewritten_after_finishing"]),
            "final_exit": last.get("exit"), "final_traceback": last.get("stderr_traceback"),
            "clean_exit": clean.returncode, "table_differences": len(diffs),
            "temporaries_at_end": len(temps_end), "lock_at_end": lock_end,
        }
        for d in diffs[:10]:
            print("  diff:", d)
        for rel in res["figures_rewritten_after_finishing"][:10]:
            print("  figure written again after it was finished:", rel)
        print(json.dumps(summary, indent=1))
        ok = (len(kills) == a.kills and summary["orphans"] == 0 and summary["half_written_files"] == 0
              and not diffs and summary["final_exit"] == clean.returncode == 0 and not temps_end and not lock_end
              and summary["figures_rewritten_after_finishing"] == 0)
        print("PASS" if ok else "FAIL")
        return 0 if ok else 1
    finally:
        if not a.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
