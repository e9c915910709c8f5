"""Study: a user's regression review of this tree against an old tree (f95e2e5) on real files.

Runs the CLI as a user would, old and new side by side (paired: the order alternates per file), on
every UFF file of ``SHARED/real-frf`` and ``SHARED/uff-corpus`` (``modes FILE --json``; on a file old
refuses, ``inspect`` instead), plus ``modes``/``calibrate``/``stiffness`` on bundled files with
``data/rig.toml``. Compares per file: exit codes, mode sets (matched by frequency within 0.5 %),
the f and zeta shifts in units of the new sigma, the sigma ratios new/old, warnings added or removed,
and the child CPU time (user + sys, all threads) of each run, with the load average.

Make the old tree first: ``git -C <main> archive f95e2e5 | tar -x -C /tmp/w_old``, then, from this tree,
``python benchmarks/study_regression_f95e2e5.py /tmp/w_old [SHARED] > benchmarks/results/study_regression_f95e2e5.txt``
(SHARED: ``EMA_RIG_SHARED`` or ``../shared``);
``python benchmarks/study_regression_f95e2e5.py dig [SHARED]`` prints the cause of the flagged sigma. Flags (a test engineer's regression list): a mode lost
or gained, a sigma shrunk > 2x or grown > 3x, a warning new on every file, a traceback, CPU > 1.5x.
"""

from __future__ import annotations

import json
import os
import re
import resource
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
TOL_F = 0.005  # mode match: relative frequency difference (the brief's 0.5 %)


