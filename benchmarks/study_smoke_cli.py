"""Study: a test engineer's smoke matrix of the documented CLI at its defaults on every real file.

Runs, as a user would (a fresh process, a fresh empty working folder, outputs under ``out/``), every
DESIGN section 3.2 command that takes the file at its defaults:

- every UFF file of ``SHARED/uff-corpus`` and ``SHARED/real-frf`` and every bundled ``data/*.uff``:
  ``inspect FILE --json``, ``modes FILE --json``, ``stabilization FILE -o PNG``;
  on files with time histories also ``frf FILE -o FRF.uff``;
- the bundled rig commands: ``calibrate data/disk.uff --rig``, ``stiffness FILE --rig --json`` on every
  bundled measurement, ``simulate``, ``campaign data/campaign.toml`` and ``demo``;
- hostile inputs built in a temporary folder: a truncated copy, a non-UFF file, an empty file, a folder
  as FILE, an unwritable output path, rig files with a key missing / misspelt / a wrong type;
- every documented ``modes`` option on every file ``modes`` accepts (part E), hand-edited saved
  selections through ``stiffness --selection`` (part F), and a user's next steps (part G): the disk
  file given to ``stiffness``, simulated bearings from 1e5 to 1e13 N/m, ``frf`` then ``modes``, a
  campaign with broken measurement files.

Per run it records the exit code, wall and child CPU time, and flags (a test engineer's defect list):
a Python traceback; a failure without exactly one ``error: <file>: ...`` line naming the file; a file
written outside ``out/`` or left in ``out/`` by a failed run; a leftover temporary/lock file; a JSON
that breaks DESIGN section 3 (keys missing, a number NaN/inf where one is promised, a sigma <= 0);
physically implausible modes (above the data's last line, zeta <= 0, two modes within 0.1 %).
Warnings are counted per command over all files, numbers blanked, to find the ones that fire on
every run.

``python benchmarks/study_smoke_cli.py [SHARED] [--only-truth] > benchmarks/results/smoke_<commit>.txt``
(``--only-truth``: part H alone, the default ``modes`` of every bundled file against its truth file)
(SHARED: ``EMA_RIG_SHARED`` or ``../shared``); run it from the tree under test, ideally under
``nice -n 19``.
"""

from __future__ import annotations

import collections
import json
import math
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
DATA = REPO / "data"
DUP_REL = 0.001  # two modes within 0.1 % in f: a duplicate (the brief's definition)
MODE_KEYS = ("natural_freq", "natural_freq_std", "damping_ratio", "damping_ratio_std")
TMP_PATTERNS = (".tmp", ".lock", ".part", "~")


