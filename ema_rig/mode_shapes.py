"""Mode shapes of a modal model as plain records, and their real (normal-mode) form.

Classes
-------
ModalShapes
    What these functions (and the dataset-55 writer of :mod:`ema_rig.io.uff55`) need of a modal
    model: a structural type that :class:`ema_rig.identification.ModalModel` satisfies, so that
    this module and the io layer need not import the identification layer.

Functions
---------
mode_shapes_records
    One JSON-ready dict per mode: frequency, damping, reference, normalisation and the complex
    shape per response DOF.
real_shapes
    Complex shapes rotated to their best real approximation (for display and dataset 55 type 2).

Notes
-----
The shapes are :meth:`ema_rig.identification.ModalModel.mode_shapes`: mass-normalised
(unit 1/sqrt(kg), ``R_r = phi_r phi_r^T / (2 j w_d)``) when the reference is also a response DOF
(a driving point), else the residue column scaled to unit largest modulus (dimensionless, no
mass scaling).
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .dof import DOF, as_dof


class ModalShapes(Protocol):
    """What shape records need of a modal model (:class:`~ema_rig.identification.ModalModel` is one).

    Attributes
    ----------
    poles : ndarray, shape (n_modes,), complex128
        Poles [rad/s].
    out_dofs, in_dofs : tuple of DOF
        Response and reference DOFs.
    n_modes : int
    natural_freq : ndarray, shape (n_modes,), float64
        Undamped natural frequencies [Hz].
    damping_ratio : ndarray, shape (n_modes,), float64
        Damping ratios [-].
    """

    @property
    def poles(self) -> NDArray[np.complex128]: ...

    @property
    def out_dofs(self) -> tuple[DOF, ...]: ...

    @property
    def in_dofs(self) -> tuple[DOF, ...]: ...

    @property
    def n_modes(self) -> int: ...

    @property
    def natural_freq(self) -> NDArray[np.float64]: ...

    @property
    def damping_ratio(self) -> NDArray[np.float64]: ...

    def mode_shapes(self, reference: DOF | str | None = None) -> NDArray[np.complex128]:
        """Shapes, shape (n_modes, n_out), complex: mass-normalised at a driving point."""
        ...


def real_shapes(phi: ArrayLike) -> NDArray[np.float64]:
    """Real approximation of complex mode shapes.

    Parameters
    ----------
    phi : array_like, shape (n_modes, n_dof) or (n_dof,), complex
        Complex shapes, one per row.

    Returns
    -------
    ndarray, shape (n_modes, n_dof), float64
        ``Re(phi_r exp(-j theta_r))`` with ``theta_r`` the rotation that maximises the norm of the
        real part (``theta = angle(sum phi^2) / 2``), signed so that the largest entry is
        positive. Exact for a monophase shape (MPC = 1); the lost part grows as MPC falls.

    Examples
    --------
    >>> real_shapes([[1j, -2j]])
    array([[-1.,  2.]])
    """
    p = np.atleast_2d(np.asarray(phi, dtype=np.complex128))
    theta = 0.5 * np.angle(np.sum(p * p, axis=1))
    r = (p * np.exp(-1j * theta)[:, None]).real
    k = np.argmax(np.abs(r), axis=1)
    sign = np.sign(r[np.arange(r.shape[0]), k])
    sign[sign == 0] = 1.0
    return np.asarray(r * sign[:, None], dtype=np.float64)


def mode_shapes_records(model: ModalShapes, *, ref: DOF | str | None = None) -> list[dict[str, Any]]:
    """Mode shapes for a JSON file, one dict per mode.

    Parameters
    ----------
    model : ModalShapes
        Identified modes (a :class:`~ema_rig.identification.ModalModel`).
    ref : DOF or str, optional
        Reference whose residue column gives the shapes (default: the first driving point, i.e.
        a reference that is also a response DOF, else the first reference).

    Returns
    -------
    list of dict
        Per mode: ``mode`` (1-based), ``natural_freq`` [Hz], ``damping_ratio`` [-], ``reference``
        (DOF string), ``normalisation`` (``'mass'`` or ``'unit_max'``), ``unit``
        (``'1/sqrt(kg)'`` or None) and ``shape``: a list of ``{"dof", "re", "im", "magnitude",
        "phase_deg"}`` per response DOF (``out_dofs`` order; sign-corrected DOFs), plus
        ``real`` (:func:`real_shapes` value, same unit).

    Raises
    ------
    KeyError
        If ``ref`` is not a reference of the model.
    """
    if ref is None:
        drive = [d for d in model.in_dofs if d in model.out_dofs]
        reference = drive[0] if drive else model.in_dofs[0]
    else:
        reference = as_dof(ref)
        if reference not in model.in_dofs:
            raise KeyError(f"reference {reference} not in model ({[str(x) for x in model.in_dofs]})")
    phi = model.mode_shapes(reference)
    mass = reference in model.out_dofs
    real = real_shapes(phi) if model.n_modes else np.zeros((0, len(model.out_dofs)))
    out: list[dict[str, Any]] = []
    for r in range(model.n_modes):
        shape = [
            {
                "dof": str(d),
                "re": float(phi[r, i].real),
                "im": float(phi[r, i].imag),
                "magnitude": float(abs(phi[r, i])),
                "phase_deg": float(np.degrees(np.angle(phi[r, i]))),
                "real": float(real[r, i]),
            }
            for i, d in enumerate(model.out_dofs)
        ]
        out.append({
            "mode": r + 1,
            "natural_freq": float(model.natural_freq[r]),
            "damping_ratio": float(model.damping_ratio[r]),
            "reference": str(reference),
            "normalisation": "mass" if mass else "unit_max",
            "unit": "1/sqrt(kg)" if mass else None,
            "shape": shape,
        })
    return out


__all__ = ["ModalShapes", "mode_shapes_records", "real_shapes"]
