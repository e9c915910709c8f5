"""The whole identification of one measurement: pLSCF -> stabilization -> selection -> LSFD.

Functions
---------
identify
    What the stiffness pipeline and the campaign call for every measurement.

Classes
-------
Identification
    Frozen result: pole set, stabilization data, selection, modal model and per-mode spread.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import IdentificationError
from ..frf import FRFData
from .lsfd import lsfd
from .mac import mpc
from .modal import ModalModel
from .plscf import PoleSet, check_data, default_max_order, plscf, source_of
from .refine import Refinement
from .stabilization import (
    SelectedMode,
    Selection,
    StabilizationData,
    resolve_selection,
    select_modes,
    stabilize,
)


@dataclass(frozen=True, slots=True, eq=False)
class Identification:
    """Result of :func:`identify`.

    Parameters
    ----------
    poles : PoleSet
        Poles of every model order.
    stabilization : StabilizationData
        The same rows with their status letters.
    selection : Selection
        The physical modes (automatic, replayed or hand-picked).
    modes : ModalModel
        LSFD on the band with the selection's representative poles (sorted by frequency).
    natural_freq_std, damping_ratio_std : ndarray, shape (n_modes,)
        Spread of the natural frequency [Hz] and damping ratio across each mode's cluster,
        aligned with ``modes``.
    band : tuple of float
        Band [Hz] of the identification.
    refinement : Refinement or None
        The maximum-likelihood refinement when ``identify(..., refine=True)``; when it converged,
        ``modes`` is its model and the standard deviations are its Fisher-information ones.
    """

    poles: PoleSet
    stabilization: StabilizationData
    selection: Selection
    modes: ModalModel
    natural_freq_std: NDArray[np.float64]
    damping_ratio_std: NDArray[np.float64]
    band: tuple[float, float]
    refinement: Refinement | None = None

    @property
    def natural_freq(self) -> NDArray[np.float64]:
        """Natural frequencies of the modal model [Hz], shape (n_modes,)."""
        return self.modes.natural_freq

    @property
    def damping_ratio(self) -> NDArray[np.float64]:
        """Damping ratios of the modal model, shape (n_modes,)."""
        return self.modes.damping_ratio

    def best_reference(self) -> NDArray[np.intp]:
        """Index (into ``modes.in_dofs``) of the reference that excites each mode best, shape (n_modes,)."""
        mm = self.modes
        drive = [q for q, d in enumerate(mm.in_dofs) if d in mm.out_dofs]
        if drive:
            mass = np.stack([mm.modal_mass(mm.in_dofs[q]) for q in drive], axis=1)
            return np.asarray(drive)[np.argmin(mass, axis=1)]
        col = np.linalg.norm(mm.residues, axis=1)  # (n_modes, n_in)
        return np.argmax(col, axis=1)

    def best_shapes(self) -> NDArray[np.complex128]:
        """Each mode's shape from its best reference (mass-normalised at a driving point), (n_modes, n_out)."""
        mm = self.modes
        best = self.best_reference()
        out = np.empty((mm.n_modes, len(mm.out_dofs)), np.complex128)
        for q in np.unique(best):
            shapes = mm.mode_shapes(mm.in_dofs[q])
            out[best == q] = shapes[best == q]
        return out

    def to_records(self) -> list[dict[str, Any]]:
        """One dict per mode: frequency, damping, their spread, MPC, provenance, fit error.

        ``modal_mass`` holds the effective modal mass [kg] at every driving point (reference
        DOF that is also a response DOF), keyed by DOF string. ``mpc`` is computed on each
        mode's shape from the reference that excites it best (smallest effective modal mass, or
        largest residue column without a driving point).
        """
        mm = self.modes
        mpcs = mpc(self.best_shapes())
        drive = [d for d in mm.in_dofs if d in mm.out_dofs]
        masses = {str(d): mm.modal_mass(d) for d in drive}
        modes_by_pole = {m.pole: m for m in self.selection.modes}
        # a refined model keeps the PolyMAX pole of each mode in meta (same order)
        start = [complex(*p) for p in mm.meta.get("polymax_poles", [])] or [complex(p) for p in mm.poles]
        out = []
        for k in range(mm.n_modes):
            sel: SelectedMode | None = modes_by_pole.get(start[k])
            out.append(
                {
                    "natural_freq": float(mm.natural_freq[k]),
                    "damping_ratio": float(mm.damping_ratio[k]),
                    "natural_freq_std": float(self.natural_freq_std[k]),
                    "damping_ratio_std": float(self.damping_ratio_std[k]),
                    "mpc": float(mpcs[k]),
                    "n_poles": int(sel.n_poles) if sel else None,
                    "order": int(sel.order) if sel else None,
                    "provenance": sel.provenance if sel else None,
                    "modal_mass": {d: float(v[k]) for d, v in masses.items()},
                    "participation": [[float(c.real), float(c.imag)] for c in sel.participation] if sel else [],
                }
            )
        return out


