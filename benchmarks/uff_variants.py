"""UFF58 variants that exporters write and the shared corpus lacks, read through ema_rig (not collected by pytest).

Every file is written by the small fixed-format writer below (from the UFF58 record layouts: record 6
``2(I5,I10),2(1X,10A1,I10,I4)``, record 7 ``3I10,3E13.5``, records 8-11 ``I10,3I5,2(1X,20A1)``, data
``E13.5`` / ``E20.12``, 58b header ``I6,1A1,I6,I6,I12,I12,...``), not by ema_rig's writer. Each variant
states what a correct reader returns: the FRF of a 1 kg oscillator (60 Hz, 2 %) in SI on the written
lines, or a refusal. Run ``PYTHONPATH=. python benchmarks/uff_variants.py [OUT_DIR]``; it prints one line
per variant (``ok``, ``refused (expected)``, ``MISREAD``, ``READ (should refuse)``, ``REFUSED (should
read)``) and exits 1 if any variant is not as expected.
"""

from __future__ import annotations

import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

from ema_rig.errors import UFFError
from ema_rig.io.uff import read_uff58

G, LBF, INCH = 9.80665, 4.4482216152605, 0.0254
F = np.arange(1, 201) * 2.5  # Hz
W, WN = 2 * np.pi * F, 2 * np.pi * 60.0
H = -(W**2) / (WN**2 - W**2 + 2j * 0.02 * WN * W)  # accelerance, m/s^2/N


def _axis(code: int, le: int, fe: int, lab: str, unit: str) -> str:
    return f"{code:10d}{le:5d}{fe:5d}{0:5d} {lab:<20s} {unit:<20s}"


def _header(ft: int = 4, rsp: tuple[int, int] = (11, 2), ref: tuple[int, int] = (1, 2), odt: int = 6,
            spacing: int = 1, n: int = F.size, x0: float = F[0], dx: float = F[1] - F[0],
            xaxis: tuple = (18, 0, 0, "Frequency", "Hz"), yaxis: tuple = (12, 1, 0, "Acceleration", "m/s^2"),
            daxis: tuple = (13, 0, 1, "Force", "N"), ents: tuple[str, str] = ("NONE", "NONE")) -> list[str]:
    return ["exporter variant", "NONE", "08-Dec-26 04:00:00", "NONE", "NONE",
            f"{ft:5d}{1:10d}{0:5d}{0:10d} {ents[0]:<10s}{rsp[0]:10d}{rsp[1]:4d} {ents[1]:<10s}{ref[0]:10d}{ref[1]:4d}",
            f"{odt:10d}{n:10d}{spacing:10d}{x0:13.5E}{dx:13.5E}{0.0:13.5E}",
            _axis(*xaxis), _axis(*yaxis), _axis(*daxis), _axis(0, 0, 0, "NONE", "NONE")]


def ascii58(y: np.ndarray = H, x: np.ndarray = F, eol: str = "\n", **kw: object) -> bytes:
    odt, spacing = int(kw.get("odt", 6)), int(kw.get("spacing", 1))
    cplx, dbl = odt in (5, 6), odt in (4, 6)
    fy = "%20.12E" if dbl else "%13.5E"
    if spacing == 1:
        flat = np.column_stack([y.real, y.imag]).ravel() if cplx else y.real
        per = 4 if dbl else 6
        body = ["".join(fy % v for v in flat[i:i + per]) for i in range(0, flat.size, per)]
    else:
        body = [f"{xi:13.5E}" + "".join(fy % v for v in ((yi.real, yi.imag) if cplx else (yi.real,)))
                for xi, yi in zip(x, y, strict=True)]
    return eol.join(["    -1", "    58", *_header(**kw), *body, "    -1"]).encode("latin-1") + eol.encode()


def binary58(y: np.ndarray = H, x: np.ndarray = F, bo: int = 1, xs: int = 0, eol: str = "\n", **kw: object) -> bytes:
    odt, spacing = int(kw.get("odt", 6)), int(kw.get("spacing", 1))
    e, s = ("<" if bo == 1 else ">"), (8 if odt in (4, 6) else 4)
    cols = [y.real, y.imag] if odt in (5, 6) else [y.real]
    fields = ([("x", f"{e}f{xs or s}")] if spacing == 0 else []) + [(f"y{i}", f"{e}f{s}") for i in range(len(cols))]
    rec = np.empty(y.size, dtype=np.dtype(fields))
    if spacing == 0:
        rec["x"] = x
    for i, c in enumerate(cols):
        rec[f"y{i}"] = c
    payload = rec.tobytes()
    head = f"{58:6d}b{bo:6d}{2:6d}{11:12d}{len(payload):12d}{0:6d}{0:6d}{0:12d}{0:12d}"
    return (eol.join(["    -1", head, *_header(**kw)]) + eol).encode("latin-1") + payload + f"    -1{eol}".encode()


