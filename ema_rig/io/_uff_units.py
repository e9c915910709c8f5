"""Private: unit decisions for UFF dataset-58 FRFs (ordinate codes, unit labels, dataset 164).

A unit label such as ``"g"``, ``"m/s^2"``, ``"(m/s)/N"``, ``"(1/N)*(m/s²)"`` or ``"in/s2/lbf"``
is parsed into dimensions (length, time, force exponents) and a factor to SI. The ordinate
specific data type code (8 displacement, 11 velocity, 12 acceleration; denominator 13 or 9
force) gives the quantity. Code and label must agree; when they do not, the rig file's
``[units] prefer`` decides, else it is an error.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from ..literals import FrfForm
from .units import FORM_DIMS, MAX_UNIT_POWER, Unit, force_factor, is_no_label, parse_unit
from .units import G0 as G0  # re-exported: the writer scales by it
from .units import response_unit as response_unit  # re-exported: read_uff58 checks --units with it

_FORM_DIMS = FORM_DIMS
_CODE_FORM: dict[int, FrfForm] = {8: "receptance", 11: "mobility", 12: "accelerance"}
_CODE_NAMES = {
    0: "unknown", 1: "general", 2: "stress", 3: "strain", 5: "temperature", 6: "heat flux",
    8: "displacement", 9: "reaction force", 11: "velocity", 12: "acceleration", 13: "excitation force",
    15: "pressure", 16: "mass", 17: "time", 18: "frequency", 19: "rpm", 20: "order",
}


class UnitRangeError(ValueError):
    """A dataset-164 conversion is out of range (the factor would be 0, inf or overflow)."""


@dataclass(frozen=True, slots=True)
class UnitDecision:
    """How the values of one FRF dataset are turned into SI."""

    frf_form: FrfForm
    factor: float
    text: str
    note: str | None = None


SI_ASSUMED = "no unit label and no dataset 164: SI (m, N) assumed"
"""The unit decision of a dataset whose units nothing in the file states."""
ORDINATE_SI_ASSUMED = "no ordinate unit label and no dataset 164: SI (m) assumed for the ordinate"
"""The unit decision of a dataset whose file states the denominator's unit only (a label, lbf or kN)."""


def trailing_units_problem(records: Sequence[Any], index: int) -> str | None:
    """Why a dataset that states no units and has no dataset 164 before it cannot be read as SI, or None.

    A dataset 164 sets the units of the datasets after it (I-DEAS universal file format); one
    that only follows the dataset (a writer that puts the unit system last) may or may not be
    meant for it, and its factors would change the values. SI is assumed only when no such
    dataset 164 with non-SI factors follows.

    Parameters
    ----------
    records : sequence of UFFRecord
        Every dataset of the file, in file order.
    index : int
        The dataset whose units nothing before it states.

    Returns
    -------
    str or None
        One line naming the dataset 164, for the refusal.
    """
    for r in records:
        if r.index > index and r.type == 164 and r.status == "read":
            h = r.header
            if (h["length_factor"], h["force_factor"]) != (1.0, 1.0):
                return (f"no unit label and no dataset 164 before it, but dataset {r.index} (164, "
                        f"{h['unit_description']!r}: length factor {h['length_factor']:.10g}, force factor "
                        f"{h['force_factor']:.10g}) follows it: a dataset 164 sets the units of the datasets "
                        "after it, so whether these are SI or its units the file does not say")
    return None


def _code_name(code: int) -> str:
    return f"{code} ({_CODE_NAMES.get(code, 'other')})"


_AXIS_WORDS = {
    "receptance": "receptance", "compliance": "receptance", "flexibility": "receptance",
    "mobility": "mobility", "admittance": "mobility",
    "accelerance": "accelerance", "inertance": "accelerance",
}


