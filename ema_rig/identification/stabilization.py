"""Stabilization bookkeeping and automatic selection of physical modes.

Functions
---------
stabilize
    Status letter of every pole from its nearest neighbour at the previous model order.
select_modes
    Cluster stable poles across orders into physical modes (provenance ``"auto"``).
select_near
    For given frequencies, the nearest automatically found mode (provenance ``"near"``).
select_poles
    Modes from hand-picked ``(order, index)`` pairs (provenance ``"manual"``).
resolve_selection
    Replay a saved :class:`Selection` on (possibly other) data.

Classes
-------
StabilizationData
    The :class:`~ema_rig.identification.plscf.PoleSet` rows plus ``status`` and ``unstable``.
SelectedMode, Selection
    The chosen modes with their spread across the cluster; JSON round trip.

Notes
-----
Status letters (per pole, against the closest pole in frequency among the stable poles of the
previous computed order)::

    o  new pole (no neighbour within the frequency tolerance, or the pole itself is unstable)
    f  frequency stable          |df| / f            <= freq_tol     (default 1 %)
    d  frequency and damping     |dzeta| / zeta      <= damping_tol  (default 5 %)
    v  frequency and vector      1 - MAC(l, l_prev)  <= mac_tol      (default 2 %)
    s  all three

For one reference the participation "vector" is a scalar, the MAC is 1 and ``v`` reduces to
``f``. Unstable poles (``Re lambda >= 0``) are mathematical poles by construction of the
estimator (see :mod:`ema_rig.identification.plscf`): they are always ``o`` and flagged in
``unstable``.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._atomic import write_text
from ..errors import IdentificationError
from .criteria import STABILIZATION_CRITERIA, StabilizationCriteria
from .mac import mac
from .plscf import PoleSet

STATUS_LETTERS: tuple[str, ...] = ("o", "f", "d", "v", "s")
STATUS_LABELS: Mapping[str, str] = MappingProxyType(
    {
        "o": "new / unstable",
        "f": "stable frequency",
        "d": "stable frequency + damping",
        "v": "stable frequency + vector",
        "s": "stable frequency + damping + vector",
    }
)
PROVENANCES: tuple[str, ...] = ("auto", "near", "manual", "tracked")


@dataclass(frozen=True, slots=True, eq=False)
class StabilizationData:
    """Poles of all orders with their stabilization status (tidy, one row per pole).

    Parameters
    ----------
    poles : PoleSet
        The estimator's output.
    status : ndarray of str, shape (n_poles,)
        One of ``o f d v s`` per row.
    tolerances : mapping
        ``freq_tol``, ``damping_tol``, ``mac_tol`` used.
    """

    poles: PoleSet
    status: NDArray[np.str_]
    tolerances: Mapping[str, float] = field(default_factory=dict)

    def __repr__(self) -> str:
        n_s = int(np.count_nonzero(self.status == "s"))
        return f"StabilizationData({len(self.status)} poles, {n_s} stable in all criteria; {self.poles!r})"

    def __post_init__(self) -> None:
        st = np.asarray(self.status, dtype="<U1").copy()
        if st.shape != (len(self.poles),):
            raise ValueError(f"status must have shape ({len(self.poles)},), got {st.shape}")
        bad = set(np.unique(st)) - set(STATUS_LETTERS)
        if bad:
            raise ValueError(f"unknown status letters {sorted(bad)}; allowed {STATUS_LETTERS}")
        st.setflags(write=False)
        object.__setattr__(self, "status", st)
        object.__setattr__(self, "tolerances", MappingProxyType(dict(self.tolerances)))

    def __len__(self) -> int:
        return len(self.poles)

    # delegated tidy columns --------------------------------------------------
    @property
    def order(self) -> NDArray[np.int64]:
        """Model order per row, shape (n_poles,)."""
        return self.poles.order

    @property
    def pole(self) -> NDArray[np.complex128]:
        """Pole [rad/s] per row, shape (n_poles,)."""
        return self.poles.pole

    @property
    def natural_freq(self) -> NDArray[np.float64]:
        """``|lambda| / 2 pi`` [Hz], shape (n_poles,)."""
        return self.poles.natural_freq

    @property
    def damping_ratio(self) -> NDArray[np.float64]:
        """``-Re lambda / |lambda|``, shape (n_poles,)."""
        return self.poles.damping_ratio

    @property
    def participation(self) -> NDArray[np.complex128]:
        """Participation vectors, shape (n_poles, n_in)."""
        return self.poles.participation

    @property
    def unstable(self) -> NDArray[np.bool_]:
        """True for poles with ``Re lambda >= 0`` (mathematical poles), shape (n_poles,)."""
        return self.poles.pole.real >= 0

    @property
    def band(self) -> tuple[float, float]:
        """Band [Hz] of the estimate."""
        return self.poles.band

    @property
    def orders(self) -> tuple[int, ...]:
        """Computed model orders."""
        return self.poles.orders

    def counts(self) -> dict[str, int]:
        """Number of poles per status letter (plus ``"unstable"``)."""
        out = {k: int(np.sum(self.status == k)) for k in STATUS_LETTERS}
        out["unstable"] = int(np.sum(self.unstable))
        return out

    def index_in_order(self, row: int) -> int:
        """Position of PoleSet row ``row`` among its order's poles sorted by frequency."""
        return int(np.flatnonzero(self.poles.at_order(int(self.order[row])) == row)[0])

    def row_of(self, order: int, index: int) -> int:
        """PoleSet row of the ``index``-th pole (by frequency) of model order ``order``."""
        rows = self.poles.at_order(int(order))
        if not 0 <= index < rows.size:
            raise IndexError(f"order {order} has {rows.size} poles in the band, no index {index}")
        return int(rows[index])


