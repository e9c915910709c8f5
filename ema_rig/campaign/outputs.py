"""The outputs of a campaign run: table (CSV), resolved settings (JSON), figures, HTML report.

Every file is written atomically. Figures of a previous run that this run does not produce again
(a bearing renamed, a condition removed) are removed, so the folder holds one campaign's outputs.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from os import PathLike
from pathlib import Path
from typing import Any

from .. import _atomic
from ..config import read_regular_file
from .result import CampaignResult

#: The figures written by the last run of a folder (to remove those no longer produced).
_MANIFEST = ".ema-rig-figures.json"


def write_outputs(result: CampaignResult, out_dir: str | PathLike[str]) -> dict[str, Path]:
    """Write the table (CSV), the resolved settings (JSON), the figures and the HTML report.

    Parameters
    ----------
    result : CampaignResult
    out_dir : path
        The output folder (the caller holds its lock during :func:`~ema_rig.campaign.run`).

    Returns
    -------
    dict
        Output kind (``"table"``, ``"settings"``, figure names, ``"report"``) -> path.

    Raises
    ------
    OSError
        When a file cannot be written (disk full, permission), naming that file.
    """
    from ..plot.campaign import campaign_figures
    from ..report import write_report

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}
    files["table"] = out / "campaign.csv"
    _atomic.write_text(files["table"], result.to_csv())
    files["settings"] = out / "settings.json"
    _atomic.write_json(files["settings"], {**result.config.settings(), "k_MS_used": result.k_MS,
                                           "k_MS_std_used": result.k_MS_std,
                                           "calibration": _strip(result.calibration)})
    previous = _previous_figures(out)
    figures: dict[str, Path] = {}
    for name, fig in campaign_figures(result).items():  # pyplot-free Figures: nothing to close
        path = out / f"{name}.png"
        with _atomic.atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=120)
        figures[name] = path
    for stale in previous - {p.name for p in figures.values()}:
        (out / stale).unlink(missing_ok=True)
    _atomic.write_json(out / _MANIFEST, sorted(p.name for p in figures.values()))
    files.update(figures)
    files["report"] = out / "report.html"
    write_report(result, files["report"], figures)
    return files


def _previous_figures(out: Path) -> set[str]:
    """Names of the PNG files the previous run wrote into ``out`` (only plain ``*.png`` names)."""
    try:
        names = json.loads(read_regular_file(out / _MANIFEST, max_bytes=1 << 20).decode("utf-8"))
    except (OSError, ValueError, RecursionError):
        return set()
    if not isinstance(names, list):
        return set()
    return {n for n in names if isinstance(n, str) and n.endswith(".png") and Path(n).name == n
            and not n.startswith(".")}


def _strip(d: Mapping[str, Any] | None) -> dict[str, Any] | None:
    if d is None:
        return None
    return {k: v for k, v in d.items() if k not in ("candidates",)}


__all__ = ["write_outputs"]
