"""Mode-shape correlation: MAC, auto-MAC and MPC.

Functions
---------
mac
    Modal assurance criterion between two sets of (complex) shapes.
mpc
    Modal phase collinearity of each shape.

Notes
-----
``MAC(a, b) = |a^H b|^2 / ((a^H a) (b^H b))`` is 1 for shapes that differ only by a complex
scale and 0 for orthogonal ones. It is implemented here (three lines of numpy) rather than
taken from sdypy-EMA, because importing ``sdypy.EMA`` imports matplotlib.pyplot; the
cross-check test compares both.
"""

from __future__ import annotations

from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray


def mac(phi_a: ArrayLike, phi_b: ArrayLike | None = None) -> NDArray[np.float64]:
    """Modal assurance criterion.

    Parameters
    ----------
    phi_a : array_like, shape (n_a, n_dof) or (n_dof,)
        Shapes, one per row (complex or real).
    phi_b : array_like, shape (n_b, n_dof) or (n_dof,), optional
        Second set; default ``phi_a`` (auto-MAC).

    Returns
    -------
    ndarray, shape (n_a, n_b)
        MAC values in [0, 1]; 0 where a shape is all zero.

    Examples
    --------
    >>> mac([[1, 0], [1, 1]]).round(3)
    array([[1. , 0.5],
           [0.5, 1. ]])
    """
    a = np.atleast_2d(np.asarray(phi_a, dtype=np.complex128))
    b = a if phi_b is None else np.atleast_2d(np.asarray(phi_b, dtype=np.complex128))
    if a.shape[1] != b.shape[1]:
        raise ValueError(f"shapes must have the same number of DOFs, got {a.shape[1]} and {b.shape[1]}")
    num = np.abs(a.conj() @ b.T) ** 2
    den = np.outer(np.sum(np.abs(a) ** 2, axis=1), np.sum(np.abs(b) ** 2, axis=1))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
    return cast("NDArray[np.float64]", np.clip(out.real, 0.0, 1.0))


def mpc(phi: ArrayLike) -> NDArray[np.float64]:
    """Modal phase collinearity of each shape (Pappa et al.).

    Parameters
    ----------
    phi : array_like, shape (n_modes, n_dof) or (n_dof,)
        Complex shapes, one per row.

    Returns
    -------
    ndarray, shape (n_modes,)
        1 for a real (monophase) shape, down to 0 for a shape whose real and imaginary parts
        are uncorrelated and equally large.

    Notes
    -----
    ``MPC = ((l1 - l2) / (l1 + l2))^2`` with ``l1 >= l2`` the eigenvalues of the 2x2
    covariance of the real and imaginary parts of the (mean-free is not applied) shape.
    """
    p = np.atleast_2d(np.asarray(phi, dtype=np.complex128))
    re, im = p.real, p.imag
    sxx = np.sum(re * re, axis=1)
    syy = np.sum(im * im, axis=1)
    sxy = np.sum(re * im, axis=1)
    tr = sxx + syy
    disc = np.sqrt(np.maximum((sxx - syy) ** 2 + 4 * sxy**2, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(tr > 0, (disc / np.where(tr > 0, tr, 1.0)) ** 2, 0.0)
    return out


__all__ = ["mac", "mpc"]
