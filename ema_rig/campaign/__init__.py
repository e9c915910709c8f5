"""Campaigns: bearing stiffness over many measurements, one row per measurement.

A campaign file (TOML) names the rig file, an optional steel-disk calibration file and one
``[[measurement]]`` table per UFF export with its conditions::

    rig = "rig.toml"                  # relative to the campaign file
    calibration = "disk.uff"          # optional: k_MS from a steel-disk run
    k_disk = 2.0e9                    # optional: finite stiffness of the disk [N/m] (wins over
                                      # the rig file's [calibration] k_disk)
    k_disk_std = 2.0e8                # optional: its standard uncertainty [N/m] (needs k_disk)
    title = "6302 campaign"           # optional

    [defaults]                        # optional identification settings
    band = [150.0, 1000.0]            # Hz
    max_order = 60

    [bearings.dummy]                  # optional, per bearing name
    k_lower = 31.14e6                 # FE bounds [N/m], drawn as a band
    k_upper = 34.12e6
    [bearings.6205]                   # the Hertzian estimate (ema_rig.rig.hertz) of this geometry
    n_balls = 9
    ball_diameter = 7.938e-3          # m
    pitch_diameter = 38.5e-3          # m
    [output]                          # optional: CSV units, per-measurement report figures
    stiffness_unit = "MN/m"           # N/m (default), MN/m, N/µm
    damping_unit = "%"                # - (default) or %

    [[measurement]]
    file = "m001.uff"
    bearing = "6302"
    radial_load = 1000.0              # N
    speed = 600.0                     # rpm (0 = not rotating)
    shaft_position = 0.0              # deg (optional)
    repeat = 1                        # optional, >= 1
    tags = ["lifetime"]               # optional free-form
    id = "m001"                       # optional, default: the file stem; a plain file name

:func:`run` processes the measurements (in parallel with ``jobs`` processes or any
:class:`concurrent.futures.Executor`, e.g. ``dask.distributed.Client.get_executor()``), writes a
JSON result per measurement as soon as it finishes, skips measurements whose inputs (file content,
the rig's content, settings, version) have not changed since a previous run, and returns a
:class:`CampaignResult`.

Modules
-------
schema
    The campaign file into :class:`CampaignConfig` (:func:`load_campaign`).
runner
    What a measurement depends on (:class:`MeasurementTask`), the cache, the pool, :func:`run`.
result
    :class:`CampaignResult` and the table (:data:`COLUMNS`).
outputs
    CSV, settings, figures and report (:func:`write_outputs`); with drilldown (each
    measurement's figures) the only parts that plot.
"""

from __future__ import annotations

from .outputs import write_outputs
from .result import COLUMNS, CampaignResult, summary_rows
from .runner import MeasurementTask, process_measurement, run
from .schema import BearingInfo, CampaignConfig, Measurement, load_campaign

__all__ = [
    "BearingInfo",
    "COLUMNS",
    "CampaignConfig",
    "CampaignResult",
    "Measurement",
    "MeasurementTask",
    "load_campaign",
    "process_measurement",
    "run",
    "summary_rows",
    "write_outputs",
]