def decide(h: dict[str, Any], units164: dict[str, Any] | None, preference: str | None,
           assumed: str | None = None) -> UnitDecision:
    """Decide FRF form and SI factor of one dataset-58 FRF (see :func:`_decide`).

    A free-text axis label naming another FRF form (``"Receptance"`` over ``(m/s)/N``) does not
    decide anything, but the disagreement is added to the decision text. ``assumed`` (a unit
    checked by :func:`response_unit`) stands in for a missing ordinate unit label; a file's own
    label always wins.
    """
    num_lab = str(h.get("ordinate_axis_units_lab", ""))
    if assumed is not None and is_no_label(num_lab):
        h = {**h, "ordinate_axis_units_lab": assumed}
        try:
            dec = _decide(h, units164, preference)
        except ValueError as exc:  # the label named is not the file's: say where it came from
            raise ValueError(f"{exc}; the file has no unit label: {assumed!r} was given by the user (--units or "
                             "the rig file's [units] ordinate)") from None
        dec = UnitDecision(dec.frf_form, dec.factor,
                           f"{dec.text}; the file has no unit label: {assumed!r} given by the user (--units or "
                           "the rig file's [units] ordinate)")
    else:
        dec = _decide(h, units164, preference)
    if not (math.isfinite(dec.factor) and dec.factor > 0.0):
        raise UnitRangeError(f"unit conversion factor {dec.factor:g} is not finite and positive ({dec.text})")
    lab = h.get("ordinate_axis_lab", "")
    named = next((f for w, f in _AXIS_WORDS.items() if w in lab.lower()), None)
    if named is not None and named != dec.frf_form:
        text = f"{dec.text}; note: the axis label {lab!r} names {named}, codes/unit labels decide"
        return UnitDecision(dec.frf_form, dec.factor, text)
    return dec