def run(tree: Path, args: list[str]) -> dict[str, Any]:
    """One CLI call in ``tree``: exit code, child CPU [s], stdout/stderr, the JSON it wrote (if any)."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    with tempfile.TemporaryDirectory() as td:
        out = Path(td) / "out.json"
        argv = [a.replace("{json}", str(out)) for a in args]
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        p = subprocess.run([sys.executable, "-m", "ema_rig.cli", *argv], cwd=td, env=env,
                           capture_output=True, text=True, check=False)
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        js = json.loads(out.read_text()) if out.exists() else None
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return {"rc": p.returncode, "cpu": cpu, "out": p.stdout, "err": p.stderr, "json": js}


def paired(old: Path, new: Path, args: list[str], first_old: bool) -> tuple[dict[str, Any], dict[str, Any]]:
    if first_old:
        a = run(old, args)
        b = run(new, args)
    else:
        b = run(new, args)
        a = run(old, args)
    return a, b


def _modes(js: dict[str, Any] | None) -> list[dict[str, Any]]:
    if not js:
        return []
    return list(js.get("modes", []))


def _norm_warning(w: str) -> str:
    """A warning with its numbers blanked, so a changed number is no new warning."""
    return re.sub(r"[-+]?\d[\d.eE+-]*", "#", w)


def warnings_of(r: dict[str, Any]) -> list[str]:
    js = r["json"]
    if js and "warnings" in js:
        return [str(w) for w in js["warnings"]]
    return [ln for ln in r["err"].splitlines() if ln.startswith("warning")]


def compare(name: str, a: dict[str, Any], b: dict[str, Any], lines: list[str], flags: list[str]) -> dict[str, int]:
    """Write the per-file comparison; return counts of added/removed normalised warnings."""
    cpu_ratio = b["cpu"] / a["cpu"] if a["cpu"] > 0 else float("nan")
    lines.append(f"== {name}: rc old {a['rc']} new {b['rc']}; CPU old {a['cpu']:.2f} s new {b['cpu']:.2f} s "
                 f"(new/old {cpu_ratio:.2f})")
    if a["rc"] != b["rc"]:
        flags.append(f"{name}: exit code {a['rc']} -> {b['rc']}")
    for tag, r in (("old", a), ("new", b)):
        if "Traceback" in r["err"]:
            flags.append(f"{name}: traceback in {tag}: {r['err'].strip().splitlines()[-1]}")
    if cpu_ratio > 1.5 and b["cpu"] > 1.0:
        flags.append(f"{name}: CPU {a['cpu']:.2f} -> {b['cpu']:.2f} s ({cpu_ratio:.2f}x)")
    ma, mb = _modes(a["json"]), _modes(b["json"])
    used: set[int] = set()
    lines.append("   f_old [Hz]   f_new [Hz]  df/sig_new  dz/sig_new  sf new/old  sz new/old  sf_new [Hz]  kind old/new")
    for m in ma:
        fa = m["natural_freq"]
        j = min((k for k in range(len(mb)) if k not in used), key=lambda k: abs(mb[k]["natural_freq"] - fa),
                default=None)
        if j is None or abs(mb[j]["natural_freq"] - fa) > TOL_F * fa:
            lines.append(f"   {fa:10.4f}   {'LOST':>10}")
            flags.append(f"{name}: mode {fa:.4f} Hz lost")
            continue
        used.add(j)
        n = mb[j]
        sfn, sfo = n.get("natural_freq_std"), m.get("natural_freq_std")
        szn, szo = n.get("damping_ratio_std"), m.get("damping_ratio_std")
        dfs = (n["natural_freq"] - fa) / sfn if sfn else float("nan")
        dzs = (n["damping_ratio"] - m["damping_ratio"]) / szn if szn else float("nan")
        rf = sfn / sfo if sfn and sfo else float("nan")
        rz = szn / szo if szn and szo else float("nan")
        lines.append(f"   {fa:10.4f}   {n['natural_freq']:10.4f}  {dfs:10.2f}  {dzs:10.2f}  {rf:10.2f}  {rz:10.2f}"
                     f"  {sfn if sfn else float('nan'):11.4g}  {m.get('std_kind')}/{n.get('std_kind')}")
        for what, r in (("sigma_f", rf), ("sigma_zeta", rz)):
            if r == r and (r < 0.5 or r > 3.0):
                flags.append(f"{name}: {fa:.3f} Hz {what} new/old {r:.2f}")
        if abs(dfs) > 2.0:
            flags.append(f"{name}: {fa:.3f} Hz f moved {dfs:.1f} new sigma")
    for k, n in enumerate(mb):
        if k not in used:
            lines.append(f"   {'GAINED':>10}   {n['natural_freq']:10.4f}")
            flags.append(f"{name}: mode {n['natural_freq']:.4f} Hz gained")
    wa = {_norm_warning(w): w for w in warnings_of(a)}
    wb = {_norm_warning(w): w for w in warnings_of(b)}
    for k in sorted(set(wb) - set(wa)):
        lines.append(f"   + warning: {wb[k][:300]}")
    for k in sorted(set(wa) - set(wb)):
        lines.append(f"   - warning: {wa[k][:300]}")
    return {"added": len(set(wb) - set(wa)), "removed": len(set(wa) - set(wb))}


def demo(old: Path, new: Path) -> list[str]:
    """``demo -o DIR`` in both trees: exit codes, CPU and the campaign table's k_TB per measurement."""
    import csv

    out: list[str] = []
    res = {}
    for tag, tree in (("old", old), ("new", new)):
        with tempfile.TemporaryDirectory() as td:
            r = run(tree, ["demo", "-o", str(Path(td) / "d")])
            csv_path = Path(td) / "d" / "campaign.csv"
            rows = list(csv.DictReader(csv_path.read_text().splitlines())) if r["rc"] == 0 else []
        res[tag] = (r, rows)
        out.append(f"== demo {tag}: rc {r['rc']}, CPU {r['cpu']:.1f} s, {len(rows)} rows")
    rows_a, rows_b = res["old"][1], res["new"][1]
    if rows_a and rows_b:
        keys = [k for k in rows_a[0] if k.startswith(("k_TB", "id", "warn"))]
        out.append("   " + "  ".join(keys))
        for a, b in zip(rows_a, rows_b, strict=False):
            diff = [k for k in keys if a.get(k) != b.get(k)]
            if diff:
                out.append("   " + a.get("id", "?") + ": " + "; ".join(f"{k} {a.get(k)} -> {b.get(k)}" for k in diff))
    return out