def identify(
    data: FRFData,
    *,
    band: tuple[float, float] | None = None,
    max_order: int | None = None,
    freq_tol: float = 0.01,
    damping_tol: float = 0.05,
    mac_tol: float = 0.02,
    selection: Selection | None = None,
    near_tol: float = 0.03,
    residuals: bool = True,
    progress: bool = False,
    refine: bool = False,
) -> Identification:
    """Identify the physical modes of a measurement in a band.

    Parameters
    ----------
    data : FRFData
        FRFs, shape (n_out, n_in, n_freq).
    band : (float, float), optional
        ``(freq_lower, freq_upper)`` [Hz]; default the whole data.
    max_order : int, optional
        Highest model order (default :func:`~ema_rig.identification.plscf.default_max_order`:
        64 for one reference, 40 for two, i.e. companion matrices up to 64 / 80 rows).
    freq_tol, damping_tol, mac_tol : float, optional
        Stabilization tolerances (defaults 1 %, 5 %, 2 %), see
        :func:`~ema_rig.identification.stabilization.stabilize`.
    selection : Selection, optional
        A saved selection to replay (:func:`~ema_rig.identification.stabilization.resolve_selection`:
        exact on the same data, nearest mode within ``near_tol`` on other data); its band and
        maximum order are used unless ``band`` / ``max_order`` are given. Default: automatic
        selection (:func:`~ema_rig.identification.stabilization.select_modes`).
    near_tol : float, optional
        Relative frequency window for replaying a selection on other data (default 0.03).
    residuals : bool, optional
        LSFD with lower and upper residuals (default True).
    progress : bool, optional
        Progress bar over the model orders.
    refine : bool, optional
        Refine the modal model by maximum likelihood
        (:func:`~ema_rig.identification.refine.refine`, using ``data.coherence`` when present) and
        report its Fisher-information standard deviations (default False). When it does not
        converge, the PolyMAX model and cluster spreads are kept with an
        :class:`~ema_rig.errors.IdentificationWarning` giving the reason.

    Returns
    -------
    Identification

    Raises
    ------
    IdentificationError
        Band outside the data, too few lines for the order, an all-zero FRF, NaN/inf values,
        no stable pole in the band, no physical mode, or a replayed mode not found.

    Examples
    --------
    >>> import numpy as np
    >>> from ema_rig.frf import FRFData
    >>> f = np.arange(0.0, 400.5, 0.5)
    >>> jw = 2j * np.pi * f
    >>> lam = -0.01 * 2 * np.pi * 150 + 2j * np.pi * 150 * np.sqrt(1 - 0.01**2)
    >>> h = (1 / (jw - lam) + 1 / (jw - lam.conjugate()))[None, None] / (4j * np.pi * 150)
    >>> ident = identify(FRFData(f, h, ["1+Y"], ["1+Y"], frf_form="receptance"), band=(50, 350))
    >>> ident.natural_freq.round(6), ident.damping_ratio.round(6)
    (array([150.]), array([0.01]))
    """
    if selection is not None and not isinstance(selection, Selection):
        raise TypeError(f"selection must be a Selection, got {type(selection).__name__}")
    if selection is not None:
        # replay: the selection's band and order unless given explicitly
        band = selection.band if band is None else band
        max_order = selection.max_order if max_order is None and selection.max_order >= 1 else max_order
    data = check_data(data, band)
    src = source_of(data)
    if max_order is None:
        max_order = default_max_order(data.n_in)
    poles = plscf(data, max_order=max_order, progress=progress)
    stab = stabilize(poles, freq_tol=freq_tol, damping_tol=damping_tol, mac_tol=mac_tol)
    fband = stab.band
    n_stable = int(np.sum(np.isin(stab.status, ["s", "d", "v", "f"])))
    if n_stable == 0:
        raise IdentificationError(
            f"no stable pole in the band {fband[0]:g}..{fband[1]:g} Hz up to order {max_order} "
            f"({len(poles)} poles, {int(np.sum(stab.unstable))} of them unstable)",
            file=src,
        )
    if selection is None:
        sel = select_modes(stab, source=src)
        if len(sel) == 0:
            raise IdentificationError(
                f"no physical mode in the band {fband[0]:g}..{fband[1]:g} Hz: {n_stable} stable poles "
                f"but no cluster of them persists over the orders up to {max_order}",
                file=src,
            )
    else:
        try:
            sel = resolve_selection(stab, selection, tol=near_tol, source=src)
        except IdentificationError as exc:
            raise IdentificationError(exc.message, file=src) from None
    # one LSFD pole per mode; sorted by |pole| so the spreads align with the modal model
    modes = sorted(sel.modes, key=lambda m: abs(m.pole))
    unique: dict[complex, SelectedMode] = {}
    for m in modes:
        unique.setdefault(m.pole, m)
    modes = list(unique.values())
    model = lsfd(data, [m.pole for m in modes], residuals=residuals)
    meta = dict(model.meta)
    meta.update({"max_order": int(max_order), "selection": sel.to_dict()})
    model = replace(model, meta=meta)
    ident = Identification(
        poles=poles,
        stabilization=stab,
        selection=sel,
        modes=model,
        natural_freq_std=np.array([m.natural_freq_std for m in modes]),
        damping_ratio_std=np.array([m.damping_ratio_std for m in modes]),
        band=fband,
    )
    # ---- optional maximum-likelihood refinement (issue 10) ----
    if refine:
        ident = _refined(ident, data)
    return ident