def ds164(length: float, force: float, desc: str) -> bytes:
    def d(v: float) -> str:
        return f"{v:25.17E}".replace("E", "D")
    return "\n".join(["    -1", "   164", f"{2:10d}{desc:<20s}{2:10d}", d(length) + d(force) + d(1.8), d(459.67),
                      "    -1", ""]).encode()


def coh58(values: np.ndarray, unit: str) -> bytes:
    return ascii58(values.astype(complex), ft=6, odt=4, yaxis=(0, 0, 0, "Coherence", unit), daxis=(0, 0, 0, "NONE", "NONE"))


def _free_axes(buf: bytes) -> bytes:
    lines = buf.decode("latin-1").split("\n")
    lines[9:13] = ["18 0 0 0 Frequency Hz", "12 1 0 0 Acceleration g", "13 0 1 0 Force N", "0 0 0 0 NONE NONE"]
    return "\n".join(lines).encode("latin-1")


def _blank_lines_in_data(buf: bytes) -> bytes:
    lines = buf.split(b"\n")
    return b"\n".join(lines[:13] + [ln + (b"\n" if i % 7 == 3 else b"") for i, ln in enumerate(lines[13:-2])]
                      + lines[-2:])


COH = 0.9 + 0.09 * np.sin(F / 10.0)
INCH164 = ds164(1 / INCH, 1 / LBF, "Inch (pound f)")
#: name -> (file bytes, expected SI accelerance or None for a refusal, what it exercises)
VARIANTS: dict[str, tuple[bytes, np.ndarray | None, str]] = {
    "ascii_double": (ascii58(), H, "E20.12, 4 per line"),
    "ascii_single": (ascii58(odt=5), H, "E13.5, 6 per line"),
    "crlf": (ascii58(eol="\r\n"), H, "CRLF line ends"),
    "cr_only": (ascii58(eol="\r"), H, "CR line ends"),
    "trailing_blanks": (ascii58().replace(b"\n", b"   \n"), H, "blanks after every line"),
    "blank_lines_in_data": (_blank_lines_in_data(ascii58()), H, "empty lines between data lines"),
    "fortran_D": (ascii58().replace(b"E+", b"D+").replace(b"E-", b"D-"), H, "D exponents"),
    "tabs": (ascii58().replace(b"  ", b"\t"), H, "tabs for blanks"),
    "uneven_double": (ascii58(spacing=0), H, "explicit abscissa, E13.5 + 2E20.12"),
    "58b_le_double": (binary58(), H, "58b little-endian"),
    "58b_be_single": (binary58(bo=2, odt=5), H, "58b big-endian float32"),
    "58b_uneven_x32": (binary58(spacing=0, xs=4), H, "58b double, float32 abscissa"),
    "58b_crlf": (binary58(eol="\r\n"), H, "58b CRLF"),
    "g_label": (ascii58(H / G, yaxis=(12, 1, 0, "Acceleration", "g")), H, "ordinate in g"),
    "mm_kN": (ascii58(H * 1e6, yaxis=(12, 1, 0, "A", "mm/s^2"), daxis=(13, 0, 1, "F", "kN")), H, "mm/s^2 per kN"),
    "g_per_lbf_whole": (ascii58(H / G * LBF, yaxis=(12, 1, 0, "A", "g/lbf"), daxis=(13, 0, 1, "F", "lbf")), H,
                        "whole-FRF label, same force below"),
    "inch164_first": (INCH164 + ascii58(H / INCH * LBF, yaxis=(12, 1, 0, "A", "NONE"),
                                        daxis=(13, 0, 1, "F", "NONE")), H, "dataset 164 before"),
    "rad_per_s": (ascii58(x0=2 * np.pi * F[0], dx=2 * np.pi * 2.5, xaxis=(18, 0, 0, "w", "rad/s")), H, "rad/s"),
    "neg_response": (ascii58(-H, rsp=(11, -2)), H, "response 11-Y"),
    "neg_both": (ascii58(H, rsp=(11, -2), ref=(1, -2)), H, "11-Y / 1-Y"),
    "dir0_response": (ascii58(H, rsp=(11, 0)), H, "scalar response"),
    "entity_dof_dot": (ascii58(-H, rsp=(0, 0), ref=(0, 0), ents=("11.Y-", "1.Y+")), H, "DOF in entity '11.Y-'"),
    "entity_dof_sign_first": (ascii58(H, rsp=(0, 0), ref=(0, 0), ents=("11+Y", "1:+Y")), H, "DOF in entity '11+Y'"),
    "free_format_axes": (_free_axes(ascii58(H / G, yaxis=(12, 1, 0, "Acceleration", "g"))), H,
                         "records 8-11 blank-separated"),
    "with_151_15_55_coh_psd": (b"    -1\n   151\nmodel\nNONE\nema\n08-DEC-26\nema\n08-DEC-26\nema\n    -1\n"
                               + ascii58() + coh58(COH, "NONE") + ascii58(np.abs(H) ** 2 + 0j, ft=9, odt=4,
                                                                          yaxis=(12, 2, 0, "PSD", "g^2/Hz"))
                               + b"    -1\n    55\nNONE\nNONE\nNONE\nNONE\nNONE\n    -1\n", H, "beside 58"),
    "coh_percent": (ascii58() + coh58(100 * COH, "%"), H, "coherence in %"),
    # refusals
    "nan": (ascii58(np.where(np.arange(F.size) == 5, np.nan, H)), None, "NaN value"),
    "vax_58b": (binary58().replace(b"     1     2          11", b"     1     1          11", 1), None, "VAX floats"),
    "g_per_N_over_lbf": (ascii58(H / G, yaxis=(12, 1, 0, "A", "g/N"), daxis=(13, 0, 1, "F", "lbf")), None,
                         "labels contradict"),
    "inch164_last": (ascii58(H, yaxis=(12, 1, 0, "A", "NONE"), daxis=(13, 0, 1, "F", "NONE")) + INCH164, None,
                     "dataset 164 after"),
    "inch164_whole_exps": (INCH164 + ascii58(H, yaxis=(12, 1, -1, "A", "NONE"), daxis=(13, 0, 0, "F", "NONE")), None,
                           "FRF exponents 1,-1 / 0,0 under 164"),
    "free_axes_3_words": (_free_axes(ascii58()).replace(b"12 1 0 0 Acceleration g", b"12 1 0 0 Real Part g"), None,
                          "ambiguous labels"),
    "real_valued_frf": (ascii58(np.abs(H) + 0j, odt=4), None, "FRF as real values"),
    "order_abscissa": (ascii58(xaxis=(20, 0, 0, "Order", "NONE")), None, "abscissa in orders"),
    "transmissibility": (ascii58(ft=5, daxis=(12, 1, 0, "A", "m/s^2")), None, "function type 5 only"),
}