def _decide(h: dict[str, Any], units164: dict[str, Any] | None, preference: str | None) -> UnitDecision:
    """Decide FRF form and SI factor of one dataset-58 FRF.

    Parameters
    ----------
    h : dict
        Parsed header (ordinate/denominator codes, exponents, labels).
    units164 : dict or None
        The dataset 164 in force for this dataset (length/force factors: file units per SI unit).
    preference : {'code', 'label'} or None
        Which wins when the ordinate code and the unit label disagree.

    Returns
    -------
    UnitDecision

    Raises
    ------
    ValueError
        With the reason (the caller turns it into a UFFError naming file and dataset).
    """
    num_code = h["ordinate_spec_data_type"]
    den_code = h["orddenom_spec_data_type"]
    num_lab = h["ordinate_axis_units_lab"]
    den_lab = h["orddenom_axis_units_lab"]
    if num_code not in (0, 1, 8, 11, 12):
        raise ValueError(
            f"ordinate specific data type {_code_name(num_code)} is not displacement (8), velocity (11) "
            "or acceleration (12)"
        )
    if den_code not in (0, 1, 9, 13):
        raise ValueError(f"denominator specific data type {_code_name(den_code)} is not a force (13 or 9)")
    code_form = _CODE_FORM.get(num_code)
    pn = parse_unit(num_lab, "ordinate unit label")
    pd = parse_unit(den_lab, "denominator unit label")
    den_lab_given = pd is not None
    notes: list[str] = []
    label_form: FrfForm | None = None
    label_factor: float | None = None
    label_text = ""
    den164 = False  # the unlabelled denominator is in the force unit of dataset 164
    if pn is not None:
        dims, fac = pn.dims, pn.factor
        if dims[2] == -1:  # the ordinate label already holds the whole FRF unit (per force)
            label_text = f"label {num_lab!r} (whole FRF unit)"
            num_dims = (dims[0], dims[1], 0)
            if pd is not None:  # a denominator label must name the force the ordinate label is per
                _check_per_force(num_lab, den_lab, pd)
        elif dims[2] == 0:
            num_dims = dims
            if pd is not None and pd.dims == (0, 0, 1):
                fac = fac / pd.factor
                label_text = f"labels {num_lab!r} / {den_lab!r}"
            elif den_lab_given:
                raise ValueError(f"denominator unit label {den_lab!r} is not a force unit (N, kN, lbf)")
            elif units164 is not None:
                # the file's unit system (dataset 164) holds for what no label states: an
                # unlabelled force is in its force unit (lbf in an inch-pound file), not N
                d_force = h["orddenom_force_unit_exp"] or 1
                if abs(d_force) > MAX_UNIT_POWER:
                    raise UnitRangeError(f"denominator force unit exponent {d_force} out of range (at most "
                                         f"{MAX_UNIT_POWER} in magnitude) for the dataset 164 conversion")
                ff = units164["force_factor"]
                fac = fac * ff**d_force
                den164 = True
                label_text = (f"label {num_lab!r} per the force unit of dataset 164 ({units164['unit_description']}: "
                              f"force factor {ff:.10g}; denominator not labelled)")
            else:
                label_text = f"label {num_lab!r} per N (denominator not labelled)"
        else:
            num_dims = (9, 9, 9)
        label_form = _FORM_DIMS.get(num_dims)
        label_factor = fac
        if label_form is None:
            label_text = f"label {num_lab!r} (not a displacement, velocity or acceleration per force)"

    if code_form is not None and label_text and label_form != code_form:
        msg = (
            f"ordinate specific data type {_code_name(num_code)} says {code_form} but the unit "
            f"{label_text} says {label_form or 'something else'}"
        )
        if preference == "code":
            notes.append(msg + "; the rig file prefers the code")
            label_form = label_factor = None
        elif preference == "label" and label_form is not None:
            notes.append(msg + "; the rig file prefers the label")
            code_form = None
        else:
            raise ValueError(msg + " (set [units] prefer = \"code\" or \"label\" in the rig file to decide)")
    if label_form is None and code_form is None:
        raise ValueError(
            f"ordinate quantity unknown: specific data type {_code_name(num_code)} and unit label {num_lab!r}"
        )
    form = label_form or code_form
    assert form is not None
    if label_factor is not None and label_form is not None:
        text = f"{form} from {label_text}: x {label_factor:.10g} to SI"
        if code_form is not None:
            text += f" (ordinate code {_code_name(num_code)} agrees)"
        if units164 is not None and not den164:
            text += f"; dataset 164 ({units164['unit_description']}) not applied, the label is explicit"
        return UnitDecision(form, label_factor, text + _j(notes))
    # from the code: the unit system of dataset 164, else SI; a labelled denominator (lbf, kN) still counts
    text = f"{form} from ordinate code {_code_name(num_code)}"
    den_fac, den_text = 1.0, ""
    if pd is not None:
        if pd.dims != (0, 0, 1):
            raise ValueError(f"denominator unit label {den_lab!r} is not a force unit (N, kN, lbf)")
        den_fac = 1.0 / pd.factor
        den_text = f"; per {den_lab!r} (denominator label): x {den_fac:.10g}"
    if units164 is None:
        if pd is None:
            return UnitDecision(form, 1.0, text + "; " + SI_ASSUMED + _j(notes))
        return UnitDecision(form, den_fac, text + "; " + ORDINATE_SI_ASSUMED + den_text + " to SI" + _j(notes))
    n_len = h["ordinate_len_unit_exp"] or 1
    n_force = h["ordinate_force_unit_exp"]
    # a labelled denominator replaces dataset 164's unit for it (exponents 0: its factor is den_fac)
    d_len = h["orddenom_len_unit_exp"] if pd is None else 0
    d_force = (h["orddenom_force_unit_exp"] or 1) if pd is None else 0
    for name, e in (("ordinate length", n_len), ("ordinate force", n_force),
                    ("denominator length", d_len), ("denominator force", d_force)):
        if abs(e) > MAX_UNIT_POWER:
            raise UnitRangeError(
                f"{name} unit exponent {e} out of range (at most {MAX_UNIT_POWER} in magnitude) for the "
                "dataset 164 conversion"
            )
    lf, ff = units164["length_factor"], units164["force_factor"]
    try:
        fac = 1.0 / (lf ** (n_len - d_len) * ff ** (n_force - d_force))
    except (OverflowError, ZeroDivisionError):
        fac = math.nan
    if not math.isfinite(fac) or fac <= 0:
        raise UnitRangeError(
            f"dataset 164 unit factors (length {lf:g}, force {ff:g}) with exponents length {n_len - d_len}, "
            f"force {n_force - d_force} give no finite non-zero conversion"
        )
    if fac != 1.0:  # the exponents decide the factor: they must be those of a response per force
        _check_frf_exponents(h, form, pd is None)
    text += (
        f"; units of dataset 164 ({units164['unit_description']}: length factor {lf:.10g}, force factor "
        f"{ff:.10g}) with exponents length {n_len - d_len}, force {n_force - d_force}: x {fac:.10g}"
        + den_text + " to SI"
    )
    return UnitDecision(form, fac * den_fac, text + _j(notes))