def stabilize(
    poles: PoleSet,
    *,
    freq_tol: float | None = None,
    damping_tol: float | None = None,
    mac_tol: float | None = None,
    criteria: StabilizationCriteria | None = None,
) -> StabilizationData:
    """Classify every pole against the previous model order.

    Parameters
    ----------
    poles : PoleSet
        Output of :func:`~ema_rig.identification.plscf.plscf`.
    freq_tol : float, optional
        Relative natural-frequency tolerance (default 0.01).
    damping_tol : float, optional
        Relative damping-ratio tolerance (default 0.05).
    mac_tol : float, optional
        Tolerance on ``1 - MAC`` of the participation vectors (default 0.02).
    criteria : StabilizationCriteria, optional
        The three tolerances with their sources
        (:class:`~ema_rig.identification.criteria.StabilizationCriteria`); each keyword given
        replaces its field.

    Returns
    -------
    StabilizationData

    Examples
    --------
    See :func:`ema_rig.identification.identify` for the whole chain.
    """
    crit = STABILIZATION_CRITERIA if criteria is None else criteria
    freq_tol = crit.freq_tol if freq_tol is None else freq_tol
    damping_tol = crit.damping_tol if damping_tol is None else damping_tol
    mac_tol = crit.mac_tol if mac_tol is None else mac_tol
    for name, v in (("freq_tol", freq_tol), ("damping_tol", damping_tol), ("mac_tol", mac_tol)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a positive number, got {v!r}")
    n = len(poles)
    status = np.full(n, "o", dtype="<U1")
    fn = poles.natural_freq
    zeta = poles.damping_ratio
    part = poles.participation
    stable_pole = poles.pole.real < 0
    # every order's poles (by frequency) against the stable poles of the order before it, all orders at once
    groups = [poles.at_order(order) for order in poles.orders]
    prev = [g[stable_pole[g]] for g in groups]
    n_prev = np.array([p.size for p in prev], dtype=np.intp)
    asked = [i for i in range(1, len(groups)) if n_prev[i - 1] and groups[i].size]
    if asked:
        cur = np.concatenate([groups[i] for i in asked])
        g_cur = np.repeat(np.array(asked, dtype=np.intp) - 1, [groups[i].size for i in asked])  # the order before
        p_rows = np.concatenate(prev)  # by order, then by frequency (each order's at_order)
        p_start = np.concatenate([[0], np.cumsum(n_prev)[:-1]]).astype(np.intp)
        # searchsorted of each pole among its previous order's stable poles: how many of them lie below it
        # (one merged sort by order, frequency, and the asked pole first among equal frequencies)
        g_all = np.concatenate([np.repeat(np.arange(len(groups)), n_prev), g_cur])
        f_all = np.concatenate([fn[p_rows], fn[cur]])
        is_p = np.concatenate([np.ones(p_rows.size, np.intp), np.zeros(cur.size, np.intp)])
        merged = np.lexsort((is_p, f_all, g_all))
        below = np.empty(merged.size, np.intp)
        below[merged] = np.cumsum(is_p[merged])
        size = n_prev[g_cur]
        j = below[p_rows.size:] - p_start[g_cur]
        lo = p_start[g_cur] + np.clip(j - 1, 0, size - 1)
        hi = p_start[g_cur] + np.clip(j, 0, size - 1)
        f_cur = fn[cur]
        ref = p_rows[np.where(np.abs(fn[p_rows[lo]] - f_cur) <= np.abs(fn[p_rows[hi]] - f_cur), lo, hi)]
        df = np.abs(f_cur - fn[ref]) / fn[ref]
        with np.errstate(invalid="ignore", divide="ignore"):
            dz = np.abs(zeta[cur] - zeta[ref]) / np.abs(zeta[ref])
        num = np.abs(np.sum(part[cur].conj() * part[ref], axis=1)) ** 2
        den = np.sum(np.abs(part[cur]) ** 2, axis=1) * np.sum(np.abs(part[ref]) ** 2, axis=1)
        dm = 1.0 - num / np.where(den > 0, den, 1.0)
        ok_f = (df <= freq_tol) & stable_pole[cur]
        ok_d = ok_f & (dz <= damping_tol)
        ok_v = ok_f & (dm <= mac_tol)
        status[cur] = np.where(ok_d & ok_v, "s", np.where(ok_d, "d", np.where(ok_v, "v", np.where(ok_f, "f", "o"))))
    return StabilizationData(
        poles, status, {"freq_tol": freq_tol, "damping_tol": damping_tol, "mac_tol": mac_tol}
    )


# ------------------------------------------------------------------------------ selection
@dataclass(frozen=True, slots=True)
class SelectedMode:
    """One selected mode.

    Parameters
    ----------
    order, index : int
        Model order and position (by frequency) among that order's poles of the
        representative pole (the cluster member closest to the cluster median).
    pole : complex
        Representative pole [rad/s], ``Im > 0``.
    natural_freq, damping_ratio : float
        Mean over the cluster [Hz], [-].
    natural_freq_std, damping_ratio_std : float
        Standard deviation over the cluster (0 for a single pole).
    n_poles : int
        Cluster size (one pole per order at most).
    provenance : {'auto', 'near', 'manual'}
        How the mode was chosen.
    participation : tuple of complex
        Participation vector of the representative pole.
    order_min, order_max : int
        Lowest and highest model order at which the mode's cluster has a pole (the orders
        over which it is stable; 0 when unknown).
    """

    order: int
    index: int
    pole: complex
    natural_freq: float
    damping_ratio: float
    natural_freq_std: float
    damping_ratio_std: float
    n_poles: int
    provenance: str = "auto"
    participation: tuple[complex, ...] = ()
    order_min: int = 0
    order_max: int = 0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (pole and participation as [re, im] pairs)."""
        return {
            "order": int(self.order),
            "index": int(self.index),
            "pole": [float(self.pole.real), float(self.pole.imag)],
            "natural_freq": float(self.natural_freq),
            "damping_ratio": float(self.damping_ratio),
            "natural_freq_std": float(self.natural_freq_std),
            "damping_ratio_std": float(self.damping_ratio_std),
            "n_poles": int(self.n_poles),
            "provenance": self.provenance,
            "participation": [[float(c.real), float(c.imag)] for c in self.participation],
            "order_min": int(self.order_min),
            "order_max": int(self.order_max),
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> SelectedMode:
        """Inverse of :meth:`to_dict`.

        Raises
        ------
        ValueError, TypeError, KeyError, OverflowError
            ``d`` is no mode as :meth:`to_dict` writes it (not an object, a key missing, a pole
            that is not finite or not above the real axis, a natural frequency that is not finite
            and positive, a damping ratio that is not finite, an integer out of range).
        """
        if not isinstance(d, Mapping):
            raise TypeError(f"each mode must be an object, got {type(d).__name__}")
        prov = str(d.get("provenance", "manual"))
        if prov not in PROVENANCES:
            raise ValueError(f"provenance must be one of {PROVENANCES}, got {prov!r}")
        re, im = d["pole"]
        pole = complex(float(re), float(im))
        f_n, zeta = float(d["natural_freq"]), float(d["damping_ratio"])
        if not (np.isfinite(pole) and pole.imag > 0):
            raise ValueError(f"pole must be finite with Im > 0 [rad/s], got {pole}")
        if not (np.isfinite(f_n) and f_n > 0 and np.isfinite(zeta)):
            raise ValueError(f"natural_freq must be finite and positive and damping_ratio finite, "
                             f"got {f_n} Hz, {zeta}")
        return cls(
            order=int(d["order"]),
            index=int(d["index"]),
            pole=pole,
            natural_freq=f_n,
            damping_ratio=zeta,
            natural_freq_std=float(d.get("natural_freq_std", 0.0)),
            damping_ratio_std=float(d.get("damping_ratio_std", 0.0)),
            n_poles=int(d.get("n_poles", 1)),
            provenance=prov,
            participation=tuple(complex(float(a), float(b)) for a, b in d.get("participation", [])),
            order_min=int(d.get("order_min", 0)),
            order_max=int(d.get("order_max", 0)),
        )


@dataclass(frozen=True, slots=True)
class Selection:
    """The physical modes chosen from a stabilization diagram.

    Parameters
    ----------
    modes : tuple of SelectedMode
        Sorted by natural frequency.
    band : tuple of float
        Band [Hz] of the estimate the modes were chosen from.
    max_order : int
        Highest model order of that estimate.
    tolerances : mapping
        Stabilization and clustering tolerances used.
    in_dofs : tuple of str
        Reference DOFs (participation columns).
    source : str or None
        Where the selection was made (file name), for the record.

    Notes
    -----
    A selection replays exactly on the data it was made on (same ``(order, index)`` and pole)
    and by nearest frequency on other data (provenance ``"near"``), see
    :func:`resolve_selection`.
    """

    modes: tuple[SelectedMode, ...]
    band: tuple[float, float]
    max_order: int
    tolerances: Mapping[str, float] = field(default_factory=dict)
    in_dofs: tuple[str, ...] = ()
    source: str | None = None

    def __post_init__(self) -> None:
        modes = tuple(sorted(self.modes, key=lambda m: m.natural_freq))
        object.__setattr__(self, "modes", modes)
        object.__setattr__(self, "band", (float(self.band[0]), float(self.band[1])))
        object.__setattr__(self, "tolerances", MappingProxyType(dict(self.tolerances)))
        object.__setattr__(self, "in_dofs", tuple(str(d) for d in self.in_dofs))

    def __len__(self) -> int:
        return len(self.modes)

    def __repr__(self) -> str:
        """One line: the modes' frequencies with their provenance, band, order and source."""
        freqs = ", ".join(f"{m.natural_freq:.1f}" for m in self.modes[:8]) + (", ..." if len(self.modes) > 8 else "")
        kinds = sorted({m.provenance for m in self.modes})
        return (f"Selection({len(self.modes)} modes [{', '.join(kinds)}]: {freqs} Hz; band "
                f"{self.band[0]:g}-{self.band[1]:g} Hz, order {self.max_order}; source {self.source})")

    @property
    def poles(self) -> NDArray[np.complex128]:
        """Representative poles [rad/s], shape (n_modes,)."""
        return np.array([m.pole for m in self.modes], dtype=np.complex128)

    @property
    def natural_freq(self) -> NDArray[np.float64]:
        """Cluster-mean natural frequencies [Hz], shape (n_modes,)."""
        return np.array([m.natural_freq for m in self.modes], dtype=np.float64)

    @property
    def damping_ratio(self) -> NDArray[np.float64]:
        """Cluster-mean damping ratios, shape (n_modes,)."""
        return np.array([m.damping_ratio for m in self.modes], dtype=np.float64)

    @property
    def natural_freq_std(self) -> NDArray[np.float64]:
        """Spread of the natural frequency across each cluster [Hz], shape (n_modes,)."""
        return np.array([m.natural_freq_std for m in self.modes], dtype=np.float64)

    @property
    def damping_ratio_std(self) -> NDArray[np.float64]:
        """Spread of the damping ratio across each cluster, shape (n_modes,)."""
        return np.array([m.damping_ratio_std for m in self.modes], dtype=np.float64)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "format": "ema_rig.selection/1",
            "source": self.source,
            "band": list(self.band),
            "max_order": int(self.max_order),
            "in_dofs": list(self.in_dofs),
            "tolerances": {k: float(v) for k, v in self.tolerances.items()},
            "modes": [m.to_dict() for m in self.modes],
        }

    def to_json(self, path: str | PathLike[str] | None = None) -> str:
        """Serialise to JSON; also write it (atomically) to ``path`` when given."""
        text = json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n"
        if path is not None:
            write_text(path, text)
        return text

    @classmethod
    def from_json(cls, text_or_path: str | PathLike[str]) -> Selection:
        """Read a selection from a JSON string or a file path.

        Raises
        ------
        IdentificationError
            The text is not a selection written by :meth:`to_json`.
        """
        src: str | None = None
        text = str(text_or_path)
        if isinstance(text_or_path, PathLike) or not text.lstrip().startswith("{"):
            src = str(text_or_path)
            text = Path(text_or_path).read_text(encoding="utf-8")
        try:
            d = json.loads(text)
            if not isinstance(d, dict):
                raise TypeError(f"expected a JSON object, got {type(d).__name__}")
            if d.get("format") != "ema_rig.selection/1":
                raise ValueError(f"format must be 'ema_rig.selection/1', got {d.get('format')!r}")
            if not isinstance(d["modes"], list):
                raise TypeError(f"modes must be a list, got {type(d['modes']).__name__}")
            if not d["modes"]:
                raise ValueError("it holds no mode (nothing to replay)")
            band = d["band"]
            if isinstance(band, str) or len(band) != 2:
                raise ValueError(f"band must be [low, high] in Hz, got {band!r}")
            lo, hi = float(band[0]), float(band[1])
            if not (np.isfinite(lo) and np.isfinite(hi) and 0 <= lo < hi):
                raise ValueError(f"band must be finite with 0 <= low < high, got {lo}..{hi} Hz")
            max_order = int(d["max_order"])
            if max_order < 1:
                raise ValueError(f"max_order must be a positive integer, got {max_order}")
            return cls(
                modes=tuple(SelectedMode.from_dict(m) for m in d["modes"]),
                band=(lo, hi),
                max_order=max_order,
                tolerances={str(k): float(v) for k, v in dict(d.get("tolerances", {})).items()},
                in_dofs=tuple(str(x) for x in d.get("in_dofs", ())),
                source=d.get("source"),
            )
        except KeyError as exc:
            raise IdentificationError(f"not a valid mode selection: key {exc} missing", file=src) from None
        except (ValueError, TypeError, OverflowError) as exc:
            raise IdentificationError(f"not a valid mode selection: {exc}", file=src) from None

    def to_records(self) -> list[dict[str, Any]]:
        """One dict per mode."""
        return [m.to_dict() for m in self.modes]


