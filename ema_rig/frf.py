"""The central data object: a matrix of frequency response functions.

Classes
-------
FRFData
    Frozen container: ``freq`` (Hz), complex ``frf`` of shape ``(n_out, n_in, n_freq)``, output and
    input DOFs, sensor roles and axes, FRF form and SI unit.

Functions
---------
frf_unit
    SI unit string of an FRF form (``"m/s^2/N"`` for accelerance).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any, Literal, cast

import numpy as np
from numpy.typing import NDArray

from .dof import DOF, as_dof
from .literals import FrfForm

FRF_FORMS: tuple[str, ...] = ("accelerance", "mobility", "receptance")
FORM_POWER = {"receptance": 0, "mobility": 1, "accelerance": 2}
"""Power of ``j omega`` that turns a receptance into each FRF form (0, 1, 2)."""
_FORM_POWER = FORM_POWER  # the old private name, kept while the branches in flight land
_FORM_UNIT = {"receptance": "m/N", "mobility": "m/s/N", "accelerance": "m/s^2/N"}


def frf_unit(frf_form: FrfForm) -> str:
    """SI unit string of an FRF form.

    Parameters
    ----------
    frf_form : {'accelerance', 'mobility', 'receptance'}

    Returns
    -------
    str
        ``'m/s^2/N'``, ``'m/s/N'`` or ``'m/N'``.
    """
    try:
        return _FORM_UNIT[frf_form]
    except KeyError:
        raise ValueError(f"frf_form must be one of {FRF_FORMS}, got {frf_form!r}") from None


def _freeze(meta: Mapping[str, Any] | None) -> Mapping[str, Any]:
    return MappingProxyType(dict(meta or {}))


def _frozen(x: Any, dtype: type) -> bool:
    """True when ``x`` is an ndarray of ``dtype`` that nobody can write to.

    It and every array it is a view of are read-only, and the memory at the end of that chain
    is the array's own or an immutable ``bytes``: such an array can be kept without a copy
    (a slice of an FRFData, or an array a reader built and froze).
    """
    if not (isinstance(x, np.ndarray) and x.dtype == dtype):
        return False
    while isinstance(x, np.ndarray):
        if x.flags.writeable:
            return False
        x = x.base
    return x is None or isinstance(x, bytes)


def _check_coherence(coherence: Any, shape: tuple[int, ...]) -> NDArray[np.float64]:
    """A read-only float64 coherence array (a copy unless already frozen), checked against the FRF shape and 0..1."""
    if _frozen(coherence, np.float64):
        coh = coherence
    else:
        coh = np.array(coherence, copy=True)
        if np.iscomplexobj(coh):
            raise ValueError("coherence must be real (it is |gamma|^2, unit-less)")
        coh = coh.astype(np.float64, copy=False)
    if coh.shape != shape:
        raise ValueError(f"coherence must have the FRF shape {shape}, got {coh.shape}")
    if not np.all(np.isfinite(coh)):
        raise ValueError("coherence contains NaN or inf values")
    if coh.size and not (coh.min() >= 0.0 and coh.max() <= 1.0):
        raise ValueError(f"coherence values must lie in 0..1, got {coh.min():g}..{coh.max():g}")
    coh.setflags(write=False)
    return cast("NDArray[np.float64]", coh)


@dataclass(frozen=True, slots=True, eq=False)
class FRFData:
    """A matrix of frequency response functions on a common frequency axis.

    Parameters
    ----------
    freq : array_like, shape (n_freq,)
        Frequency axis in Hz, finite and strictly increasing, >= 0.
    frf : array_like, shape (n_out, n_in, n_freq)
        Complex FRFs in SI units of ``frf_form`` (``m/s^2/N`` for accelerance).
    out_dofs : sequence of DOF or str, length n_out
        Response DOFs (already sign-corrected: a sensor mounted along -Y appears as +Y).
    in_dofs : sequence of DOF or str, length n_in
        Reference (excitation) DOFs.
    frf_form : {'accelerance', 'mobility', 'receptance'}, optional
        Default 'accelerance'.
    roles : sequence of str or None, length n_out, optional
        Sensor role of each output (``'housing'``, ``'spindle'``) from the rig file.
    axes : sequence of str or None, length n_out, optional
        Sensor axis of each output (``'radial'``, ``'lateral'``, ``'axial'``).
    meta : mapping, optional
        Provenance (source file, unit decisions, UFF header ids, ``warnings``). Read-only.
    coherence : array_like, shape (n_out, n_in, n_freq), optional
        Ordinary coherence ``gamma^2`` of each FRF (unit-less, float64, finite, 0 <= value <= 1),
        e.g. from UFF58 function type 6 datasets. None when not known for every FRF.
    n_averages : float, optional
        Number of averages behind the FRFs and the coherence (>= 1; an effective, non-integer
        number where overlapped segments are not independent), None when unknown. The one place
        this number lives: readers, ``--averages`` and the rig file's ``[identification]
        n_averages`` all set it here.

    Notes
    -----
    Instances are immutable: every method returns a new object and the arrays are made
    read-only. Arrays are copied unless already frozen (read-only down to their memory),
    so ``band`` returns views of the same lines without a copy. ``unit_str`` is derived from ``frf_form``; data are always stored in SI.
    ``coherence`` follows every selection (``band``, ``sel``, ``to_form``).

    Examples
    --------
    >>> import numpy as np
    >>> f = np.linspace(0.0, 100.0, 5)
    >>> d = FRFData(f, np.ones((2, 1, 5), complex), ["1+Y", "2+Y"], ["1+Y"])
    >>> d.shape, d.unit_str
    ((2, 1, 5), 'm/s^2/N')
    >>> d.band(20.0, 80.0).n_freq
    3
    """

    freq: NDArray[np.float64]
    frf: NDArray[np.complex128]
    out_dofs: tuple[DOF, ...]
    in_dofs: tuple[DOF, ...]
    frf_form: FrfForm = "accelerance"
    roles: tuple[str | None, ...] = ()
    axes: tuple[str | None, ...] = ()
    meta: Mapping[str, Any] = field(default_factory=dict)
    coherence: NDArray[np.float64] | None = None
    n_averages: float | None = None

    def __post_init__(self) -> None:
        freq = np.array(self.freq, dtype=np.float64, copy=True)
        if freq.ndim != 1 or freq.size == 0:
            raise ValueError(f"freq must be a non-empty 1-D array, got shape {freq.shape}")
        if not np.all(np.isfinite(freq)):
            raise ValueError("freq contains NaN or inf values")
        if freq[0] < 0:
            raise ValueError(f"freq must be >= 0 Hz, got {freq[0]}")
        if freq.size > 1 and not np.all(np.diff(freq) > 0):
            raise ValueError("freq must be strictly increasing")
        # kept as is when already frozen (a slice of an FRFData, a reader's array), else copied
        frf = self.frf if _frozen(self.frf, np.complex128) else np.array(self.frf, dtype=np.complex128, copy=True)
        if frf.ndim != 3:
            raise ValueError(f"frf must have shape (n_out, n_in, n_freq), got {frf.shape}")
        if frf.shape[2] != freq.size:
            raise ValueError(
                f"frf has {frf.shape[2]} frequency lines but freq has {freq.size}"
            )
        out_dofs = tuple(as_dof(d) for d in self.out_dofs)
        in_dofs = tuple(as_dof(d) for d in self.in_dofs)
        if len(out_dofs) != frf.shape[0]:
            raise ValueError(f"{len(out_dofs)} out_dofs for {frf.shape[0]} outputs")
        if len(in_dofs) != frf.shape[1]:
            raise ValueError(f"{len(in_dofs)} in_dofs for {frf.shape[1]} inputs")
        if len(set(out_dofs)) != len(out_dofs):
            raise ValueError(f"duplicate output DOFs: {[str(d) for d in out_dofs]}")
        if len(set(in_dofs)) != len(in_dofs):
            raise ValueError(f"duplicate input DOFs: {[str(d) for d in in_dofs]}")
        if self.frf_form not in FRF_FORMS:
            raise ValueError(f"frf_form must be one of {FRF_FORMS}, got {self.frf_form!r}")
        roles = tuple(self.roles) if self.roles else (None,) * len(out_dofs)
        axes = tuple(self.axes) if self.axes else (None,) * len(out_dofs)
        if len(roles) != len(out_dofs) or len(axes) != len(out_dofs):
            raise ValueError("roles and axes must have one entry per output DOF")
        coherence = None if self.coherence is None else _check_coherence(self.coherence, frf.shape)
        if self.n_averages is not None and (
            isinstance(self.n_averages, bool) or not isinstance(self.n_averages, (int, float, np.integer, np.floating))
            or not np.isfinite(self.n_averages) or self.n_averages < 1
        ):
            raise ValueError(f"n_averages must be a number >= 1 or None, got {self.n_averages!r}")
        freq.setflags(write=False)
        frf.setflags(write=False)
        object.__setattr__(self, "coherence", coherence)
        n_avg = self.n_averages
        if n_avg is not None:
            n_avg = int(n_avg) if float(n_avg).is_integer() else float(n_avg)
        object.__setattr__(self, "n_averages", n_avg)
        object.__setattr__(self, "freq", freq)
        object.__setattr__(self, "frf", frf)
        object.__setattr__(self, "out_dofs", out_dofs)
        object.__setattr__(self, "in_dofs", in_dofs)
        object.__setattr__(self, "roles", roles)
        object.__setattr__(self, "axes", axes)
        object.__setattr__(self, "meta", _freeze(self.meta))

    # ------------------------------------------------------------------ shape
    @property
    def shape(self) -> tuple[int, int, int]:
        """``(n_out, n_in, n_freq)``."""
        return self.frf.shape

    @property
    def n_out(self) -> int:
        """Number of response DOFs."""
        return cast("int", self.frf.shape[0])

    @property
    def n_in(self) -> int:
        """Number of reference DOFs."""
        return cast("int", self.frf.shape[1])

    @property
    def n_freq(self) -> int:
        """Number of frequency lines."""
        return cast("int", self.frf.shape[2])

    @property
    def freq_rad(self) -> NDArray[np.float64]:
        """Frequency axis in rad/s, shape (n_freq,)."""
        return 2.0 * np.pi * self.freq

    @property
    def unit_str(self) -> str:
        """SI unit of the FRF values, e.g. ``'m/s^2/N'``."""
        return frf_unit(self.frf_form)

    @property
    def is_even(self) -> bool:
        """True when the frequency lines are equally spaced (to 1e-6 of the step)."""
        if self.n_freq < 3:
            return True
        d = np.diff(self.freq)
        return bool(np.ptp(d) <= 1e-6 * abs(d.mean()))

    def __repr__(self) -> str:
        return (
            f"FRFData({self.n_out} out x {self.n_in} in x {self.n_freq} lines, "
            f"{self.freq[0]:g}-{self.freq[-1]:g} Hz, {self.frf_form} [{self.unit_str}])"
        )

    # ------------------------------------------------------------- selection
    def band(self, freq_lower: float, freq_upper: float) -> FRFData:
        """Lines with ``freq_lower <= freq <= freq_upper`` (Hz).

        Raises
        ------
        ValueError
            If the band is empty, reversed, or holds no line of the data.
        """
        lo, hi = float(freq_lower), float(freq_upper)
        if not (np.isfinite(lo) and np.isfinite(hi)) or hi <= lo:
            raise ValueError(f"band must satisfy freq_lower < freq_upper, got {lo:g}..{hi:g} Hz")
        # the lines are strictly increasing: the band is one slice, a view of the (frozen) data
        keep = slice(int(np.searchsorted(self.freq, lo, side="left")), int(np.searchsorted(self.freq, hi, side="right")))
        if keep.stop <= keep.start:
            raise ValueError(
                f"band {lo:g}..{hi:g} Hz holds no line of the data "
                f"({self.freq[0]:g}..{self.freq[-1]:g} Hz)"
            )
        return replace(self, freq=self.freq[keep], frf=self.frf[:, :, keep], coherence=self._coh(..., keep))

    def _coh(self, *index: Any) -> NDArray[np.float64] | None:
        """The coherence indexed like the FRF (None stays None)."""
        return None if self.coherence is None else self.coherence[index]

    def _select_outputs(self, idx: Sequence[int]) -> FRFData:
        idx = list(idx)
        return replace(
            self,
            frf=self.frf[idx],
            coherence=self._coh(idx),
            out_dofs=tuple(self.out_dofs[i] for i in idx),
            roles=tuple(self.roles[i] for i in idx),
            axes=tuple(self.axes[i] for i in idx),
        )

    def sel(
        self,
        *,
        out: str | DOF | Iterable[str | DOF] | None = None,
        inp: str | DOF | Iterable[str | DOF] | None = None,
        role: str | Iterable[str] | None = None,
        axis: str | Iterable[str] | None = None,
    ) -> FRFData:
        """Select outputs by DOF, role or axis and inputs by DOF.

        Parameters
        ----------
        out, inp : DOF, str or iterable of them, optional
            Output / input DOFs to keep, in the order given.
        role : str or iterable of str, optional
            Keep outputs whose sensor role is one of these (``'housing'``, ``'spindle'``).
        axis : str or iterable of str, optional
            Keep outputs whose sensor axis is one of these (``'radial'``, ...).

        Returns
        -------
        FRFData

        Raises
        ------
        KeyError
            If a requested DOF is not in the data.
        ValueError
            If the selection is empty.
        """
        data = self
        if out is not None:
            wanted = [as_dof(out)] if isinstance(out, (str, DOF)) else [as_dof(d) for d in out]
            idx = []
            for d in wanted:
                if d not in data.out_dofs:
                    raise KeyError(f"output DOF {d} not in data ({[str(x) for x in data.out_dofs]})")
                idx.append(data.out_dofs.index(d))
            data = data._select_outputs(idx)
        if role is not None or axis is not None:
            roles = {role} if isinstance(role, str) else (set(role) if role is not None else None)
            axs = {axis} if isinstance(axis, str) else (set(axis) if axis is not None else None)
            idx = [
                i
                for i in range(data.n_out)
                if (roles is None or data.roles[i] in roles) and (axs is None or data.axes[i] in axs)
            ]
            if not idx:
                raise ValueError(f"no output with role={role!r} and axis={axis!r}")
            data = data._select_outputs(idx)
        if inp is not None:
            wanted = [as_dof(inp)] if isinstance(inp, (str, DOF)) else [as_dof(d) for d in inp]
            jdx = []
            for d in wanted:
                if d not in data.in_dofs:
                    raise KeyError(f"input DOF {d} not in data ({[str(x) for x in data.in_dofs]})")
                jdx.append(data.in_dofs.index(d))
            data = replace(data, frf=data.frf[:, jdx], coherence=data._coh(slice(None), jdx),
                           in_dofs=tuple(data.in_dofs[j] for j in jdx))
        return data

    # ------------------------------------------------------------ conversion
    def to_form(self, frf_form: FrfForm, *, at_zero: Literal["nan", "drop"] = "nan") -> FRFData:
        """Convert between accelerance, mobility and receptance.

        ``accelerance = (j w) mobility = (j w)^2 receptance`` with ``w = 2 pi freq``.

        Parameters
        ----------
        frf_form : {'accelerance', 'mobility', 'receptance'}
            Target form.
        at_zero : {'nan', 'drop'}, optional
            What to do with a 0 Hz line when the conversion divides by ``j w``: mark it NaN
            (default; the value is undefined there) or drop the line. A conversion that
            multiplies by ``j w`` gives an exact 0 at 0 Hz.

        Returns
        -------
        FRFData
        """
        frf_unit(frf_form)
        p = FORM_POWER[frf_form] - FORM_POWER[self.frf_form]
        if p == 0:
            return self
        data = self
        if p < 0 and data.freq[0] == 0.0:
            if at_zero == "drop":
                if data.n_freq == 1:
                    raise ValueError("cannot drop the only (0 Hz) line")
                data = replace(data, freq=data.freq[1:], frf=data.frf[:, :, 1:],
                               coherence=data._coh(..., slice(1, None)))
            elif at_zero != "nan":
                raise ValueError(f"at_zero must be 'nan' or 'drop', got {at_zero!r}")
        jw = 1j * data.freq_rad
        factor = np.empty_like(jw)
        nz = jw != 0
        factor[nz] = jw[nz] ** p
        factor[~nz] = 0.0 if p > 0 else np.nan
        return replace(data, frf=data.frf * factor, frf_form=frf_form)

    # ------------------------------------------------------------- summaries
    def sum_frf(self) -> NDArray[np.float64]:
        """Sum of FRF magnitudes over all outputs and inputs, shape (n_freq,), unit ``unit_str``."""
        return cast("NDArray[np.float64]", np.abs(self.frf).sum(axis=(0, 1)))

    def cmif(self) -> NDArray[np.float64]:
        """Complex mode indicator function: singular values per line.

        Returns
        -------
        ndarray, shape (min(n_out, n_in), n_freq)
            Singular values of ``frf[:, :, k]``, largest first, unit ``unit_str``.
        """
        mats = np.moveaxis(self.frf, 2, 0)
        return np.asarray(np.linalg.svd(mats, compute_uv=False).T, dtype=np.float64)

    def with_meta(self, **meta: Any) -> FRFData:
        """A copy with extra metadata entries."""
        merged = dict(self.meta)
        merged.update(meta)
        return replace(self, meta=merged)

    def replace(self, **changes: Any) -> FRFData:
        """A copy with some fields replaced (validated again)."""
        return replace(self, **changes)


__all__ = ["FORM_POWER", "FRFData", "FRF_FORMS", "FrfForm", "frf_unit"]
