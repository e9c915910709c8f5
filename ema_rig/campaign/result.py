"""The result of a campaign run: one row per measurement, as a table (CSV, pandas, records)."""

from __future__ import annotations

import csv
import html
import io
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .._optional import import_optional
from .._text import csv_cell, std_text
from .schema import CampaignConfig

#: Column order of the campaign table.
COLUMNS: tuple[str, ...] = (
    "id", "file", "bearing", "radial_load", "speed", "shaft_position", "repeat", "tags",
    "status", "k_TB", "k_TB_std", "k_TB_std_measured", "k_TB_MS", "k_MS",
    "housing_freq", "housing_freq_std", "housing_damping",
    "spindle_freq", "spindle_damping", "c_TB", "c_TB_std", "c_TB_kind", "loss_factor", "loss_factor_std",
    "mode_source", "error", "elapsed_s", "warnings",
)

#: Stiffness units of the CSV: name -> factor from N/m.
STIFFNESS_UNITS: dict[str, float] = {"N/m": 1.0, "MN/m": 1e-6, "N/µm": 1e-6, "N/um": 1e-6}
#: Damping units of the CSV: ``-`` (a fraction of critical) or ``%``.
DAMPING_UNITS: dict[str, float] = {"-": 1.0, "%": 100.0}
_STIFFNESS_COLUMNS = ("k_TB", "k_TB_std", "k_TB_std_measured", "k_TB_MS", "k_MS")
_DAMPING_COLUMNS = ("housing_damping", "spindle_damping")
#: Units of the other numeric columns (in the CSV header).
_UNITS = {"radial_load": "N", "speed": "rpm", "shaft_position": "deg", "housing_freq": "Hz",
          "housing_freq_std": "Hz", "spindle_freq": "Hz", "elapsed_s": "s", "c_TB": "N s/m",
          "c_TB_std": "N s/m", "loss_factor": "-", "loss_factor_std": "-"}


def csv_header(column: str, *, stiffness_unit: str = "N/m", damping_unit: str = "-") -> str:
    """The CSV header of a column: its name and its unit, e.g. ``k_TB [MN/m]``, ``speed [rpm]``."""
    if column in _STIFFNESS_COLUMNS:
        return f"{column} [{stiffness_unit}]"
    if column in _DAMPING_COLUMNS:
        return f"{column} [{damping_unit}]"
    unit = _UNITS.get(column)
    return column if unit is None else f"{column} [{unit}]"


