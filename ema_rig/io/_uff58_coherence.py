"""Private: coherence (UFF dataset 58, function type 6) as ASCII bytes.

:func:`ema_rig.io.uff.write_uff58` writes FRFs (function type 4) only; coherence is a real,
dimensionless function of frequency and needs its own header (function type 6, ordinate and
denominator specific data type 0, unit ``NONE``). The field layout is that of
:mod:`ema_rig.io._uff_write`, whose formatting helpers are reused.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..dof import DOF
from ._uff_write import fmt13, fmt_axis, format_values, line80


def coherence_bytes(freq: NDArray[np.float64], coherence: NDArray[np.float64], *, response: DOF,
                    reference: DOF, ids: tuple[str, str, str, str, str]) -> bytes:
    """The bytes of one ASCII dataset 58 holding a coherence function.

    Parameters
    ----------
    freq : ndarray, shape (n,)
        Evenly spaced frequency lines [Hz].
    coherence : ndarray, shape (n,)
        Values in [0, 1] (dimensionless); written as real double precision (ordinate type 4).
    response, reference : DOF
        The (output, input) pair.
    ids : tuple of 5 str
        The five id lines.
    """
    f = np.asarray(freq, dtype=np.float64)
    c = np.asarray(coherence, dtype=np.float64)
    if f.shape != c.shape or f.ndim != 1 or f.size < 2:
        raise ValueError(f"freq and coherence must be 1-D of the same length >= 2, got {f.shape}, {c.shape}")
    if not np.all(np.isfinite(c)):
        raise ValueError("coherence contains NaN or inf values")
    n = f.size
    head = [
        *(line80(s) for s in ids),
        f"{6:5d}{1:10d}{0:5d}{0:10d} {'NONE':<10}{response.node:10d}{response.direction:4d} "
        f"{'NONE':<10}{reference.node:10d}{reference.direction:4d}",
        f"{4:10d}{n:10d}{1:10d}" + fmt13(f[0]) + fmt13((f[-1] - f[0]) / (n - 1)) + f"{0.0:13.6E}",
        fmt_axis(18, 0, 0, "Frequency", "Hz"),
        fmt_axis(0, 0, 0, "Coherence", "NONE"),
        fmt_axis(0, 0, 0, "NONE", "NONE"),
        fmt_axis(0, 0, 0, "NONE", "NONE"),
    ]
    body = format_values(c, ["%20.12E"] * 4)
    return ("    -1\n" + f"{58:6d}" + "\n" + "\n".join(head) + "\n" + body + "    -1\n").encode("utf-8")