def _files(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


def run(args: list[str], expect: list[str] | None = None, stdin_dir: Path | None = None) -> dict[str, Any]:
    """One CLI call in a fresh folder; ``{out}`` in args is the output folder ``out``.

    Returns exit code, wall and child CPU [s], stderr, the JSON files written and the flags.
    """
    td = Path(tempfile.mkdtemp(prefix="smoke_"))
    out = td / "out"
    out.mkdir()
    argv = [a.replace("{out}", str(out)) for a in args]
    env = dict(os.environ, PYTHONPATH=str(REPO), MPLBACKEND="Agg")
    repo_before = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "--untracked-files=all"],
                                 capture_output=True, text=True, check=False).stdout
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "ema_rig.cli", *argv], cwd=td, env=env,
                       capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    repo_after = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "--untracked-files=all"],
                                capture_output=True, text=True, check=False).stdout
    flags: list[str] = []
    if "Traceback (most recent call last)" in p.stderr or "Traceback" in p.stdout:
        flags.append("TRACEBACK")
    errs = [ln for ln in p.stderr.splitlines() if ln.startswith("error:")]
    if p.returncode != 0:
        if len(errs) != 1:
            flags.append(f"{len(errs)} error lines on failure")
        elif not re.match(r"error: \S.*?: \S", errs[0]):
            flags.append("error line without 'error: <file>: <what>'")
    elif errs:
        flags.append("error line on success")
    outside = _files(td) - {"out"} - {"out/" + f for f in _files(out)}
    if outside:
        flags.append(f"written outside out/: {sorted(outside)}")
    if repo_after != repo_before:
        flags.append("the source tree changed: " + repo_after.replace("\n", "; ")[:200])
    written = _files(out)
    leftovers = [f for f in written if any(f.endswith(s) or f"/{s}" in f for s in TMP_PATTERNS)
                 or Path(f).name.startswith(".ema-rig.lock")]
    if leftovers:
        flags.append(f"leftover temporaries {sorted(leftovers)}")
    if p.returncode != 0 and written and expect is not None:
        kept = sorted(set(written) - set(expect))
        if kept:
            flags.append(f"failed run left {kept}")
    jsons: dict[str, Any] = {}
    for f in written:
        if f.endswith(".json") and "/" not in f:
            try:
                jsons[f] = json.loads((out / f).read_text())
            except (json.JSONDecodeError, UnicodeDecodeError) as e:
                flags.append(f"{f}: not JSON ({e})")
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    shutil.rmtree(td, ignore_errors=True)
    return {"rc": p.returncode, "wall": wall, "cpu": cpu, "out": p.stdout, "err": p.stderr,
            "errors": errs, "json": jsons, "flags": flags, "written": sorted(written)}


def _finite_pos(x: Any) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x) and x > 0


def check_modes(js: dict[str, Any], fmax: float | None) -> list[str]:
    """DESIGN 3.2 contract of the ``modes`` JSON and the physical plausibility of its modes."""
    flags: list[str] = []
    for key in ("modes", "warnings"):
        if key not in js:
            flags.append(f"key {key!r} missing")
    if not isinstance(js.get("warnings", []), list) or any(not isinstance(w, str) or "\n" in w
                                                            for w in js.get("warnings", [])):
        flags.append("warnings not a list of one-line strings")
    fs = []
    for m in js.get("modes", []):
        miss = [k for k in MODE_KEYS if k not in m]
        if miss:
            flags.append(f"mode keys missing {miss}")
            continue
        f, z = m["natural_freq"], m["damping_ratio"]
        if not _finite_pos(f):
            flags.append(f"f = {f}")
            continue
        fs.append(f)
        if not (isinstance(z, (int, float)) and math.isfinite(z)) or z <= 0:
            flags.append(f"{f:.4g} Hz: zeta = {z}")
        for k in ("natural_freq_std", "damping_ratio_std"):
            if not _finite_pos(m[k]):
                flags.append(f"{f:.4g} Hz: {k} = {m[k]}")
        if fmax is not None and f > fmax * 1.0001:
            flags.append(f"{f:.6g} Hz above the data's last line {fmax:.6g} Hz")
    fs.sort()
    for a, b in zip(fs, fs[1:], strict=False):
        if (b - a) / a < DUP_REL:
            flags.append(f"modes {a:.6g} / {b:.6g} Hz within {DUP_REL:.1%}")
    return flags


def check_rig(js: dict[str, Any], keys: tuple[str, ...]) -> list[str]:
    """DESIGN 3.2 keys of ``stiffness`` / ``calibrate`` and the sigmas they promise."""
    flags = [f"key {k!r} missing" for k in (*keys, "warnings", "housing_mode") if k not in js]
    for k in keys:
        v = js.get(k)
        if v is not None and not _finite_pos(v):
            flags.append(f"{k} = {v}")
    hm = js.get("housing_mode") or {}
    for k in ("natural_freq", "damping_ratio"):
        if hm and not _finite_pos(hm.get(k)):
            flags.append(f"housing_mode.{k} = {hm.get(k)}")
    return flags