def _check_frf_exponents(h: Mapping[str, Any], form: FrfForm, den_unlabelled: bool) -> None:
    """Refuse header unit exponents that do not describe a response per force.

    Records 9 and 10 give the length and force exponents of the ordinate (numerator) and of the
    denominator; for a displacement, velocity or acceleration per force they are length 1, force 0
    over length 0, force 1 (time is always in seconds). 0 in a length exponent of the ordinate or
    the force exponent of the denominator means "not filled in" (pyuff writes 0 everywhere) and
    is read as the expected value. Other values (e.g. the whole FRF's exponents, length 1 and force
    -1, in the ordinate) would make dataset 164 scale the values by a wrong power of its factors.
    """
    got = (h["ordinate_len_unit_exp"] or 1, h["ordinate_force_unit_exp"])
    den = (h["orddenom_len_unit_exp"], h["orddenom_force_unit_exp"] or 1) if den_unlabelled else (0, 1)
    if got != (1, 0) or den != (0, 1):
        raise ValueError(
            f"unit exponents (ordinate length {got[0]}, force {got[1]}; denominator length {den[0]}, force {den[1]}) "
            f"do not describe a {form} (a response per force: length 1, force 0 over length 0, force 1): the "
            "factor of dataset 164 that applies is not clear"
        )


def _check_per_force(num_lab: str, den_lab: str, pd: Unit) -> None:
    """Refuse a denominator label that contradicts the force of a whole-FRF ordinate label
    (``'g/N'`` over ``'lbf'``): which of the two the values are per, nothing in the file says."""
    if pd.dims != (0, 0, 1):
        raise ValueError(f"denominator unit label {den_lab!r} is not a force unit (N, kN, lbf)")
    per = 1.0 / force_factor(num_lab)
    if not math.isclose(per, pd.factor, rel_tol=1e-12):  # both from the same exact unit constants
        raise ValueError(
            f"ordinate unit label {num_lab!r} is per {per:.10g} N but the denominator unit label {den_lab!r} is "
            f"{pd.factor:.10g} N: the labels contradict each other, the values are not read"
        )


def _j(notes: list[str]) -> str:
    return "" if not notes else "; " + "; ".join(notes)


_FREQ_ABSCISSA_CODES = (0, 1, 18)
"""Abscissa specific data type codes an FRF's abscissa may carry: unknown, general, frequency."""
_NOT_FREQ_WITH_LABEL = (17, 19, 20)
"""Codes that contradict a frequency unit label: time, rpm (a shaft-speed axis), order."""


def frf_header_problem(h: Mapping[str, Any]) -> str | None:
    """Why the header of a dataset-58 FRF (function type 4) cannot be read as an FRF, or None.

    An FRF is complex: an FRF dataset of real values (ordinate data type 2 or 4) holds a
    magnitude, a real part or (Re, Im) pairs under a wrong type code, never the FRF itself
    (the UFF corpus' ``ufffiles_case{1,2,5,6}`` hold the complex FRF of their ``case{3,4,7,8}``
    twins as interleaved pairs: 1602 real "lines" for 801, up to twice the frequency). Its
    abscissa must be a frequency (:func:`abscissa_factor`), and a denominator unit label must name the
    force a whole-FRF ordinate label (``g/N``) is per.

    Parameters
    ----------
    h : mapping
        The parsed dataset-58 header (``ord_data_type``, ``abscissa_spec_data_type``, labels).

    Returns
    -------
    str or None
        One line naming the field and value, for the refusal.
    """
    odt = h.get("ord_data_type")
    if odt in (2, 4):
        return (f"FRF stored as real values (ordinate data type {odt}, real {'single' if odt == 2 else 'double'}): "
                "an FRF is complex (type 5 or 6); the values (a magnitude, a real part or (Re, Im) pairs under a "
                "wrong type code) are not read rather than taken as an FRF with zero imaginary part")
    try:
        abscissa_factor(dict(h))
        num = parse_unit(str(h.get("ordinate_axis_units_lab", "")), "ordinate unit label")
        den = parse_unit(str(h.get("orddenom_axis_units_lab", "")), "denominator unit label")
        if num is not None and num.dims[2] == -1 and den is not None:
            _check_per_force(num.label, den.label, den)
    except ValueError as exc:
        return str(exc)
    return None