def _refined(ident: Identification, data: FRFData) -> Identification:
    """``ident`` with the ML-refined modes and their standard deviations, or unchanged with a warning."""
    import warnings

    from ..errors import IdentificationWarning
    from .refine import refine as refine_model

    ref = refine_model(data, ident.modes)
    if not ref.converged:
        warnings.warn(
            f"{source_of(data) or 'data'}: ML refinement fell back to PolyMAX ({ref.reason}); "
            "the standard deviations are the pole-cluster spreads",
            IdentificationWarning,
            stacklevel=3,
        )
        return replace(ident, refinement=ref)
    for w in ref.warnings:
        if "kept at its PolyMAX pole" in w:
            w += " (its standard deviations are the pole-cluster spread)"
        warnings.warn(f"{source_of(data) or 'data'}: {w}", IdentificationWarning, stacklevel=3)
    # modes kept at their PolyMAX pole keep their cluster spread
    return replace(
        ident,
        modes=ref.model,
        natural_freq_std=np.where(np.isnan(ref.natural_freq_std), ident.natural_freq_std, ref.natural_freq_std),
        damping_ratio_std=np.where(np.isnan(ref.damping_ratio_std), ident.damping_ratio_std, ref.damping_ratio_std),
        refinement=ref,
    )


__all__ = ["Identification", "identify"]