def check_inspect(js: dict[str, Any]) -> list[str]:
    flags = [f"key {k!r} missing" for k in ("file", "datasets") if k not in js]
    for d in js.get("datasets", []):
        miss = [k for k in ("index", "type", "function_type", "response", "reference", "num_pts", "status",
                            "reason") if k not in d]
        if miss:
            flags.append(f"dataset {d.get('index')}: keys missing {miss}")
        if d.get("status") not in ("read", "refused"):
            flags.append(f"dataset {d.get('index')}: status {d.get('status')!r}")
        if d.get("status") == "refused" and not d.get("reason"):
            flags.append(f"dataset {d.get('index')}: refused without a reason")
    return flags


def norm_warning(w: str) -> str:
    """A warning with its file and numbers blanked, so one kind of warning counts once per file."""
    w = re.sub(r"^warning: \S+?: ", "warning: ", w)
    return re.sub(r"[-+]?\d[\d.eE+-]*", "#", w)[:150]


def warnings_of(r: dict[str, Any]) -> list[str]:
    return [ln for ln in r["err"].splitlines() if ln.startswith("warning")]


def data_band(inspect_js: dict[str, Any] | None) -> float | None:
    """The last line [Hz] of the file's FRF datasets (the analyser's band), from ``inspect``'s JSON."""
    if not inspect_js:
        return None
    tops = [d["band"][1] for d in inspect_js.get("datasets", [])
            if d.get("function_type") == 4 and d.get("status") == "read" and d.get("band")]
    return max(tops) if tops else None


def has_time(inspect_js: dict[str, Any] | None) -> bool:
    return bool(inspect_js) and any(d.get("function_type") == 1 and d.get("status") == "read"
                                    for d in inspect_js.get("datasets", []))


def row(lines: list[str], name: str, cmd: str, r: dict[str, Any], extra: list[str]) -> int:
    flags = r["flags"] + extra
    msg = r["errors"][0][:160] if r["errors"] else ""
    lines.append(f"{name:<34} {cmd:<13} rc {r['rc']:>2}  wall {r['wall']:6.2f} s  cpu {r['cpu']:6.2f} s  "
                 f"{'FLAG ' + ' | '.join(flags) if flags else 'ok'}")
    if msg:
        lines.append(f"{'':<34} {'':<13} {msg}")
    return len(flags)