def order_ranks(stab: StabilizationData) -> NDArray[np.intp]:
    """For every row, its position among its order's poles sorted by frequency (all rows at once)."""
    key = np.lexsort((stab.natural_freq, stab.order))
    ranks = np.empty(len(stab), np.intp)
    first = np.searchsorted(stab.order[key], stab.order[key], side="left")
    ranks[key] = np.arange(key.size) - first
    return ranks


def _mode_from_rows(stab: StabilizationData, rows: NDArray[np.intp], provenance: str,
                    ranks: NDArray[np.intp] | None = None) -> SelectedMode:
    """The mode of one cluster (rows of ``stab``): :func:`_modes_from_rows` of the one cluster."""
    return _modes_from_rows(stab, [rows], provenance, ranks)[0]


def _segment_medians(x: NDArray[np.float64], starts: NDArray[np.intp], sizes: NDArray[np.intp]
                     ) -> NDArray[np.float64]:
    """``np.median`` of each segment ``x[s:s + n]`` (segments side by side, none empty), shape (n_seg,).

    The middle value, or the mean of the two middle values (``(a + b) / 2``, as ``np.median`` forms
    it), of each segment sorted; NaN for a segment holding a NaN, as ``np.median`` gives.
    """
    seg = np.repeat(np.arange(sizes.size), sizes)
    xs = x[np.lexsort((x, seg))]  # sorted within each segment (NaN last)
    lo = xs[starts + (sizes - 1) // 2]
    hi = xs[starts + sizes // 2]
    med = np.where(sizes % 2 == 1, lo, (lo + hi) / 2.0)
    nan = np.add.reduceat(np.isnan(x).astype(np.intp), starts) > 0
    return np.where(nan, np.nan, med)


def _modes_from_rows(stab: StabilizationData, clusters: Sequence[NDArray[np.intp]], provenance: str,
                     ranks: NDArray[np.intp] | None = None) -> list[SelectedMode]:
    """The mode of each cluster of rows of ``stab`` (none empty), formed for all clusters at once.

    Natural frequency and damping ratio: the mean over the cluster's poles, their standard deviation
    (``ddof = 1``; 0 for one pole); the representative pole the member nearest to the cluster's
    medians (``|f - f_med| / f_med + 0.05 |zeta - zeta_med| / |zeta_med|``, the first of equal ones).
    The elementwise steps run over the clusters side by side, the sums per cluster (the pairwise sums of
    ``np.mean`` and ``np.std``): the same numbers as one cluster at a time.
    ``ranks``: :func:`order_ranks` of ``stab`` when the caller has it.
    """
    if not clusters:
        return []
    sizes = np.array([r.size for r in clusters], dtype=np.intp)
    if np.any(sizes == 0):
        raise ValueError("a cluster without rows has no mode")
    rows = np.concatenate(clusters).astype(np.intp, copy=False)
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.intp)
    fn = stab.natural_freq[rows]
    zeta = stab.damping_ratio[rows]
    mf = _segment_medians(fn, starts, sizes)
    mz = _segment_medians(zeta, starts, sizes)
    mf_r, mz_r = np.repeat(mf, sizes), np.repeat(mz, sizes)
    score = np.abs(fn - mf_r) / mf_r + 0.05 * np.abs(zeta - mz_r) / np.repeat(np.maximum(np.abs(mz), 1e-12), sizes)
    # sums per cluster: np.add.reduce of each cluster's contiguous part, the pairwise sum np.mean and np.std
    # form (np.add.reduceat adds in another order)
    bounds = list(zip(starts.tolist(), (starts + sizes).tolist(), strict=True))

    def sums(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.array([np.add.reduce(x[a:b]) for a, b in bounds])

    mean_f, mean_z = sums(fn) / sizes, sums(zeta) / sizes
    ddof = np.where(sizes > 1, 1, 0)

    def std(x: NDArray[np.float64], mean: NDArray[np.float64]) -> NDArray[np.float64]:
        d = x - np.repeat(mean, sizes)
        d *= d
        out: NDArray[np.float64] = np.sqrt(sums(d) / (sizes - ddof))
        return out

    std_f, std_z = std(fn, mean_f), std(zeta, mean_z)
    orders = stab.order[rows]
    o_min, o_max = np.minimum.reduceat(orders, starts), np.maximum.reduceat(orders, starts)
    reps = np.array([rows[a + int(np.argmin(score[a:b]))] for a, b in bounds], dtype=np.intp)
    poles = stab.pole[reps].tolist()
    parts = stab.participation[reps].tolist()
    return [SelectedMode(order=int(stab.order[rep]),
                         index=stab.index_in_order(rep) if ranks is None else int(ranks[rep]), pole=complex(poles[i]),
                         natural_freq=float(mean_f[i]), damping_ratio=float(mean_z[i]),
                         natural_freq_std=float(std_f[i]), damping_ratio_std=float(std_z[i]),
                         n_poles=int(sizes[i]), provenance=provenance,
                         participation=tuple(complex(c) for c in parts[i]),
                         order_min=int(o_min[i]), order_max=int(o_max[i]))
            for i, rep in enumerate(reps.tolist())]


def _linkage_labels(
    stab: StabilizationData, cand: NDArray[np.intp], freq_tol: float, damping_tol: float, mac_tol: float
) -> NDArray[np.intp]:
    """Average-linkage cluster labels of the candidate rows, cut at distance 1.

    Candidates are sorted by frequency and cut wherever two neighbours are more than
    ``freq_tol`` apart: every pair across such a gap is farther than 1, so average linkage
    never joins them and each chunk is clustered on its own (linear in the number of chunks
    instead of quadratic in the number of poles).
    """
    from scipy.cluster.hierarchy import fcluster, linkage

    zeta = stab.damping_ratio
    labels = np.zeros(cand.size, np.intp)
    if cand.size == 0:
        return labels
    order = np.argsort(stab.natural_freq[cand], kind="stable")
    fs = stab.natural_freq[cand[order]]
    gap = np.diff(fs) / (0.5 * (fs[1:] + fs[:-1])) > freq_tol
    starts = np.concatenate([[0], np.flatnonzero(gap) + 1, [cand.size]])
    next_label = 1
    for a, b in zip(starts[:-1], starts[1:], strict=True):
        idx = order[a:b]
        if idx.size == 1:
            labels[idx] = next_label
            next_label += 1
            continue
        rows = cand[idx]
        fn = stab.natural_freq[rows]
        zc = zeta[rows]
        df = np.abs(fn[:, None] - fn[None, :]) / (0.5 * (fn[:, None] + fn[None, :])) / freq_tol
        dz = np.abs(zc[:, None] - zc[None, :]) / (0.5 * (zc[:, None] + zc[None, :])) / damping_tol
        dist = np.maximum(df, dz)
        if stab.poles.n_in > 1:
            dist = np.maximum(dist, (1.0 - mac(stab.participation[rows])) / mac_tol)
        if dist.max() <= 1.0:  # every pair within the tolerances: one cluster, as linkage would give
            labels[idx] = next_label
            next_label += 1
            continue
        iu = np.triu_indices(idx.size, 1)
        lab = fcluster(linkage(dist[iu], method="average"), t=1.0, criterion="distance")
        labels[idx] = lab + next_label - 1
        next_label += int(lab.max())
    return labels


def cluster_poles(
    stab: StabilizationData,
    *,
    statuses: Iterable[str] = ("s",),
    freq_tol: float | None = None,
    damping_tol: float | None = None,
    mac_tol: float | None = None,
    max_damping: float = 0.2,
    criteria: StabilizationCriteria = STABILIZATION_CRITERIA,
) -> list[NDArray[np.intp]]:
    """Every cluster of candidate poles (rows of ``stab``), one pole per order, by frequency.

    Candidates are the poles with a status in ``statuses`` and damping in ``(0, max_damping]``;
    clustering as in :func:`select_modes`, without any size threshold. The distance scales
    ``freq_tol``, ``damping_tol``, ``mac_tol`` default to the ``cluster_*`` fields of ``criteria``
    (:class:`~ema_rig.identification.criteria.StabilizationCriteria`: 0.005, 0.5, 0.1, with their
    sources); given, they replace them.
    """
    freq_tol, damping_tol, mac_tol = criteria.cluster_scales(freq_tol, damping_tol, mac_tol)
    wanted = set(statuses)
    if not wanted <= set(STATUS_LETTERS):
        raise ValueError(f"statuses must be among {STATUS_LETTERS}, got {sorted(wanted)}")
    zeta = stab.damping_ratio
    cand = np.flatnonzero(
        np.isin(stab.status, list(wanted)) & (zeta > 0) & (zeta <= max_damping) & ~stab.unstable
    )
    labels = _linkage_labels(stab, cand, freq_tol, damping_tol, mac_tol)
    if cand.size == 0:
        return []
    # each label's rows (ascending, as cand holds them), one pole per order: the one closest to the
    # label's median frequency (all labels at once: the medians by one sort, then one sort by label,
    # order and distance to the median, the first of each order kept)
    by_label = np.argsort(labels, kind="stable")
    rows, lab = cand[by_label], labels[by_label]
    sizes = np.diff(np.flatnonzero(np.concatenate([[True], lab[1:] != lab[:-1], [True]])))
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.intp)
    fn = stab.natural_freq[rows]
    med = _segment_medians(fn, starts, sizes)
    group = np.repeat(np.arange(sizes.size), sizes)
    order = stab.order[rows]
    key = np.lexsort((np.abs(fn - np.repeat(med, sizes)), order, group))
    rows, order, group = rows[key], order[key], group[key]
    first = np.ones(rows.size, bool)
    first[1:] = (order[1:] != order[:-1]) | (group[1:] != group[:-1])
    rows, group = rows[first], group[first]
    cut = np.flatnonzero(np.concatenate([[True], group[1:] != group[:-1]]))
    out = np.split(rows, cut[1:])
    at = _segment_medians(stab.natural_freq[rows], cut.astype(np.intp), np.diff(np.concatenate([cut, [rows.size]])))
    return [out[i] for i in sorted(range(len(out)), key=lambda i: float(at[i]))]


def select_modes(
    stab: StabilizationData,
    *,
    statuses: Iterable[str] = ("s",),
    freq_tol: float | None = None,
    damping_tol: float | None = None,
    mac_tol: float | None = None,
    min_fraction: float = 0.2,
    min_poles: int = 3,
    max_damping: float = 0.2,
    source: str | None = None,
) -> Selection:
    """Cluster stable poles across orders into physical modes.

    Parameters
    ----------
    stab : StabilizationData
        Output of :func:`stabilize`.
    statuses : iterable of str, optional
        Status letters that make a pole a candidate (default only ``s``).
    freq_tol : float, optional
        Clustering scale for the relative frequency distance (default
        ``StabilizationCriteria.cluster_freq_tol``, 0.005).
    damping_tol : float, optional
        Clustering scale for the relative damping distance (default
        ``StabilizationCriteria.cluster_damping_tol``, 0.5).
    mac_tol : float, optional
        Clustering scale for ``1 - MAC`` of the participation vectors (default
        ``StabilizationCriteria.cluster_mac_tol``, 0.1; ignored for one reference).
    min_fraction : float, optional
        A cluster needs poles at ``min_fraction`` of the computed orders (default 0.2) ...
    min_poles : int, optional
        ... and at least ``min_poles`` poles (default 3).
    max_damping : float, optional
        Clusters with mean damping ratio outside ``(0, max_damping]`` are dropped as
        unphysical (default 0.2).
    source : str, optional
        Recorded in the selection.

    Returns
    -------
    Selection
        Modes sorted by frequency with provenance ``"auto"``; empty if nothing qualifies.

    Notes
    -----
    The distance between two candidate poles is the largest of ``|df| / f / freq_tol``,
    ``|dzeta| / zeta / damping_tol`` and ``(1 - MAC) / mac_tol``; clusters are formed by
    average linkage cut at 1 (``scipy.cluster.hierarchy``). Each cluster keeps at most one
    pole per order (the one closest to the cluster's median frequency); the mode reports the
    mean and standard deviation over those poles and, as its representative pole, the member
    closest to the cluster median.
    """
    freq_tol, damping_tol, mac_tol = STABILIZATION_CRITERIA.cluster_scales(freq_tol, damping_tol, mac_tol)
    tol = {
        **dict(stab.tolerances),
        "cluster_freq_tol": freq_tol,
        "cluster_damping_tol": damping_tol,
        "cluster_mac_tol": mac_tol,
        "min_fraction": min_fraction,
        "min_poles": min_poles,
        "max_damping": max_damping,
    }
    clusters = cluster_poles(stab, statuses=statuses, freq_tol=freq_tol, damping_tol=damping_tol,
                             mac_tol=mac_tol, max_damping=max_damping)
    sel_kw: dict[str, Any] = {
        "band": stab.band,
        "max_order": max(stab.orders) if stab.orders else 0,
        "tolerances": tol,
        "in_dofs": tuple(str(d) for d in stab.poles.in_dofs),
        "source": source,
    }
    need = max(min_poles, int(np.ceil(min_fraction * len(stab.orders))))
    modes = []
    for rows in clusters:
        if rows.size < need:
            continue
        m = _mode_from_rows(stab, rows, "auto")
        if not (0 < m.damping_ratio <= max_damping):
            continue
        if not (stab.band[0] <= m.natural_freq <= stab.band[1]):
            continue
        modes.append(m)
    return Selection(modes=tuple(modes), **sel_kw)


def _neighbours(stab: StabilizationData, row: int, freq_tol: float) -> NDArray[np.intp]:
    """Non-unstable poles within ``freq_tol`` of a pole, one per order (closest)."""
    fn = stab.natural_freq
    f0 = fn[row]
    ok = (np.abs(fn - f0) <= freq_tol * f0) & ~stab.unstable & (stab.status != "o")
    ok[row] = True
    rows = np.flatnonzero(ok)
    key = np.lexsort((np.abs(fn[rows] - f0), stab.order[rows]))
    rows = rows[key]
    first = np.ones(rows.size, bool)
    first[1:] = stab.order[rows][1:] != stab.order[rows][:-1]
    rows = rows[first]
    # the picked pole itself represents its own order
    rows = np.concatenate([[row], rows[(stab.order[rows] != stab.order[row])]])
    return rows.astype(np.intp)


def select_poles(
    stab: StabilizationData,
    picks: Sequence[tuple[int, int]],
    *,
    freq_tol: float = 0.005,
    provenance: str = "manual",
    source: str | None = None,
) -> Selection:
    """Modes from hand-picked poles.

    Parameters
    ----------
    stab : StabilizationData
    picks : sequence of (order, index)
        ``index`` is the position of the pole among its order's poles sorted by frequency
        (what :meth:`StabilizationData.index_in_order` returns).
    freq_tol : float, optional
        Relative window in which the non-new poles of the other orders count towards the
        mode's mean and spread (default 0.005).
    provenance : str, optional
        Recorded provenance (default ``"manual"``).
    source : str, optional
        Recorded in the selection.

    Returns
    -------
    Selection
        The representative pole of each mode is the picked pole itself.

    Raises
    ------
    IdentificationError
        A picked pole is unstable (``Re lambda >= 0``; its participation is not computed).
    """
    if provenance not in PROVENANCES:
        raise ValueError(f"provenance must be one of {PROVENANCES}, got {provenance!r}")
    modes = []
    for order, index in picks:
        row = stab.row_of(order, index)
        if stab.unstable[row]:
            raise IdentificationError(
                f"pole {index} of order {order} ({stab.natural_freq[row]:.6g} Hz) is unstable (Re lambda >= 0): "
                "never a physical mode; pick a stable pole", file=source)
        rows = _neighbours(stab, row, freq_tol)
        m = _mode_from_rows(stab, rows, provenance)
        modes.append(
            SelectedMode(
                order=int(order),
                index=int(index),
                pole=complex(stab.pole[row]),
                natural_freq=m.natural_freq,
                damping_ratio=m.damping_ratio,
                natural_freq_std=m.natural_freq_std,
                damping_ratio_std=m.damping_ratio_std,
                n_poles=m.n_poles,
                provenance=provenance,
                participation=tuple(complex(c) for c in stab.participation[row]),
            )
        )
    return Selection(
        modes=tuple(modes),
        band=stab.band,
        max_order=max(stab.orders) if stab.orders else 0,
        tolerances={**dict(stab.tolerances), "cluster_freq_tol": freq_tol},
        in_dofs=tuple(str(d) for d in stab.poles.in_dofs),
        source=source,
    )


def select_near(
    stab: StabilizationData,
    natural_freq: Iterable[float],
    *,
    tol: float = 0.03,
    auto: Selection | None = None,
    source: str | None = None,
) -> Selection:
    """For each requested frequency, the nearest mode found in ``stab``.

    Parameters
    ----------
    stab : StabilizationData
    natural_freq : iterable of float
        Requested natural frequencies [Hz].
    tol : float, optional
        Largest relative distance accepted (default 0.03).
    auto : Selection, optional
        Automatic selection of ``stab`` (computed with default settings when omitted); its
        modes are preferred, otherwise the nearest stable (``s``/``d``) pole is taken.
    source : str, optional
        Recorded in the selection.

    Returns
    -------
    Selection
        Provenance ``"near"``, one mode per requested frequency.

    Raises
    ------
    IdentificationError
        Nothing stable within ``tol`` of a requested frequency.
    """
    auto = select_modes(stab) if auto is None else auto
    modes = []
    for f in natural_freq:
        f = float(f)
        best: SelectedMode | None = None
        if len(auto):
            k = int(np.argmin(np.abs(auto.natural_freq - f)))
            if abs(auto.natural_freq[k] - f) <= tol * f:
                best = auto.modes[k]
        if best is None:
            ok = np.flatnonzero(np.isin(stab.status, ["s", "d"]) & ~stab.unstable)
            if ok.size:
                k = ok[np.argmin(np.abs(stab.natural_freq[ok] - f))]
                if abs(stab.natural_freq[k] - f) <= tol * f:
                    rows = _neighbours(stab, int(k), 0.005)
                    best = _mode_from_rows(stab, rows, "near")
        if best is None:
            raise IdentificationError(
                f"no stable mode within {100 * tol:g} % of the selected {f:g} Hz "
                f"(band {stab.band[0]:g}..{stab.band[1]:g} Hz)"
            )
        d = best.to_dict()
        d["provenance"] = "near"
        modes.append(SelectedMode.from_dict(d))
    return Selection(
        modes=tuple(modes),
        band=stab.band,
        max_order=max(stab.orders) if stab.orders else 0,
        tolerances={**dict(stab.tolerances), "near_tol": tol},
        in_dofs=tuple(str(d) for d in stab.poles.in_dofs),
        source=source,
    )


def resolve_selection(
    stab: StabilizationData,
    selection: Selection,
    *,
    tol: float = 0.03,
    source: str | None = None,
    track_tol: float = 0.2,
) -> Selection:
    """Replay a saved selection on ``stab``.

    A mode whose ``(order, index)`` exists in ``stab`` with the same pole (to 1e-9 relative)
    is taken as it is (same data): its provenance is kept. Every other mode is replaced by the
    nearest mode found in ``stab`` within ``tol`` (:func:`select_near`, provenance ``"near"``).
    Modes that moved further (another load, another speed) are *tracked* when frequency order
    makes it one to one: as many automatically selected modes of ``stab`` are left unclaimed as
    selected modes are lost, and each pair (in frequency order) lies within ``track_tol``; they get
    provenance ``"tracked"`` — :func:`~ema_rig.identification.identify` warns
    about every tracked mode, since frequency order alone decided the correspondence.

    Raises
    ------
    IdentificationError
        A mode of the selection has no counterpart, not even a tracked one.
    """
    exact: list[SelectedMode] = []
    todo: list[float] = []
    for m in selection.modes:
        try:
            row = stab.row_of(m.order, m.index)
        except IndexError:
            row = -1
        if row >= 0 and not stab.unstable[row] and abs(stab.pole[row] - m.pole) <= 1e-9 * abs(m.pole):
            exact.append(m)
        else:
            todo.append(m.natural_freq)
    found: list[SelectedMode] = []
    lost: list[float] = []
    auto: Selection | None = None
    for f in todo:
        auto = select_modes(stab) if auto is None else auto
        try:
            found.extend(select_near(stab, [f], tol=tol, auto=auto, source=source).modes)
        except IdentificationError:
            lost.append(f)
    if lost:
        assert auto is not None
        claimed = {round(m.natural_freq, 9) for m in (*exact, *found)}
        free = sorted((m for m in auto.modes if round(m.natural_freq, 9) not in claimed),
                      key=lambda m: m.natural_freq)
        lost.sort()
        # frequency order decides only when it is one to one: as many free automatic modes as lost ones
        pairs = list(zip(lost, free, strict=True)) if len(free) == len(lost) else []
        if not pairs or any(abs(m.natural_freq - f) > track_tol * f for f, m in pairs):
            raise IdentificationError(
                f"no stable mode within {100 * tol:g} % of the selected {lost[0]:g} Hz, and it cannot be "
                f"tracked by frequency order ({len(lost)} selected mode(s) lost, {len(free)} free automatic "
                f"mode(s), tracking limit {100 * track_tol:g} %; band {stab.band[0]:g}..{stab.band[1]:g} Hz)"
            )
        for _, best in pairs:
            d = best.to_dict()
            d["provenance"] = "tracked"
            found.append(SelectedMode.from_dict(d))
    modes = tuple(sorted((*exact, *found), key=lambda m: m.natural_freq))
    return Selection(
        modes=modes,
        band=stab.band,
        max_order=max(stab.orders) if stab.orders else 0,
        tolerances=dict(selection.tolerances),
        in_dofs=tuple(str(d) for d in stab.poles.in_dofs),
        source=source if source is not None else selection.source,
    )


__all__ = [
    "PROVENANCES",
    "STATUS_LABELS",
    "STATUS_LETTERS",
    "SelectedMode",
    "Selection",
    "StabilizationData",
    "cluster_poles",
    "resolve_selection",
    "select_modes",
    "select_near",
    "select_poles",
    "stabilize",
]
