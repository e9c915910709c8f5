"""Test geometry from UFF: nodes (datasets 15 and 2411) and trace lines (dataset 82), via pyuff.

Functions
---------
read_geometry
    Nodes and trace lines of a UFF file -> :class:`Geometry`.

Classes
-------
Geometry
    Frozen: node numbers, coordinates (n_nodes, 3) and trace lines as node pairs.

Notes
-----
These datasets are plain fixed-format text that pyuff reads correctly, so pyuff does the parsing
here (unlike dataset 58, see :mod:`ema_rig.io.uff`). pyuff raises bare ``Exception`` on a bad
dataset; it is turned into a :class:`~ema_rig.errors.UFFError` naming the file and the dataset.
Coordinates are returned in the file's length unit (the datasets do not state it); nodes defined
in a local coordinate system (``def_cs`` not 0) are taken as global and listed in ``notes``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from ..dof import DOF
from ..errors import UFFError

NODE_DATASETS: tuple[int, ...] = (15, 2411)
LINE_DATASET = 82


@dataclass(frozen=True, slots=True, eq=False)
class Geometry:
    """Nodes and trace lines of a test structure.

    Parameters
    ----------
    node_ids : array_like of int, shape (n_nodes,)
        Node numbers (unique).
    coords : array_like of float, shape (n_nodes, 3)
        X, Y, Z coordinates (file length unit).
    lines : sequence of (int, int), optional
        Trace lines as pairs of node numbers (each node must exist).
    source : str, optional
        File the geometry came from.
    notes : tuple of str, optional
        Assumptions made while reading.
    """

    node_ids: NDArray[np.int64]
    coords: NDArray[np.float64]
    lines: tuple[tuple[int, int], ...] = ()
    source: str = ""
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        ids = np.array(self.node_ids, dtype=np.int64).ravel()
        xyz = np.array(self.coords, dtype=np.float64)
        if xyz.shape != (ids.size, 3):
            raise ValueError(f"coords must have shape (n_nodes, 3) = ({ids.size}, 3), got {xyz.shape}")
        if np.unique(ids).size != ids.size:
            raise ValueError("node numbers must be unique")
        if not np.all(np.isfinite(xyz)):
            raise ValueError("coordinates contain NaN or inf values")
        known = set(ids.tolist())
        lines = tuple((int(a), int(b)) for a, b in self.lines)
        missing = sorted({n for ab in lines for n in ab} - known)
        if missing:
            raise ValueError(f"trace lines use node(s) {missing[:5]} that are not defined")
        ids.setflags(write=False)
        xyz.setflags(write=False)
        object.__setattr__(self, "node_ids", ids)
        object.__setattr__(self, "coords", xyz)
        object.__setattr__(self, "lines", lines)
        object.__setattr__(self, "notes", tuple(self.notes))

    @property
    def n_nodes(self) -> int:
        """Number of nodes."""
        return int(self.node_ids.size)

    def rows(self, nodes: Any) -> NDArray[np.int64]:
        """Row of each node number in ``node_ids`` (-1 where the node is not in the geometry).

        Parameters
        ----------
        nodes : array_like of int, shape (n,)

        Returns
        -------
        ndarray of int64, shape (n,)
        """
        q = np.asarray(nodes, dtype=np.int64).ravel()
        order = np.argsort(self.node_ids, kind="stable")
        srt = self.node_ids[order]
        pos = np.clip(np.searchsorted(srt, q), 0, max(srt.size - 1, 0))
        hit = srt.size > 0
        found = (srt[pos] == q) if hit else np.zeros(q.size, dtype=bool)
        return np.where(found, order[pos] if hit else -1, -1).astype(np.int64)

    def coord(self, node: int) -> NDArray[np.float64]:
        """Coordinates of one node, shape (3,).

        Raises
        ------
        KeyError
            If the node is not in the geometry.
        """
        hit = np.flatnonzero(self.node_ids == int(node))
        if hit.size == 0:
            raise KeyError(f"node {node} is not in the geometry ({self.source or 'no file'})")
        return cast("NDArray[np.float64]", self.coords[int(hit[0])])

    @property
    def size(self) -> float:
        """Largest extent of the nodes along X, Y or Z (file unit); 1.0 for a single point."""
        span = float(np.ptp(self.coords, axis=0).max()) if self.n_nodes > 1 else 0.0
        return span if span > 0 else 1.0

    def __repr__(self) -> str:
        return f"Geometry({self.n_nodes} nodes, {len(self.lines)} trace lines{', ' + self.source if self.source else ''})"


def _line_pairs(nodes: NDArray[Any]) -> list[tuple[int, int]]:
    """Consecutive node pairs of a dataset-82 trace; node 0 lifts the pen."""
    seq = [int(n) for n in np.asarray(nodes).ravel()]
    return [(a, b) for a, b in zip(seq[:-1], seq[1:], strict=True) if a != 0 and b != 0 and a != b]


def read_geometry(path: str | PathLike[str]) -> Geometry:
    """Read nodes (UFF datasets 15 / 2411) and trace lines (82) with pyuff.

    Parameters
    ----------
    path : str or path-like
        UFF file; other datasets (58, 55, 151, 164 ...) are skipped unread.

    Returns
    -------
    Geometry
        Nodes in order of first definition (a node defined twice keeps its last definition, noted), trace lines
        from every dataset 82.

    Raises
    ------
    UFFError
        Naming this file and the dataset: the file is missing, holds no node dataset, pyuff
        cannot read a node or line dataset, a node number is not an integer or a coordinate is
        NaN/inf.
    """
    import pyuff

    p = Path(path)
    if not p.is_file():
        raise UFFError("file not found" if not p.exists() else "not a file", file=p)
    try:
        uff = pyuff.UFF(str(p))
        types = [int(t) for t in np.asarray(uff.get_set_types()).ravel()]
    except Exception as exc:  # pyuff raises bare Exception on anything it cannot parse
        raise UFFError(f"pyuff cannot list the datasets: {exc}", file=p) from None
    id_parts: list[NDArray[np.int64]] = []
    xyz_parts: list[NDArray[np.float64]] = []
    lines: list[tuple[int, int]] = []
    notes: list[str] = []
    for i, t in enumerate(types):
        if t not in (*NODE_DATASETS, LINE_DATASET):
            continue
        try:
            d = uff.read_sets(i)
        except Exception as exc:  # see above
            raise UFFError(f"pyuff cannot read dataset {t}: {exc}", file=p, dataset=i) from None
        if t == LINE_DATASET:
            lines += _line_pairs(d.get("nodes", []))
            continue
        try:
            ids = np.asarray(d["node_nums"], dtype=float).ravel()
            xyz = np.column_stack([np.asarray(d[k], dtype=float).ravel() for k in ("x", "y", "z")])
        except (KeyError, ValueError) as exc:
            raise UFFError(f"dataset {t} without node numbers and coordinates ({exc})", file=p, dataset=i) from None
        if xyz.shape[0] != ids.size:
            raise UFFError(f"dataset {t}: {ids.size} node numbers for {xyz.shape[0]} coordinates", file=p, dataset=i)
        bad_id = ~np.isfinite(ids) | (ids != np.round(ids)) | (np.abs(ids) > 2**53)
        if bad_id.any():
            raise UFFError(f"dataset {t}: {int(bad_id.sum())} node number(s) that are not integers "
                           f"(first {ids[bad_id][0]!r})", file=p, dataset=i)
        bad = ~np.all(np.isfinite(xyz), axis=1)
        if bad.any():
            first = ids[bad][:5].astype(np.int64).tolist()
            raise UFFError(f"dataset {t}: {int(bad.sum())} node(s) with NaN or inf coordinates (node(s) {first})",
                           file=p, dataset=i)
        cs = np.asarray(d.get("def_cs", np.zeros(ids.size)), dtype=float).ravel()
        if np.any(cs != 0):
            notes.append(f"dataset {i}: {int(np.count_nonzero(cs))} node(s) in a local coordinate system "
                         "(taken as global)")
        id_parts.append(ids.astype(np.int64))
        xyz_parts.append(xyz)
    if not id_parts:
        raise UFFError("no node dataset (15 or 2411) in the file", file=p)
    all_ids = np.concatenate(id_parts)
    all_xyz = np.concatenate(xyz_parts)
    # a node defined again keeps its last definition: the last occurrence of each number, in
    # the order of first appearance
    rev_ids = all_ids[::-1]
    uniq, last_rev = np.unique(rev_ids, return_index=True)
    n_dup = all_ids.size - uniq.size
    if n_dup:
        counts = np.unique(all_ids, return_counts=True)
        twice = counts[0][counts[1] > 1]
        notes.append(f"{n_dup} duplicate node definition(s) of {twice.size} node(s) (e.g. {twice[:5].tolist()}); "
                     "the last definition is used")
    _, first_idx = np.unique(all_ids, return_index=True)
    order = np.argsort(first_idx, kind="stable")
    ids_all = uniq[order]
    coords = all_xyz[all_ids.size - 1 - last_rev[order]]
    known = set(ids_all.tolist())
    undefined = sorted({n for ab in lines for n in ab} - known)
    if undefined:
        notes.append(f"trace lines to {len(undefined)} undefined node(s) {undefined[:5]} dropped")
        lines = [ab for ab in lines if ab[0] in known and ab[1] in known]
    return Geometry(ids_all, coords, tuple(lines), str(p), tuple(notes))


def match_notes(geometry: Geometry, dofs: Sequence[DOF]) -> tuple[str, ...]:
    """How the response DOFs and the geometry's nodes match, as one-line notes.

    Parameters
    ----------
    geometry : Geometry
    dofs : sequence of DOF
        The measured response DOFs.

    Returns
    -------
    tuple of str
        Response nodes missing from the geometry (their shapes are not drawn), geometry nodes
        with no response DOF (drawn unmoved), and the geometry's own notes (duplicate nodes,
        local coordinate systems, dropped trace lines); empty when everything matches.
    """
    nodes = np.array(sorted({d.node for d in dofs}), dtype=np.int64)
    rows = geometry.rows(nodes)
    out = list(geometry.notes)
    missing = nodes[rows < 0]
    if missing.size:
        out.append(f"{missing.size} response node(s) not in the geometry {geometry.source or ''} "
                   f"(not drawn): {missing[:10].tolist()}")
    unused = geometry.n_nodes - int(np.count_nonzero(rows >= 0))
    if unused:
        out.append(f"{unused} of {geometry.n_nodes} geometry node(s) carry no measured DOF (drawn unmoved)")
    return tuple(out)


__all__ = ["Geometry", "LINE_DATASET", "NODE_DATASETS", "match_notes", "read_geometry"]