def abscissa_factor(h: dict[str, Any]) -> float:
    """Factor from the file's abscissa unit to Hz (ValueError if it is not a frequency or unreadable).

    Without a unit label the abscissa specific data type code decides: 18 (frequency), 0
    (unknown) or 1 (general) are read as Hz; any other code (rpm 19, order 20, time 17, a
    response quantity) is refused, not taken as Hz. A frequency label (``Hz``, ``rad/s``,
    ``rpm`` ...) converts, unless the code says time, rpm or order.
    """
    code = h["abscissa_spec_data_type"]
    lab = h["abscissa_axis_units_lab"]
    u = parse_unit(lab, "abscissa unit label")
    if code == 17 or (u is not None and u.quantity == "time"):
        raise ValueError(f"abscissa is time (code {code}, unit {lab!r}), not frequency")
    if u is None:
        if code not in _FREQ_ABSCISSA_CODES:
            raise ValueError(
                f"abscissa specific data type {_code_name(code)} is not a frequency (18) and no unit label says "
                "otherwise: the abscissa is not read rather than taken as Hz"
            )
        return 1.0
    if code in _NOT_FREQ_WITH_LABEL:
        raise ValueError(f"abscissa specific data type {_code_name(code)} contradicts its frequency unit label "
                         f"{lab!r}: the abscissa is not read rather than guessed")
    if u.quantity != "frequency":
        raise ValueError(f"abscissa unit {lab!r} is not a frequency unit (Hz, kHz, rad/s, 1/s)")
    return u.factor


def time_factor(h: dict[str, Any]) -> float:
    """Factor from the file's abscissa unit to seconds (ValueError if it is not a time or unreadable)."""
    code = h["abscissa_spec_data_type"]
    lab = h["abscissa_axis_units_lab"]
    u = parse_unit(lab, "abscissa unit label")
    if u is None:
        if code not in (0, 1, 17):
            raise ValueError(f"abscissa specific data type {_code_name(code)} is not time (17)")
        return 1.0
    if u.quantity != "time":
        raise ValueError(f"abscissa unit {lab!r} is not a time unit (s, ms, ...)")
    return u.factor


def ordinate_factor(h: dict[str, Any], dims: tuple[int, int, int], units164: dict[str, Any] | None
                    ) -> tuple[float, str]:
    """Factor to SI of a dataset-58 ordinate that is not a ratio (time data), and how it was decided.

    Parameters
    ----------
    h : dict
        Parsed header.
    dims : tuple of int
        The (length, time, force) exponents the ordinate must have (from its data type code).
    units164 : dict or None
        The dataset 164 in force (used only when the ordinate has no unit label).

    Returns
    -------
    factor : float
    text : str
        ``"label 'mm/s^2'"``, ``"dataset 164 (...)"`` or ``"no unit label and no dataset 164"``.

    Raises
    ------
    ValueError
        A label that cannot be read or is not of ``dims``; a dataset 164 conversion out of range.
    """
    lab = h["ordinate_axis_units_lab"]
    u = parse_unit(lab, "ordinate unit label")
    if u is not None:
        if u.dims != dims:
            want = {(0, 0, 1): "force", (1, -2, 0): "acceleration", (1, -1, 0): "velocity",
                    (1, 0, 0): "displacement"}.get(dims, str(dims))
            raise ValueError(f"ordinate unit {lab.strip()!r} is not a {want} unit (it is {u.quantity})")
        return u.factor, f"label {lab.strip()!r}"
    if units164 is None:
        return 1.0, "no unit label and no dataset 164"
    n_len = h["ordinate_len_unit_exp"] or dims[0]
    n_force = h["ordinate_force_unit_exp"] or dims[2]
    if (n_len, n_force) != (dims[0], dims[2]):
        raise ValueError(f"ordinate unit exponents length {n_len}, force {n_force} do not fit its data type "
                         f"{_code_name(h['ordinate_spec_data_type'])} (length {dims[0]}, force {dims[2]})")
    lf, ff = units164["length_factor"], units164["force_factor"]
    try:
        fac = 1.0 / (lf**n_len * ff**n_force)
    except (OverflowError, ZeroDivisionError):
        fac = math.nan
    if not (math.isfinite(fac) and fac > 0):
        raise UnitRangeError(f"dataset 164 unit factors (length {lf:g}, force {ff:g}) give no finite non-zero "
                             "conversion")
    return fac, (f"dataset 164 ({units164['unit_description']}: length factor {lf:.10g}, force factor "
                 f"{ff:.10g})")
