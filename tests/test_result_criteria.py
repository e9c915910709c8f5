"""The result warnings' thresholds and the clustering scales live in the criteria objects (issue 18, Build 5)."""

from __future__ import annotations

import dataclasses

import numpy as np

from ema_rig.frf import FRFData
from ema_rig.identification import identify
from ema_rig.identification.criteria import (
    IdentificationCriteria,
    ResultCriteria,
    StabilizationCriteria,
)
from ema_rig.identification.identification import POOR_FIT, _edge_warnings
from ema_rig.identification.stabilization import cluster_poles

FN, ZETA = 150.0, 0.01


def _one_mode(noise: float = 0.0) -> FRFData:
    """Receptance of one mode at 150 Hz, 1 % damping (analytic), optional proportional complex noise."""
    f = np.arange(0.0, 400.5, 0.5)
    jw = 2j * np.pi * f
    lam = -ZETA * 2 * np.pi * FN + 2j * np.pi * FN * np.sqrt(1 - ZETA**2)
    h = (1 / (jw - lam) + 1 / (jw - lam.conjugate())) / (4j * np.pi * FN)
    rng = np.random.default_rng(3)
    h = h * (1 + noise * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)))
    return FRFData(f, h[None, None], ["1+Y"], ["1+Y"], frf_form="receptance")


def test_edge_margin_is_the_half_power_bandwidth_or_a_share_of_the_band():
    ident = identify(_one_mode(), band=(50, 350))
    assert ident.natural_freq.round(3).tolist() == [FN]
    # 2 zeta f_n = 3 Hz and 1 % of a 300 Hz band = 3 Hz: 150 Hz is far from both edges
    assert _edge_warnings(ident.modes, (50.0, 350.0)) == []
    # the same mode 2.5 Hz inside a band edge: within its half-power bandwidth (3 Hz), warned
    assert len(_edge_warnings(ident.modes, (147.5, 350.0))) == 1
    # ... 3.5 Hz inside: outside the bandwidth and 1 % of the band's 202.5 Hz (2.0 Hz): no warning
    assert _edge_warnings(ident.modes, (146.5, 350.0)) == []
    # the criteria's fields set the margin: 4 half-bandwidths (6 Hz) or 5 % of the band (10 Hz)
    assert len(_edge_warnings(ident.modes, (146.5, 350.0), ResultCriteria(edge_hbw=4.0))) == 1
    assert len(_edge_warnings(ident.modes, (140.5, 350.0), ResultCriteria(edge_band_share=0.05))) == 1


def test_poor_fit_threshold_from_the_criteria():
    assert POOR_FIT == ResultCriteria().poor_fit == 0.20  # the old module constant keeps its value
    data = _one_mode(noise=0.02)
    ident = identify(data, band=(50, 350))
    assert not any(w.startswith("poor fit") for w in ident.warnings)
    # 2 % proportional noise: the relative synthesis error is about 3 %, below 20 %, far above 1e-6
    strict = IdentificationCriteria(result=ResultCriteria(poor_fit=1e-6))
    assert any(w.startswith("poor fit") for w in identify(data, band=(50, 350), criteria=strict).warnings)


def test_cluster_scales_from_the_criteria_and_old_keywords():
    ident = identify(_one_mode(noise=0.01), band=(50, 350))
    stab = ident.stabilization
    crit = StabilizationCriteria()
    assert (crit.cluster_freq_tol, crit.cluster_damping_tol, crit.cluster_mac_tol) == (0.005, 0.5, 0.1)
    default = cluster_poles(stab)
    old_kw = cluster_poles(stab, freq_tol=0.005, damping_tol=0.5, mac_tol=0.1)
    assert [r.tolist() for r in default] == [r.tolist() for r in old_kw]
    # a damping scale far below the scatter of the damping across orders splits the mode's cluster;
    # the keyword wins over the criteria
    fine = dataclasses.replace(crit, cluster_damping_tol=1e-6)
    assert len(cluster_poles(stab, criteria=fine)) > len(default)
    assert [r.tolist() for r in cluster_poles(stab, criteria=fine, damping_tol=0.5)] == [r.tolist() for r in default]
