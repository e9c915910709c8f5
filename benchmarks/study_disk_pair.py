"""Study: why ``data/disk.uff`` at the default band merged 789.7 and 801.0 Hz into one mode (issue 18).

The bundled steel-disk file (simulator truth in ``data/disk.uff.truth.json``: 789.66 Hz, zeta 2 %,
and 801.00 Hz, zeta 1.5 %, 1.4 % apart) identified at the defaults (0-2000 Hz), with and without
``CompletenessCriteria.split_misfit``. Printed:

- the completeness machinery's view of the merged mode before the split: its PolyMAX and ML
  frequencies, the ML move in ML standard uncertainties (``_split`` needs ``split_sigmas``), the
  candidates near it (a rejected cluster needs ``JudgeCriteria.min_poles`` to enter ``_split`` or
  ``_complete``), the ML's held-pole feature (``LocalML.moved_to``);
- the band's misfit segments and their ratio to the noise;
- the local nested F test (``identification._local_f``) of each true pole added to the model's poles
  on its own lines (``_local_lines``), with its degrees of freedom and threshold;
- the two runs' modes near the pair against the truth, in standard uncertainties.

Run: ``PYTHONPATH=. python benchmarks/study_disk_pair.py``.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent


def _pole(fn: float, z: float) -> complex:
    w = 2 * np.pi * fn
    return complex(-z * w, w * np.sqrt(1 - z * z))


def main() -> None:
    from scipy.stats import f as f_dist

    from ema_rig.identification import identification as idm
    from ema_rig.identification import identify
    from ema_rig.identification.criteria import IdentificationCriteria
    from ema_rig.io.uff import read_uff58

    path = REPO / "data" / "disk.uff"
    truth = [m for m in json.loads(path.with_name("disk.uff.truth.json").read_text())["modes"]
             if 700 < m["natural_freq"] < 1000]
    data = read_uff58(path)
    seen: dict[str, object] = {}
    split = idm._split

    def spy(d, done, residuals, crit):  # type: ignore[no-untyped-def]
        seen.update(done=done, data=d, crit=crit)
        return split(d, done, residuals, crit)

    off = IdentificationCriteria()
    off = replace(off, completeness=replace(off.completeness, split_misfit=False))
    idm._split = spy  # type: ignore[assignment]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            before = identify(data, criteria=off)
    finally:
        idm._split = split
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        after = identify(data)
    done, d, crit = seen["done"], seen["data"], seen["crit"]
    cc = crit.completeness  # type: ignore[attr-defined]
    ml = done.fitted[1]  # type: ignore[attr-defined]
    f = d.freq  # type: ignore[attr-defined]
    fn_ml = np.abs(ml.poles) / (2 * np.pi)
    k = int(np.argmin(np.abs(fn_ml - 797.7)))
    f_pm = abs(complex(*done.fitted[2][k])) / (2 * np.pi)  # type: ignore[attr-defined]
    print(f"# benchmarks/study_disk_pair.py: data/disk.uff at the default band ({f[0]:g}..{f[-1]:g} Hz, "
          f"{f.size} lines, {d.n_out} outputs x {d.n_in} reference)")
    print(f"merged mode: PolyMAX {f_pm:.3f} Hz, ML {fn_ml[k]:.3f} +/- {ml.natural_freq_std[k]:.3f} Hz, kind "
          f"{ml.kind[k]}; ML move {fn_ml[k] - f_pm:+.3f} Hz = {(fn_ml[k] - f_pm) / ml.natural_freq_std[k]:.2f} sigma "
          f"(_split needs > {cc.split_sigmas:g} sigma towards a rejected cluster)")
    mt = None if ml.moved_to is None else ml.moved_to[k]
    print("held-pole feature (LocalML.moved_to):", "none" if mt is None or not np.isfinite(mt) else f"{abs(mt) / 2 / np.pi:.3f} Hz")
    print(f"candidates within 30 Hz (a cluster enters _split/_complete with >= {crit.judge.min_poles} poles):")
    for c in done.candidates:
        if abs(c.natural_freq - fn_ml[k]) < 30:
            print(f"  {c.natural_freq:9.3f} Hz  poles {c.mode.n_poles:3d}  accepted {c.accepted!s:5}  {c.reason[:70]}")
    t = done.test
    print("misfit segments (residual / noise) of the model before the split:")
    for a, b, r, bad in zip(t.freq_lower, t.freq_upper, t.ratio, t.failed, strict=True):
        if bad or a <= fn_ml[k] <= b:
            print(f"  {a:7.1f}..{b:7.1f} Hz  {r:7.2f}{'  FAILS' if bad else ''}")
    null = [complex(p) for p in ml.poles]
    print("local nested F test of each true pole over the model's poles, on its own lines:")
    for m in truth:
        if not 780 < m["natural_freq"] < 810:
            continue
        half = cc.local_hbw * m["damping_ratio"] * m["natural_freq"]
        sl = (f >= m["natural_freq"] - half) & (f <= m["natural_freq"] + half)
        res = idm._local_f(d, null, [*null, _pole(m["natural_freq"], m["damping_ratio"])], sl, t.variance, cc)
        if res is None:
            print(f"  {m['natural_freq']:.2f} Hz: the fit failed")
            continue
        stat, q, dof = res
        print(f"  {m['natural_freq']:.2f} Hz on {f[sl][0]:.1f}..{f[sl][-1]:.1f} Hz: F = {stat:.1f} with ({q:.0f}, {dof:.0f}) "
              f"dof; threshold at p = {cc.local_p:g}: {f_dist.isf(cc.local_p, q, dof):.2f}")
    for name, ident in (("split_misfit off (as main, ec07f23)", before), ("split_misfit on", after)):
        fn, s_f = ident.natural_freq, ident.natural_freq_std
        zeta, s_z = ident.damping_ratio, ident.damping_ratio_std
        print(f"{name}: {fn.size} modes; near the truth of 700-1000 Hz:")
        for m in truth:
            j = int(np.argmin(np.abs(fn - m["natural_freq"])))
            print(f"  truth {m['natural_freq']:8.3f} Hz zeta {100 * m['damping_ratio']:.2f} %: {fn[j]:8.3f} +/- {s_f[j]:.3f} Hz "
                  f"({(fn[j] - m['natural_freq']) / s_f[j]:+6.1f} sigma), zeta {100 * zeta[j]:.3f} +/- {100 * s_z[j]:.3f} % "
                  f"({(zeta[j] - m['damping_ratio']) / s_z[j]:+6.1f} sigma)")
        warn = [w for w in ident.warnings if "79" in w or "80" in w]
        print("  warnings naming the pair:", warn or "none")


if __name__ == "__main__":
    main()