@dataclass(frozen=True, slots=True)
class CampaignResult:
    """What a campaign run produced.

    Attributes
    ----------
    config : CampaignConfig
    rows : tuple of dict
        One row per measurement in campaign order, keys :data:`COLUMNS`.
    calibration : dict or None
        The k_MS calibration (``k_MS``, ``k_MS_std``, ``housing_mode``, ``status``, ``error``).
    k_MS, k_MS_std : float
        The mounting stiffness used [N/m] and its standard uncertainty.
    out_dir : Path or None
        Where tables, figures and the report were written.
    computed, reused : int
        How many measurements were computed (or found missing/unreadable) in this run and how many
        were reused from a previous run; ``computed + reused`` is the number of measurements.
    files : dict
        Written outputs by kind (``"table"``, ``"report"``, figure names ...).
    """

    config: CampaignConfig
    rows: tuple[dict[str, Any], ...]
    calibration: dict[str, Any] | None
    k_MS: float
    k_MS_std: float | None
    out_dir: Path | None = None
    computed: int = 0
    reused: int = 0
    files: Mapping[str, Path] = field(default_factory=dict)

    def __repr__(self) -> str:
        cal = "" if self.calibration is None else f", calibration {self.calibration.get('status')}"
        return (f"CampaignResult({self.config.title!r}: {len(self.rows)} measurements, {self.n_failed} failed, "
                f"k_MS {self.k_MS / 1e6:.2f} MN/m{cal}, computed {self.computed}, reused {self.reused}, "
                f"out_dir={str(self.out_dir) if self.out_dir else None!r})")

    def _repr_html_(self) -> str:
        """The summary table in Jupyter: id, conditions, k_TB with its measured and total ± in MN/m (as
        the report and the console label them), housing mode, the number of warnings, status."""
        head = "".join(f"<th>{html.escape(h)}</th>" for h in
                       ("id", "bearing", "load [N]", "speed [rpm]", "k_TB [MN/m]", "± measured [MN/m]",
                        "± total [MN/m]", "f_H [Hz]", "warnings", "status"))
        body = []
        for r in self.rows:
            cells = (r["id"], r["bearing"], f"{r['radial_load']:g}", f"{r['speed']:g}", f"{r['k_TB'] / 1e6:.2f}",
                     std_text(r.get("k_TB_std_measured", math.nan) / 1e6), std_text(r["k_TB_std"] / 1e6),
                     f"{r['housing_freq']:.1f}", len(r.get("warnings") or ()),
                     "ok" if r["status"] == "ok" else f"error: {r['error']}")
            body.append("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in cells) + "</tr>")
        return f"<p>{html.escape(repr(self))}</p><table><tr>{head}</tr>{''.join(body)}</table>"

    @property
    def n_failed(self) -> int:
        """Number of measurements that ended in an error."""
        return sum(r["status"] != "ok" for r in self.rows)

    @property
    def ok(self) -> bool:
        """True when every measurement (and the calibration, if any) succeeded."""
        cal_ok = self.calibration is None or self.calibration.get("status") == "ok"
        return self.n_failed == 0 and cal_ok

    def to_records(self) -> list[dict[str, Any]]:
        """The table rows as a list of dicts (keys :data:`COLUMNS`)."""
        return [dict(r) for r in self.rows]

    def to_dataframe(self) -> Any:
        """The table as a pandas DataFrame (needs the ``pandas`` extra)."""
        pd = import_optional("pandas", extra="pandas")
        return pd.DataFrame(self.to_records(), columns=list(COLUMNS))

    def to_csv(self, *, stiffness_unit: str | None = None, damping_unit: str | None = None) -> str:
        """The table as CSV text, every header with its unit (``k_TB [N/m]``, ``speed [rpm]`` ...).

        Parameters
        ----------
        stiffness_unit : {'N/m', 'MN/m', 'N/µm'}, optional
            Unit of the stiffness columns; default the campaign file's ``[output] stiffness_unit``,
            else N/m (SI).
        damping_unit : {'-', '%'}, optional
            Damping ratios as a fraction of critical (``-``) or in percent; default the campaign
            file's ``[output] damping_unit``, else ``-``.

        Raises
        ------
        ValueError
            For an unknown unit.
        """
        su = stiffness_unit if stiffness_unit is not None else self.config.stiffness_unit
        su = su.replace("\u03bc", "\u00b5")  # Greek mu typed for the micro sign: the same unit
        du = damping_unit if damping_unit is not None else self.config.damping_unit
        if su not in STIFFNESS_UNITS:
            raise ValueError(f"stiffness unit must be one of {', '.join(STIFFNESS_UNITS)}, got {su!r}")
        if du not in DAMPING_UNITS:
            raise ValueError(f"damping unit must be one of {', '.join(DAMPING_UNITS)}, got {du!r}")
        scale = {**{c: STIFFNESS_UNITS[su] for c in _STIFFNESS_COLUMNS}, **{c: DAMPING_UNITS[du] for c in _DAMPING_COLUMNS}}
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow([csv_header(c, stiffness_unit=su, damping_unit=du) for c in COLUMNS])
        for r in self.rows:
            w.writerow([_csv_value(r.get(c), scale.get(c, 1.0)) for c in COLUMNS])
        return buf.getvalue()


def _csv_value(v: Any, scale: float = 1.0) -> Any:
    """A cell: numbers as numbers, text inert (no control characters, never a spreadsheet formula)."""
    if v is None:
        return ""
    if isinstance(v, (list, tuple)):  # warnings: one cell, caveats separated by " | "
        return csv_cell(" | ".join(str(x) for x in v))
    if isinstance(v, float):
        return "" if not math.isfinite(v) else repr(v * scale if scale != 1.0 else v)
    return csv_cell(v)


def summary_rows(result: CampaignResult) -> Iterable[dict[str, Any]]:
    """Rows for a compact console table: id, conditions, k_TB ± std, housing mode, status."""
    for r in result.rows:
        yield {
            "id": r["id"],
            "bearing": r["bearing"],
            "load [N]": r["radial_load"],
            "speed [rpm]": r["speed"],
            "k_TB [N/m]": r["k_TB"],
            "± [N/m]": r["k_TB_std"],
            "± measured [N/m]": r.get("k_TB_std_measured", math.nan),
            "warnings": len(r.get("warnings") or ()),
            "f_H [Hz]": r["housing_freq"],
            "status": r["status"] if r["status"] == "ok" else f"error: {r['error']}",
        }


__all__ = ["COLUMNS", "DAMPING_UNITS", "STIFFNESS_UNITS", "CampaignResult", "csv_header", "summary_rows"]
