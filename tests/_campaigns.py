"""Test helper: a small campaign of simulated 6302 measurements written into a folder."""

from __future__ import annotations

from pathlib import Path


def simulated_6302_campaign(d: Path, rig_toml_text: str, k_tb: dict[str, float], *, seed: int,
                            broken: bool = False) -> Path:
    """Write ``rig.toml``, one simulated measurement per ``{id: k_TB [N/m]}`` and ``campaign.toml``.

    Ids are ``<letter><radial load in N>`` (e.g. ``"p400"``); measurement ``i`` uses seed
    ``seed + i``, 0.5 % noise, max order 24, the per-measurement figures on (the default).
    ``broken`` adds a measurement whose file is not UFF. Returns ``d``.
    """
    from ema_rig.config import load_rig
    from ema_rig.simulate import simulate_measurement, write_measurement

    (d / "rig.toml").write_text(rig_toml_text, encoding="utf-8")
    rig = load_rig(d / "rig.toml")
    lines = ['rig = "rig.toml"', "[defaults]", "max_order = 24"]
    for i, (mid, k) in enumerate(k_tb.items()):
        write_measurement(simulate_measurement(rig, k_tb=k, noise=0.005, seed=seed + i), d / f"{mid}.uff", rig=rig)
        lines += ["[[measurement]]", f'file = "{mid}.uff"', 'bearing = "6302"', f"radial_load = {mid[1:]}.0"]
    if broken:
        (d / "broken.uff").write_text("not a UFF file\n", encoding="utf-8")
        lines += ["[[measurement]]", 'file = "broken.uff"', 'bearing = "6302"', "radial_load = 1500.0"]
    (d / "campaign.toml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return d
