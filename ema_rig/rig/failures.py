"""Why a candidate mode is not the housing mode: a typed failure that still is its one-line text.

:func:`ema_rig.rig.matching.match_modes` writes one line per failed housing criterion into
``Candidate.failures`` (and so into the ``candidates`` of ``ema-rig stiffness --json``). A
:class:`Failure` is that line -- a ``str``, so the JSON and every message are unchanged -- with
its :data:`~ema_rig.literals.FailureKind`, so the code that needs to know which criterion failed
asks ``failure.kind`` instead of matching the text.

Classes
-------
Failure
    One failed criterion: the text (a ``str``) and its ``kind``.
"""

from __future__ import annotations

from ..literals import FailureKind


class Failure(str):
    """One failed housing criterion: its one-line text, with its kind.

    Parameters
    ----------
    kind : FailureKind
        Which criterion failed.
    text : str
        The line shown to the user (and written to JSON).

    Examples
    --------
    >>> f = Failure("tilt", "tilt: radial housing sensors out of phase (min cos -0.40)")
    >>> f.kind, f == "tilt: radial housing sensors out of phase (min cos -0.40)"
    ('tilt', True)
    """

    kind: FailureKind

    def __new__(cls, kind: FailureKind, text: str) -> Failure:
        obj = super().__new__(cls, text)
        obj.kind = kind
        return obj

    def __getnewargs__(self) -> tuple[str, str]:  # type: ignore[override]
        # pickle and copy rebuild a Failure from its kind and text (campaign workers, dataclasses.asdict)
        return (self.kind, str(self))


__all__ = ["Failure"]
