"""The result of a campaign run: one row per measurement, as a table (CSV, pandas, records)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .schema import CampaignConfig

#: Column order of the campaign table.
COLUMNS: tuple[str, ...] = (
    "id", "file", "bearing", "radial_load", "speed", "shaft_position", "repeat", "tags",
    "status", "k_TB", "k_TB_std", "k_TB_MS", "k_MS",
    "housing_freq", "housing_freq_std", "housing_damping",
    "spindle_freq", "spindle_damping", "error", "elapsed_s",
)


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
        from .._optional import import_optional

        pd = import_optional("pandas", extra="pandas")
        return pd.DataFrame(self.to_records(), columns=list(COLUMNS))

    def to_csv(self) -> str:
        """The table as CSV text."""
        import csv
        import io

        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=list(COLUMNS), extrasaction="ignore", lineterminator="\n")
        w.writeheader()
        for r in self.rows:
            w.writerow({k: _csv_value(r.get(k)) for k in COLUMNS})
        return buf.getvalue()


def _csv_value(v: Any) -> Any:
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if not math.isfinite(v) else repr(v)
    return v


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
            "f_H [Hz]": r["housing_freq"],
            "status": r["status"] if r["status"] == "ok" else f"error: {r['error']}",
        }


__all__ = ["COLUMNS", "CampaignResult", "summary_rows"]
