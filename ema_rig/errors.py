"""Exception and warning types of ema_rig.

Every error a user can cause with a bad file, a bad configuration or data that cannot be
identified derives from :class:`EmaRigError`. The command line prints such errors as one line
``error: <file>: <what is wrong>`` and exits non-zero; anything else is a bug.

Classes
-------
EmaRigError
    Base class; carries the offending ``file`` (may be None).
UFFError
    A UFF file or one of its datasets cannot be read or written (``dataset`` is its 0-based index).
FileAccessError
    A UFF file could not be read at this moment (missing, I/O, permission, memory): not a fault of
    its content, so a result cache must not keep it.
ConfigError
    A rig or campaign TOML file is invalid (``key`` names the offending key path).
IdentificationError
    Modal identification failed (no stable pole, bad band, too few lines for the order ...).
BandError
    The requested band is not covered by the data (:func:`band_error` words it).
InversionError
    A natural frequency cannot be turned into a physical stiffness.
MatchingError
    No identified mode matches the housing mode; ``candidates`` lists why each was rejected.
IdentificationWarning, UnitWarning
    User-facing numerical or unit doubts.
"""

from __future__ import annotations

from os import PathLike
from typing import Any


class EmaRigError(Exception):
    """Base class of all errors caused by user input.

    Parameters
    ----------
    message : str
        What is wrong, in words a test engineer understands.
    file : str or path-like, optional
        The file the problem was found in.
    """

    def __init__(self, message: str, *, file: str | PathLike[str] | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.file = None if file is None else str(file)

    def __str__(self) -> str:
        if self.file:
            return f"{self.file}: {self.message}"
        return self.message


class UFFError(EmaRigError, ValueError):
    """A UFF file (or one dataset of it) cannot be read or written.

    Parameters
    ----------
    message : str
        What is wrong.
    file : str or path-like, optional
        The UFF file.
    dataset : int, optional
        0-based index of the dataset in file order.
    """

    def __init__(
        self,
        message: str,
        *,
        file: str | PathLike[str] | None = None,
        dataset: int | None = None,
    ) -> None:
        super().__init__(message, file=file)
        self.dataset = dataset

    def __str__(self) -> str:
        where = f"dataset {self.dataset}: " if self.dataset is not None else ""
        head = f"{self.file}: " if self.file else ""
        return f"{head}{where}{self.message}"


class FileAccessError(UFFError):
    """A UFF file could not be read at this moment: missing, an I/O or permission error, no memory.

    Nothing about the file's content: the same bytes may read fine on the next run (a network
    share back, another worker count). A campaign reports it in the row and computes the
    measurement again on the next run instead of reusing the error (its key is the content's).

    Parameters
    ----------
    message : str
        What failed (the operating system's words).
    file : str or path-like, optional
        The UFF file.
    dataset : int, optional
        0-based index of the dataset in file order (None: the whole file could not be read).
    """


class ConfigError(EmaRigError, ValueError):
    """A rig or campaign configuration is invalid.

    Parameters
    ----------
    message : str
        What is wrong (names the allowed values).
    file : str or path-like, optional
        The TOML file.
    key : str, optional
        Dotted key path, e.g. ``"sensor[2].role"``.
    """

    def __init__(
        self,
        message: str,
        *,
        file: str | PathLike[str] | None = None,
        key: str | None = None,
    ) -> None:
        super().__init__(message, file=file)
        self.key = key

    def __str__(self) -> str:
        where = f"{self.key}: " if self.key else ""
        head = f"{self.file}: " if self.file else ""
        return f"{head}{where}{self.message}"


class IdentificationError(EmaRigError, ValueError):
    """Modal identification failed or was asked something impossible.

    Parameters
    ----------
    message : str
        What is wrong.
    file : str or path-like, optional
        The measurement file it concerns.
    """


class BandError(IdentificationError):
    """The requested frequency band is not covered by the data (a wrong band, not bad data).

    Parameters
    ----------
    message : str
        What is wrong (made by :func:`band_error`).
    file : str or path-like, optional
        The measurement file it concerns.
    """


def band_error(lo: float, hi: float, f0: float, f1: float, *, file: str | PathLike[str] | None = None) -> BandError:
    """The refusal of a band ``lo..hi`` [Hz] that the data's ``f0..f1`` [Hz] do not cover.

    One wording for every stage: a band that overlaps the data only in part "extends beyond the
    data" (and the overlap is suggested), one without any overlap "lies outside the data".

    Parameters
    ----------
    lo, hi : float
        The requested band [Hz].
    f0, f1 : float
        The first and last frequency line of the data [Hz].
    file : str or path-like, optional
        The measurement file.

    Returns
    -------
    BandError
        The error to raise.
    """
    a, b = max(lo, f0), min(hi, f1)
    if b > a:
        text = (f"band {lo:g}..{hi:g} Hz extends beyond the data ({f0:g}..{f1:g} Hz); "
                f"choose a band within it, e.g. {a:g}..{b:g} Hz")
    else:
        text = f"band {lo:g}..{hi:g} Hz lies outside the data ({f0:g}..{f1:g} Hz)"
    return BandError(text, file=file)


class InversionError(EmaRigError, ValueError):
    """A natural frequency lies outside the range that gives a positive stiffness.

    Parameters
    ----------
    message : str
        What is wrong (the frequency and the valid range).
    file : str or path-like, optional
        The measurement file it concerns.
    """


class MatchingError(EmaRigError):
    """No identified mode could be matched to the rig model's housing mode.

    Parameters
    ----------
    message : str
        What is wrong.
    candidates : list of dict, optional
        Every mode considered, with the reason it was kept or rejected.
    file : str or path-like, optional
        The measurement file.
    """

    def __init__(
        self,
        message: str,
        *,
        candidates: list[dict[str, Any]] | None = None,
        file: str | PathLike[str] | None = None,
    ) -> None:
        super().__init__(message, file=file)
        self.candidates = list(candidates or [])


class IdentificationWarning(UserWarning):
    """A numerical doubt about an identification result (ill conditioning, weak mode ...)."""


class UnitWarning(UserWarning):
    """A unit decision that the user should know about (assumed unit, ignored channel ...)."""


__all__ = [
    "BandError",
    "ConfigError",
    "EmaRigError",
    "FileAccessError",
    "IdentificationError",
    "IdentificationWarning",
    "InversionError",
    "MatchingError",
    "UFFError",
    "UnitWarning",
    "band_error",
]
