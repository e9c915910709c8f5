"""The calibration disk's stiffness as a rig-file key and a campaign key (which one wins)."""

from __future__ import annotations

import pytest

from ema_rig.campaign.schema import load_campaign
from ema_rig.errors import ConfigError


def _write(tmp_path, rig_toml_text, rig_extra="", camp_extra=""):
    (tmp_path / "rig.toml").write_text(rig_toml_text + rig_extra, encoding="utf-8")
    (tmp_path / "disk.uff").write_text("", encoding="utf-8")
    (tmp_path / "a.uff").write_text("", encoding="utf-8")
    camp = tmp_path / "campaign.toml"
    camp.write_text(
        f'rig = "rig.toml"\ncalibration = "disk.uff"\n{camp_extra}\n[[measurement]]\nfile = "a.uff"\n',
        encoding="utf-8",
    )
    return camp


def test_rig_file_disk_reaches_the_campaign(tmp_path, rig_toml_text):
    camp = _write(tmp_path, rig_toml_text, "\n[calibration]\nk_disk = 1.5e9\nk_disk_std = 1e8\n")
    cfg = load_campaign(camp)
    assert (cfg.k_disk, cfg.k_disk_std) == (1.5e9, 1e8)
    assert cfg.settings()["k_disk_std"] == 1e8


def test_campaign_disk_wins_over_the_rig_file(tmp_path, rig_toml_text):
    camp = _write(tmp_path, rig_toml_text, "\n[calibration]\nk_disk = 1.5e9\nk_disk_std = 1e8\n",
                  "k_disk = 2e9\nk_disk_std = 3e8\n")
    cfg = load_campaign(camp)
    # both the campaign's and the rig the calibration task receives carry the campaign's values
    assert (cfg.k_disk, cfg.k_disk_std) == (2e9, 3e8)
    assert (cfg.rig.k_disk, cfg.rig.k_disk_std) == (2e9, 3e8)
    # a campaign k_disk without its std does not inherit the rig file's std (another disk)
    camp = _write(tmp_path, rig_toml_text, "\n[calibration]\nk_disk = 1.5e9\nk_disk_std = 1e8\n", "k_disk = 2e9\n")
    cfg = load_campaign(camp)
    assert (cfg.k_disk, cfg.k_disk_std) == (2e9, None)


def test_no_disk_anywhere_is_rigid(tmp_path, rig_toml_text):
    cfg = load_campaign(_write(tmp_path, rig_toml_text))
    assert (cfg.k_disk, cfg.k_disk_std) == (None, None)


@pytest.mark.parametrize(
    ("extra", "key"),
    [("k_disk_std = 1e8\n", "k_disk_std"), ("k_disk = 0\n", "k_disk"), ("k_disk = 1e9\nk_disk_std = true\n", "k_disk_std")],
)
def test_campaign_disk_keys_validated(tmp_path, rig_toml_text, extra, key):
    camp = _write(tmp_path, rig_toml_text, camp_extra=extra)
    with pytest.raises(ConfigError, match=key) as ei:
        load_campaign(camp)
    assert "campaign.toml" in str(ei.value)