def dig(shared: Path) -> None:
    """The cause of the flagged sigma of ufffiles_frf (run in this tree only): the sandwich block length
    of every ML segment (``MLCriteria.block_from_scores`` on and off) and the band-to-band agreement
    of the modes (0-799.5 Hz against 79.95-719.55 Hz, matched within 0.5 %, |df| / combined sigma)."""
    import dataclasses
    import warnings

    import numpy as np

    import ema_rig.identification.ml as ml
    from ema_rig.identification import identify
    from ema_rig.io.uff import read_uff58

    warnings.simplefilter("ignore")
    data = read_uff58(shared / "uff-corpus" / "ufffiles_frf.unv")
    blocks: list[str] = []
    orig_meat = ml._meat

    def meat(sc: Any, nb: int, from_scores: bool) -> Any:
        n = sc.shape[1]
        if n > 200:
            blocks.append(f"{n} lines, {sc.shape[0]} scores: block {nb} lines fixed, Andrews "
                          f"{ml._score_bandwidth(sc):.1f} lines (cap {n // 2}), used: {from_scores and 'Andrews' or 'fixed'}")
        return orig_meat(sc, nb, from_scores)

    ml._meat = meat
    kw_staged, kw_local = dict(ml.local_ml_staged.__kwdefaults__ or {}), dict(ml.local_ml.__kwdefaults__ or {})
    for on in (True, False):
        crit = dataclasses.replace(ml.ML_CRITERIA, block_from_scores=on)
        ml.local_ml_staged.__kwdefaults__ = {**kw_staged, "criteria": crit}
        ml.local_ml.__kwdefaults__ = {**kw_local, "criteria": crit}
        res = {}
        for band in (None, (79.95, 719.55)):
            blocks.clear()
            i = identify(data, band=band)
            res[band] = (i.modes.natural_freq, i.natural_freq_std, i.damping_ratio, i.damping_ratio_std, i.std_kind)
            for b in blocks:
                print(f"block_from_scores={on} band {band}: segment of {b}")
        (fa, sa, za, sza, ka), (fb, sb, _zb, _szb, _kb) = res[None], res[(79.95, 719.55)]
        for j in np.flatnonzero((fa > 360) & (fa < 380)):
            print(f"block_from_scores={on}: whole band {fa[j]:.3f} +- {sa[j]:.3f} Hz, zeta {100 * za[j]:.3f} +- "
                  f"{100 * sza[j]:.3f} % ({ka[j]})")
        zs = []
        for j in range(len(fb)):
            k = int(np.argmin(abs(fa - fb[j])))
            if abs(fa[k] - fb[j]) < TOL_F * fb[j]:
                zs.append(abs(fa[k] - fb[j]) / float(np.hypot(sa[k], sb[j])))
        print(f"block_from_scores={on}: {len(fa)} modes 0-799.5 Hz, {len(fb)} modes 79.95-719.55 Hz, {len(zs)} matched, "
              f"{sum(z < 2 for z in zs)} within 2 combined sigma, max {max(zs):.2f}")
    ml._meat = orig_meat
    ml.local_ml_staged.__kwdefaults__, ml.local_ml.__kwdefaults__ = kw_staged, kw_local


