"""Mode shapes drawn on a large test geometry (issue 17): time for 10 shapes, drawn and saved.

A rectangular grid of ``--nodes`` nodes with trace lines between neighbours (about two lines
per node) and 10 modes of a 10-DOF chain measured at 10 of the nodes (Y direction). Each
shape is drawn with :func:`ema_rig.plot.shapes.plot_mode_shape` and saved as a 110-dpi PNG, as
``ema-rig modes --shapes --geometry`` does. The work is fixed by the geometry and the number
of shapes; the wall time is what the issue asks about (was > 300 s at 20 000 nodes).

Run::

    python benchmarks/bench_shapes.py [--nodes 20000] [--shapes 10] [--out DIR]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))


def _geometry(n_nodes: int):  # type: ignore[no-untyped-def]
    from ema_rig.io.geometry import Geometry

    nx = int(np.ceil(np.sqrt(2 * n_nodes)))
    ny = int(np.ceil(n_nodes / nx))
    ids = np.arange(1, nx * ny + 1)[:n_nodes]
    ix, iy = (ids - 1) % nx, (ids - 1) // nx
    xyz = np.column_stack([ix * 0.01, iy * 0.01, 0.002 * np.sin(ix / 7.0)])
    lines = [(int(a), int(a + 1)) for a in ids if (a - 1) % nx < nx - 1 and a + 1 <= n_nodes]
    lines += [(int(a), int(a + nx)) for a in ids if a + nx <= n_nodes]
    return Geometry(ids, xyz, lines, "grid")


def _model(nodes: list[int]):  # type: ignore[no-untyped-def]
    import scipy.linalg

    from ema_rig.identification import ModalModel

    n = len(nodes)
    m = np.eye(n)
    k = 1e5 * (2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1))
    w2, phi = scipy.linalg.eigh(k, m)
    wn = np.sqrt(w2)
    zeta = np.full(n, 0.01)
    poles = -zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)
    res = np.einsum("ir,jr->rij", phi, phi[:1]) / (2j * poles.imag)[:, None, None]
    out = tuple(f"{nd}+Y" for nd in nodes)
    return ModalModel(poles, res, np.zeros((n, 1)), np.zeros((n, 1)), out, (out[0],))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--nodes", type=int, default=20000)
    ap.add_argument("--shapes", type=int, default=10)
    ap.add_argument("--out", default=None, help="folder for the PNGs (default: a temporary one)")
    args = ap.parse_args(argv)
    from ema_rig.plot.shapes import plot_mode_shape

    geo = _geometry(args.nodes)
    measured = [int(v) for v in np.linspace(1, args.nodes, 10).astype(int)]
    model = _model(measured)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(args.out or tmp)
        out.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        for k in range(args.shapes):
            sp = plot_mode_shape(model, k % model.n_modes, geometry=geo)
            sp.figure.savefig(out / f"shape_{k + 1}.png", dpi=110)
        dt = time.perf_counter() - t0
    print(f"{geo.n_nodes} nodes, {len(geo.lines)} trace lines, {args.shapes} shapes drawn and saved in {dt:.1f} s "
          f"({dt / args.shapes:.2f} s per shape)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
