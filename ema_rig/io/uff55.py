"""Mode shapes as UFF dataset 55 (data at nodes), written through pyuff.

Functions
---------
write_uff55
    One dataset 55 per mode of a :class:`~ema_rig.identification.ModalModel` (complex modes,
    analysis type 3), atomically. The model is taken as a :class:`~ema_rig.mode_shapes.ModalShapes`
    (a structural type), so this module does not import the identification layer.
uff55_sets
    The pyuff dicts that :func:`write_uff55` writes (for callers that add their own datasets).

Notes
-----
Dataset 55 stores, per node, the X, Y, Z components of the shape. A response DOF ``n+Y`` fills
the Y component of node n; components that were not measured are written as 0. Record 8 of a
complex mode holds the pole ``lambda_r`` [rad/s] and the modal constants ``A_r = 2 j w_d`` and
``B_r = -lambda_r A_r``, so that ``R_r = phi_r phi_r^T / A_r`` reproduces the model's residues
with the mass-normalised shapes of :meth:`ModalModel.mode_shapes`. The format keeps 6
significant digits (E13.5), which bounds the round trip.
"""

from __future__ import annotations

from collections.abc import Sequence
from os import PathLike
from typing import Any

import numpy as np

from .._atomic import atomic_path
from ..dof import DOF
from ..errors import UFFError
from ..mode_shapes import ModalShapes, mode_shapes_records


def check_uff55_dofs(out_dofs: Sequence[DOF]) -> None:
    """Refuse response DOFs that dataset 55 cannot hold (its complex modes: X, Y, Z translations per node).

    Parameters
    ----------
    out_dofs : sequence of DOF
        The response DOFs of the mode shapes, shape (n_out,).

    Raises
    ------
    ValueError
        Naming the rotational or scalar (direction 0) DOFs.
    """
    bad = [str(d) for d in out_dofs if not 1 <= abs(d.direction) <= 3]
    if bad:
        raise ValueError(f"dataset 55 complex modes hold X, Y, Z translations only; cannot write the "
                         f"rotational or scalar response DOF(s) {bad}")


def uff55_sets(model: ModalShapes, *, reference: DOF | str | None = None, name: str = "") -> list[dict[str, Any]]:
    """pyuff dataset-55 dicts of every mode (complex eigenvalue, analysis type 3).

    Parameters
    ----------
    model : ModalModel
        Identified modes.
    reference : DOF or str, optional
        Reference whose residues give the shapes (default as in
        :func:`ema_rig.mode_shapes.mode_shapes_records`).
    name : str, optional
        Text for the first id line (e.g. the measurement file name).

    Returns
    -------
    list of dict
        One ``pyuff.prepare_55`` dict per mode, nodes in order of first appearance.

    Raises
    ------
    ValueError
        If the model has no mode, or a response DOF is rotational or scalar (dataset 55 complex
        modes hold three translations per node).
    """
    import pyuff

    if model.n_modes == 0:
        raise ValueError("the model has no mode to write")
    check_uff55_dofs(model.out_dofs)
    recs = mode_shapes_records(model, ref=reference)
    ref = recs[0]["reference"]
    nodes: list[int] = []
    for d in model.out_dofs:
        if d.node not in nodes:
            nodes.append(d.node)
    row = {n: i for i, n in enumerate(nodes)}
    wd = model.poles.imag
    sets = []
    for r, rec in enumerate(recs):
        comp = np.zeros((3, len(nodes)), dtype=np.complex128)
        for i, d in enumerate(model.out_dofs):
            s = rec["shape"][i]
            comp[abs(d.direction) - 1, row[d.node]] = d.sign * complex(s["re"], s["im"])
        a = 2j * wd[r]
        lam = complex(model.poles[r])
        sets.append(pyuff.prepare_55(
            id1=f"{name} mode {r + 1}"[:80].strip(),
            id2=f"f = {rec['natural_freq']:.6g} Hz, damping ratio = {rec['damping_ratio']:.4g}",
            id3=f"reference {ref}, {rec['normalisation']} normalised",
            id4="ema_rig", id5="NONE",
            model_type=1, analysis_type=3, data_ch=2, spec_data_type=8, data_type=5, n_data_per_node=3,
            load_case=1, mode_n=r + 1, eig=lam, modal_a=a, modal_b=-lam * a,
            node_nums=np.array(nodes), r1=comp[0], r2=comp[1], r3=comp[2],
        ))
    return sets


def write_uff55(path: str | PathLike[str], model: ModalShapes, *, reference: DOF | str | None = None,
                name: str = "") -> None:
    """Write the modes of a model as UFF dataset 55 (one dataset per mode), atomically.

    Parameters
    ----------
    path : str or path-like
        Output file (replaced if it exists).
    model : ModalModel
        Identified modes; shapes from :meth:`ModalModel.mode_shapes`.
    reference : DOF or str, optional
        Reference whose residues give the shapes (default: the first driving point).
    name : str, optional
        Text for the first id line.

    Raises
    ------
    UFFError
        If pyuff cannot write the file.
    ValueError
        See :func:`uff55_sets`.
    """
    import pyuff

    sets = uff55_sets(model, reference=reference, name=name)
    if any(not np.all(np.isfinite(s[k])) for s in sets for k in ("r1", "r2", "r3")):
        raise ValueError("a mode shape holds NaN or inf (mass normalisation failed?); nothing written")
    try:
        with atomic_path(path) as tmp:
            pyuff.UFF(str(tmp)).write_sets(sets, mode="overwrite")
    except OSError as exc:
        raise UFFError(f"cannot write: {exc.strerror or exc}", file=path) from None
    except Exception as exc:  # pyuff's writer raises bare Exception
        raise UFFError(f"pyuff cannot write dataset 55: {exc}", file=path) from None


__all__ = ["uff55_sets", "write_uff55"]