def hostile(tmp: Path, shared: Path) -> list[tuple[str, list[str], list[str]]]:
    """(name, argv, outputs a failed run may keep) for the hostile variants built in ``tmp``."""
    src = shared / "real-frf" / "vt_case1_full.uff"
    raw = src.read_bytes()
    (tmp / "truncated_half.uff").write_bytes(raw[: len(raw) // 2])
    (tmp / "truncated_header.uff").write_bytes(raw[:300])
    (tmp / "not_uff.uff").write_text("this is a CSV export\nf,re,im\n1,2,3\n")
    (tmp / "empty.uff").write_bytes(b"")
    (tmp / "binary_junk.uff").write_bytes(bytes(range(256)) * 20)
    (tmp / "a_folder.uff").mkdir(exist_ok=True)
    (tmp / "ro").mkdir(exist_ok=True)
    rig = (DATA / "rig.toml").read_text()
    (tmp / "rig_missing_k_B.toml").write_text(re.sub(r"(?m)^k_B\s*=.*$", "", rig))
    (tmp / "rig_misspelt_key.toml").write_text(rig.replace("m_H", "m_h", 1))
    (tmp / "rig_string_mass.toml").write_text(re.sub(r"(?m)^m_H\s*=\s*\S+", 'm_H = "2.5 kg"', rig))
    (tmp / "rig_not_toml.toml").write_text("[model\nm_H = \n")
    (tmp / "rig_no_sensor.toml").write_text(rig.split("[[sensor]]")[0])
    meas = str(DATA / "b6302_1000N_1200rpm.uff")
    cases: list[tuple[str, list[str], list[str]]] = []
    for f in ("truncated_half.uff", "truncated_header.uff", "not_uff.uff", "empty.uff", "binary_junk.uff",
              "a_folder.uff", "does_not_exist.uff"):
        path = str(tmp / f)
        cases.append((f, ["inspect", path, "--json", "{out}/i.json"], ["i.json"]))
        cases.append((f, ["modes", path, "--json", "{out}/m.json"], []))
        cases.append((f, ["stabilization", path, "-o", "{out}/s.png"], []))
        cases.append((f, ["stiffness", path, "--rig", str(DATA / "rig.toml"), "--json", "{out}/k.json"], []))
        cases.append((f, ["frf", path, "-o", "{out}/frf.uff"], []))
    mat = str(shared / "real-frf" / "vt_case1.mat")
    cases.append(("vt_case1.mat (not UFF)", ["inspect", mat, "--json", "{out}/i.json"], []))
    cases.append(("vt_case1.mat (not UFF)", ["modes", mat, "--json", "{out}/m.json"], []))
    for o in ("/proc/version/m.json", "/sys/m.json", "/dev/null/m.json", str(tmp / "a_folder.uff")):
        cases.append(("unwritable -o " + o, ["modes", meas, "--json", o], []))
        cases.append(("unwritable -o " + o, ["stabilization", meas, "-o", o], []))
    real = str(shared / "real-frf" / "vt_case1_full.uff")
    cases.append(("calibrate on a bearing file", ["calibrate", meas, "--rig", str(DATA / "rig.toml")], []))
    cases.append(("stiffness on a real file", ["stiffness", real, "--rig", str(DATA / "rig.toml")], []))
    cases.append(("modes --band above the data", ["modes", real, "--band", "600", "900"], []))
    cases.append(("modes --band one line wide", ["modes", real, "--band", "100", "100.3"], []))
    cases.append(("campaign -o /proc/x", ["campaign", str(DATA / "campaign.toml"), "-o", "/proc/x"], []))
    for f in ("rig_missing_k_B.toml", "rig_misspelt_key.toml", "rig_string_mass.toml", "rig_not_toml.toml",
              "rig_no_sensor.toml", "a_folder.uff", "empty.uff"):
        cases.append((f, ["stiffness", meas, "--rig", str(tmp / f), "--json", "{out}/k.json"], []))
        cases.append((f, ["modes", meas, "--rig", str(tmp / f), "--json", "{out}/m.json"], []))
        cases.append((f, ["calibrate", str(DATA / "disk.uff"), "--rig", str(tmp / f), "--json", "{out}/c.json"],
                      []))
        cases.append((f, ["simulate", "--rig", str(tmp / f), "--k-tb", "1e8", "-o", "{out}/sim.uff"], []))
    return cases


def selection_mutations(doc: dict[str, Any]) -> list[tuple[str, str]]:
    """(kind, JSON text): a saved selection unchanged, then hand edits a user or another tool could make."""
    def edit(path: tuple[Any, ...], value: Any) -> str:
        d = json.loads(json.dumps(doc))
        target = d
        for k in path[:-1]:
            target = target[k]
        target[path[-1]] = value
        return json.dumps(d)
    return [("unchanged", json.dumps(doc)), ("top-level list", json.dumps([doc])), ("top-level string", '"x"'),
            ("a mode not an object", edit(("modes", 0), [1, 2])), ("modes an object", edit(("modes",), {"a": 1})),
            ("order 1e400", edit(("modes", 0, "order"), 1e400)), ("band a string", edit(("band",), "150-1000")),
            ("band of three", edit(("band",), [150, 500, 1000])), ("max_order -5", edit(("max_order",), -5)),
            ("pole NaN", edit(("modes", 0, "pole"), [float("nan")] * 2)),
            ("natural_freq negative", edit(("modes", 0, "natural_freq"), -300.0)),
            ("no modes", edit(("modes",), [])), ("pole a number", edit(("modes", 0, "pole"), 5))]


def truth_coverage(lines: list[str]) -> int:
    """Part H: ``modes FILE --json`` at the defaults on every bundled file against its ``.truth.json``.

    Each reported mode is compared with the nearest true mode: f and zeta in units of the reported
    sigma (|z| > 2 expected for 4.6 % of them), the outliers beyond 4 sigma flagged when the result
    carries no warning (DESIGN 3.2: a result without warnings lies within 2 sigma of the truth; a
    calibrated sigma puts 4.6 % beyond 2 but 6e-5 beyond 4: 0.05 of the ~800 values here). True modes inside the band that no reported
    mode matches within 1 % are listed (speed harmonics excluded: no modes).
    """
    n_flags = n = n_f = n_z = 0
    for f in sorted(DATA.glob("*.uff")):
        truth = json.loads(f.with_name(f.name + ".truth.json").read_text())
        true = [(m["natural_freq"], m["damping_ratio"], m["kind"]) for m in truth["modes"] if m["kind"] != "harmonic"]
        r = run(["modes", str(f), "--json", "{out}/m.json"], expect=[])
        js = r["json"].get("m.json", {})
        out: list[str] = []
        for m in js.get("modes", []):
            fn, zeta = m["natural_freq"], m["damping_ratio"]
            t = min(true, key=lambda x: abs(x[0] - fn))
            zf, zz = (fn - t[0]) / m["natural_freq_std"], (zeta - t[1]) / m["damping_ratio_std"]
            n, n_f, n_z = n + 1, n_f + (abs(zf) > 2), n_z + (abs(zz) > 2)
            if max(abs(zf), abs(zz)) > 4 and not js.get("warnings"):
                out.append(f"{fn:.3f} +- {m['natural_freq_std']:.2g} Hz zeta {100 * zeta:.3f} +- "
                           f"{100 * m['damping_ratio_std']:.2g} % vs truth {t[0]:.2f} Hz {100 * t[1]:.2f} % ({t[2]}): "
                           f"z_f {zf:.1f}, z_zeta {zz:.1f}, no warning")
        lo, hi = js.get("band", (0.0, 0.0))
        missed = [f"{t[0]:.4g}" for t in true if lo <= t[0] <= hi
                  and not any(abs(m["natural_freq"] - t[0]) < 0.01 * t[0] for m in js.get("modes", []))]
        n_flags += row(lines, f"data/{f.name}", "modes/truth", r, out)
        lines.append(f"{'':<48} {len(js.get('modes', []))} modes, {len(js.get('warnings', []))} warnings; true modes "
                     f"in the band not found: {', '.join(missed) or 'none'} Hz")
    lines.append(f"over the {n} modes: f beyond 2 sigma of the truth {n_f} ({n_f / max(n, 1):.1%}), zeta {n_z} "
                 f"({n_z / max(n, 1):.1%}); a calibrated sigma puts 4.6 % there")
    return n_flags


def main() -> None:
    only_h = "--only-truth" in sys.argv  # part H alone (the others take 15 min)
    if only_h:
        sys.argv.remove("--only-truth")
    shared = Path(sys.argv[1] if len(sys.argv) > 1 else os.environ.get("EMA_RIG_SHARED", REPO.parent / "shared"))
    head = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True, check=False).stdout.strip()
    lines: list[str] = [f"tree {REPO} @ {head}; shared {shared}; python {sys.version.split()[0]}",
                        f"start {time.strftime('%Y-%m-%d %H:%M:%S', time.gmtime())} UTC, load {os.getloadavg()}",
                        ]
    head_h = ["", "== H. the default modes of every bundled file against its truth file"]
    if only_h:
        lines += head_h
        n_flags = truth_coverage(lines)
        lines.append(f"end {time.strftime('%Y-%m-%d %H:%M:%S', time.gmtime())} UTC, load {os.getloadavg()}; "
                     f"flags {n_flags}")
        print("\n".join(lines))
        return
    lines += ["", "== A. every UFF file at the defaults"]
    n_flags = 0
    warn_count: dict[str, collections.Counter[str]] = collections.defaultdict(collections.Counter)
    runs_per_cmd: collections.Counter[str] = collections.Counter()
    accepted: list[Path] = []
    files = sorted((shared / "uff-corpus").glob("*.u*")) + sorted((shared / "uff-corpus").glob("*.frf")) \
        + sorted((shared / "real-frf").glob("*.u*")) + sorted(DATA.glob("*.uff"))
    for f in files:
        name = f"{f.parent.name}/{f.name}"
        ri = run(["inspect", str(f), "--json", "{out}/i.json"], expect=["i.json"])  # kept on failure (DESIGN)
        ij = ri["json"].get("i.json")
        n_flags += row(lines, name, "inspect", ri, check_inspect(ij) if ij else [])
        fmax = data_band(ij)
        for cmd, args, expect in (("modes", ["modes", str(f), "--json", "{out}/m.json"], []),
                                  ("stabilization", ["stabilization", str(f), "-o", "{out}/s.png"], [])):
            r = run(args, expect=expect)
            extra: list[str] = []
            if cmd == "modes" and r["rc"] == 0:
                extra = check_modes(r["json"].get("m.json", {}), fmax)
                accepted.append(f)
            if cmd == "stabilization" and r["rc"] == 0 and "s.png" not in r["written"]:
                extra.append("exit 0 without the PNG")
            n_flags += row(lines, name, cmd, r, extra)
            if cmd == "modes" and r["rc"] == 0:
                lines.append(f"{'':<48} modes [Hz]: " + ", ".join(
                    f"{m['natural_freq']:.5g}" for m in r["json"].get("m.json", {}).get("modes", [])))
            runs_per_cmd[cmd] += 1
            for w in set(map(norm_warning, warnings_of(r))):
                warn_count[cmd][w] += 1
        if has_time(ij):
            r = run(["frf", str(f), "-o", "{out}/frf.uff"], expect=[])
            n_flags += row(lines, name, "frf", r, [])
            runs_per_cmd["frf"] += 1
            for w in set(map(norm_warning, warnings_of(r))):
                warn_count["frf"][w] += 1

    lines += ["", "== B. the rig commands on the bundled data (data/rig.toml)"]
    rig = str(DATA / "rig.toml")
    r = run(["calibrate", str(DATA / "disk.uff"), "--rig", rig, "--json", "{out}/c.json"], expect=[])
    n_flags += row(lines, "data/disk.uff", "calibrate", r,
                   check_rig(r["json"].get("c.json", {}), ("k_MS", "k_MS_std")) if r["rc"] == 0 else [])
    for f in sorted(DATA.glob("*.uff")):
        if f.name == "disk.uff":
            continue
        r = run(["stiffness", str(f), "--rig", rig, "--json", "{out}/k.json", "--plot", "{out}/k.png"],
                expect=["k.json"])
        extra = check_rig(r["json"].get("k.json", {}), ("k_TB", "k_TB_std", "k_TB_MS", "k_MS")) \
            if r["rc"] == 0 else []
        truth_p = f.with_name(f.name + ".truth.json")
        if r["rc"] == 0 and truth_p.exists():
            truth = json.loads(truth_p.read_text())
            kt = truth.get("k_TB")
            js = r["json"]["k.json"]
            if isinstance(kt, (int, float)) and not js.get("warnings"):
                z = (js["k_TB"] - kt) / js["k_TB_std"]
                if abs(z) > 2:
                    extra.append(f"no warning but k_TB {abs(z):.2f} sigma from the truth")
        n_flags += row(lines, f"data/{f.name}", "stiffness", r, extra)
        runs_per_cmd["stiffness"] += 1
        for w in set(map(norm_warning, warnings_of(r))):
            warn_count["stiffness"][w] += 1
    r = run(["simulate", "--rig", rig, "--k-tb", "1.2e8", "-o", "{out}/sim.uff"], expect=[])
    n_flags += row(lines, "simulate", "simulate", r, [])
    r = run(["campaign", str(DATA / "campaign.toml"), "-o", "{out}/camp"], expect=[])
    n_flags += row(lines, "data/campaign.toml", "campaign", r, [])
    r = run(["demo", "-o", "{out}/demo"], expect=[])
    n_flags += row(lines, "demo", "demo", r, [])

    lines += ["", "== C. hostile variants (built in a temporary folder)"]
    with tempfile.TemporaryDirectory(prefix="hostile_") as td:
        for name, args, expect in hostile(Path(td), shared):
            r = run(args, expect=expect)
            extra = []
            if r["rc"] == 0 and not name.startswith("rig_"):
                extra.append("exit 0 on a hostile input")
            n_flags += row(lines, name, args[0], r, extra)

    lines += ["", "== E. the documented options on every file modes accepts (crosscheck, refine, shapes, plots, "
              "uff55, selection save and replay)"]
    for f in accepted:
        name = f"{f.parent.name}/{f.name}"
        r = run(["modes", str(f), "--crosscheck", "--refine", "--json", "{out}/m.json", "--plot", "{out}/p.png",
                 "--uff55", "{out}/m.unv", "--shapes", "{out}/shape", "--automac", "{out}/mac.png",
                 "--save-selection", "{out}/sel.json"], expect=[])
        extra = check_modes(r["json"].get("m.json", {}), None) if r["rc"] == 0 else []
        if r["rc"] == 0 and "crosscheck" not in r["json"].get("m.json", {}):
            extra.append("no crosscheck key")
        n_flags += row(lines, name, "modes+options", r, extra)
        for w in set(map(norm_warning, warnings_of(r))):
            warn_count["modes+options"][w] += 1
        runs_per_cmd["modes+options"] += 1

    lines += ["", "== F. stiffness --selection with a saved selection, then mutations of it (hand-edited files)"]
    with tempfile.TemporaryDirectory(prefix="sel_") as td:
        sel0 = Path(td) / "sel0.json"
        meas = str(DATA / "b6302_1000N_1200rpm.uff")
        r = run(["modes", meas, "--rig", rig, "--save-selection", str(sel0)], expect=[])
        n_flags += row(lines, "save the selection", "modes", r, [])
        for kind, text in selection_mutations(json.loads(sel0.read_text())):
            p = Path(td) / "sel.json"
            p.write_text(text)
            r = run(["stiffness", meas, "--rig", rig, "--selection", str(p), "--json", "{out}/k.json"],
                    expect=["k.json"])
            extra = ["a broken selection accepted"] if r["rc"] == 0 and kind != "unchanged" else []
            n_flags += row(lines, kind, "stiffness", r, extra)

    lines += ["", "== G. a user's next steps: the disk file given to stiffness, extreme simulated bearings, "
              "frf -> modes, a campaign with broken measurement files"]
    with tempfile.TemporaryDirectory(prefix="next_") as td:
        tdp = Path(td)
        r = run(["stiffness", str(DATA / "disk.uff"), "--rig", rig], expect=[])
        n_flags += row(lines, "data/disk.uff", "stiffness", r, [])
        for k_tb in ("1e5", "1e9", "1e10", "1e12", "1e13"):
            sim = tdp / f"sim_{k_tb}.uff"
            r = run(["simulate", "--rig", rig, "--k-tb", k_tb, "--seed", "1", "-o", str(sim)], expect=[])
            n_flags += row(lines, f"simulate --k-tb {k_tb}", "simulate", r, [])
            r = run(["stiffness", str(sim), "--rig", rig, "--json", "{out}/k.json"], expect=["k.json"])
            extra = []
            js = r["json"].get("k.json", {})
            if r["rc"] == 0:
                extra = check_rig(js, ("k_TB", "k_TB_std", "k_TB_MS", "k_MS"))
                z = (js["k_TB"] - float(k_tb)) / js["k_TB_std"]
                lines.append(f"{'':<48} k_TB {js['k_TB']:.4g} +- {js['k_TB_std']:.3g} N/m (truth {k_tb}, "
                             f"z {z:.2f}), {len(js.get('warnings', []))} warnings")
                if abs(z) > 2 and not js.get("warnings"):
                    extra.append("no warning but k_TB beyond 2 sigma of the truth")
            n_flags += row(lines, f"  sim {k_tb}", "stiffness", r, extra)
        frf = tdp / "vt1_frf.uff"
        r = run(["frf", str(shared / "real-frf" / "vt_case1_full.uff"), "-o", str(frf)], expect=[])
        n_flags += row(lines, "vt_case1_full -> frf", "frf", r, [])
        r = run(["modes", str(frf), "--json", "{out}/m.json"], expect=[])
        extra = check_modes(r["json"].get("m.json", {}), 640.0) if r["rc"] == 0 else []
        n_flags += row(lines, "  its FRF", "modes", r, [])
        lines.append(f"{'':<48} {'; '.join(extra) or 'no flag'}: " + ", ".join(
            f"{m['natural_freq']:.5g} Hz zeta {100 * m['damping_ratio']:.3f} +- {100 * m['damping_ratio_std']:.3f} %"
            for m in r["json"].get("m.json", {}).get("modes", [])))
        for f in ("rig.toml", "disk.uff", "dummy_200N_r1.uff"):
            shutil.copy(DATA / f, tdp / f)
        (tdp / "empty.uff").write_bytes(b"")
        (tdp / "trunc.uff").write_bytes((DATA / "dummy_500N_r1.uff").read_bytes()[:20000])
        (tdp / "dir.uff").mkdir()
        rows = "".join(f'[[measurement]]\nid = "{i}"\nfile = "{f}"\nbearing = "dummy"\nradial_load = 200.0\n'
                       for i, f in (("ok", "dummy_200N_r1.uff"), ("empty", "empty.uff"), ("trunc", "trunc.uff"),
                                    ("dir", "dir.uff"), ("missing", "missing.uff"), ("disk", "disk.uff")))
        (tdp / "c.toml").write_text('rig = "rig.toml"\ncalibration = "disk.uff"\n[defaults]\nband = [150.0, 1000.0]\n'
                                    "[bearings.dummy]\nk_lower = 31.14e6\nk_upper = 34.12e6\n" + rows)
        r = run(["campaign", str(tdp / "c.toml"), "-o", "{out}/camp"], expect=None)
        extra = [] if r["rc"] == 3 else [f"exit {r['rc']}, expected 3 (partial failure)"]
        n_flags += row(lines, "campaign with 5 broken rows", "campaign", r, extra)
        lines += [f"{'':<48} {ln.strip()[:150]}" for ln in r["out"].splitlines() if ln.startswith("  ")][:6]

    lines += head_h
    n_flags += truth_coverage(lines)

    lines += ["", "== D. warnings by how many runs of a command they fire on (numbers and file blanked)"]
    for cmd, cnt in warn_count.items():
        lines.append(f"{cmd} ({runs_per_cmd[cmd]} runs):")
        for w, c in cnt.most_common():
            lines.append(f"  {c:>3}  {w}")
    lines += ["", f"end {time.strftime('%Y-%m-%d %H:%M:%S', time.gmtime())} UTC, load {os.getloadavg()}; "
              f"flags {n_flags}"]
    print("\n".join(lines))


if __name__ == "__main__":
    main()