def main() -> None:
    if sys.argv[1] == "dig":
        dig(Path(sys.argv[2] if len(sys.argv) > 2 else os.environ.get("EMA_RIG_SHARED", REPO.parent / "shared")))
        return
    old = Path(sys.argv[1]).resolve()
    shared = Path(sys.argv[2] if len(sys.argv) > 2 else os.environ.get("EMA_RIG_SHARED", REPO.parent / "shared"))
    new = REPO
    cases: list[tuple[str, list[str]]] = []
    for folder in ("real-frf", "uff-corpus"):
        for p in sorted((shared / folder).iterdir()):
            if p.suffix.lower() in (".uff", ".unv", ".frf", ".ufb"):
                extra = ["--crosscheck"] if folder == "real-frf" else []
                cases.append((f"{folder}/{p.name}", ["modes", str(p), "--json", "{json}", *extra]))
    # the other band of each real file (the band-to-band oracle of study_real_bands.py)
    for f, band in (("uff-corpus/ufffiles_frf.unv", ("79.95", "719.55")), ("real-frf/dam0.unv", ("1", "12")),
                    ("real-frf/vt_case1_full.uff", ("10", "300"))):
        cases.append((f"{f} band {band[0]}-{band[1]}", ["modes", str(shared / f), "--band", *band, "--json", "{json}"]))
    data, rig = REPO / "data", str(REPO / "data" / "rig.toml")
    cases.append(("data/disk.uff modes", ["modes", str(data / "disk.uff"), "--rig", rig, "--json", "{json}"]))
    cases.append(("data/disk.uff calibrate", ["calibrate", str(data / "disk.uff"), "--rig", rig, "--json", "{json}"]))
    for f in ("dummy_1000N_r1.uff", "b6302_1000N_1200rpm.uff", "b6302_1000N_static_17deg.uff"):
        cases.append((f"data/{f} modes", ["modes", str(data / f), "--rig", rig, "--json", "{json}"]))
        cases.append((f"data/{f} stiffness", ["stiffness", str(data / f), "--rig", rig, "--json", "{json}"]))
    lines: list[str] = [f"old tree {old}, new tree {new}; load average at start {os.getloadavg()}"]
    flags: list[str] = []
    tot = {"old": 0.0, "new": 0.0}
    wcount: dict[str, int] = {}
    n_modes_runs = 0
    for i, (name, args) in enumerate(cases):
        a, b = paired(old, new, args, first_old=(i % 2 == 0))
        if args[0] == "modes" and a["rc"] != 0:
            lines.append(f"== {name}: old refuses modes (rc {a['rc']}: {a['err'].strip().splitlines()[-1][:200]}); "
                         f"new rc {b['rc']}")
            if b["rc"] != a["rc"]:
                flags.append(f"{name}: modes exit code {a['rc']} -> {b['rc']}")
            ia, ib = paired(old, new, ["inspect", args[1]], first_old=(i % 2 == 0))
            lines.append(f"   inspect rc old {ia['rc']} new {ib['rc']}; same output: {ia['out'] == ib['out']}")
            if ia["rc"] != ib["rc"] or ia["out"] != ib["out"]:
                flags.append(f"{name}: inspect differs (rc {ia['rc']} -> {ib['rc']})")
            continue
        tot["old"] += a["cpu"]
        tot["new"] += b["cpu"]
        compare(name, a, b, lines, flags)
        if args[0] == "modes":
            n_modes_runs += 1
            for w in {_norm_warning(w) for w in warnings_of(b)} - {_norm_warning(w) for w in warnings_of(a)}:
                wcount[w] = wcount.get(w, 0) + 1
        if "--crosscheck" in args:
            for tag, r in (("old", a), ("new", b)):
                xs = r["out"].splitlines()
                k0 = next((k for k, ln in enumerate(xs) if "sdypy-EMA LSCF cross-check" in ln), len(xs))
                lines.append(f"   crosscheck {tag}:")
                lines += [f"     {x}" for x in xs[k0:]]
        if args[0] in ("stiffness", "calibrate") and a["json"] and b["json"]:
            for key in ("k_TB", "k_TB_std_measured", "k_TB_std", "k_MS", "k_MS_std", "k_MS_std_measured",
                        "inverted_freq"):
                if key in a["json"] or key in b["json"]:
                    lines.append(f"   {key}: old {a['json'].get(key)} new {b['json'].get(key)}")
    lines += demo(old, new)
    for w, c in sorted(wcount.items(), key=lambda t: -t[1]):
        if c >= max(3, n_modes_runs // 2):
            flags.append(f"new warning on {c} of {n_modes_runs} modes runs: {w[:200]}")
    lines.append("")
    lines.append(f"total CPU of the runs old accepted: old {tot['old']:.1f} s, new {tot['new']:.1f} s "
                 f"(new/old {tot['new'] / max(tot['old'], 1e-9):.2f}); load average at end {os.getloadavg()}")
    lines.append("FLAGS:")
    lines += [f" - {f}" for f in flags] or [" (none)"]
    print("\n".join(lines))


if __name__ == "__main__":
    main()