def main(out: Path) -> int:
    out.mkdir(parents=True, exist_ok=True)
    bad = 0
    for name, (buf, want, what) in VARIANTS.items():
        path = out / f"{name}.uff"
        path.write_bytes(buf)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                d = read_uff58(path)
        except UFFError as exc:
            verdict = "refused (expected)" if want is None else "REFUSED (should read)"
            detail = str(exc).split(": ", 1)[-1][:110]
        else:
            if want is None:
                verdict, detail = "READ (should refuse)", repr(d)
            else:
                err = float(np.max(np.abs(d.frf[0, 0] - want)) / np.max(np.abs(want)))
                ferr = float(np.max(np.abs(d.freq - F)) / F[-1])
                # 6 significant digits (E13.5) at worst, in the values and in the header's abscissa
                ok = err < 1e-5 and ferr < 1e-5 and str(d.out_dofs[0]) in ("11+Y", "11")
                detail = f"rel. error {err:.1e}, axis {ferr:.1e}, {d.out_dofs[0]} / {d.in_dofs[0]}"
                if "coh" in name:  # the coherence written beside the FRF must come back (0..1, E20.12)
                    cerr = np.inf if d.coherence is None else float(np.max(np.abs(d.coherence[0, 0] - COH)))
                    ok &= cerr < 1e-10
                    detail += f", coherence error {cerr:.1e}"
                verdict = "ok" if ok else "MISREAD"
        bad += not (verdict.startswith("ok") or verdict == "refused (expected)")
        print(f"{name:<24s} {what:<36s} {verdict:<22s} {detail}")
    print(f"{len(VARIANTS)} variants, {bad} not as expected")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="uff_variants_"))))
