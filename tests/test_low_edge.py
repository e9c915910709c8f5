"""The default band and the DC line: dam0's 0 Hz lines must not decide the fit.

Review6 defect 4: on ``dam0.unv`` (26 accelerances, 0-12.5 Hz) the FRFs are ~1000x larger at 0 and
0.03 Hz than at 1.4 Hz (a DC offset: an accelerance tends to its mass line, not upwards, at 0 Hz),
which no mode or residual term represents. The default band (the whole data) gave a median
synthesis error of 98 % and two spurious modes (5.124 Hz, MPC 0.45; 9.483 Hz, MPC 0.45). Oracle:
the peer's modes of ``real-frf/README.md`` (sdypy-EMA LSCF, 1-12 Hz) and the measurement itself
(the synthesis error), not the code's own lower-edge test.
"""

from __future__ import annotations

import numpy as np
import pytest

from ema_rig.identification import identify

# sdypy-EMA 0.31 LSCF, 1-12 Hz, orders to 160 (real-frf/README.md)
PEER = np.array([2.482, 2.958, 3.497, 4.081, 4.167, 4.633, 7.124, 8.223, 8.643, 10.21, 10.89])


@pytest.fixture
def dam0(real_frf_dir):
    from ema_rig.io.uff import read_uff58

    return read_uff58(real_frf_dir / "dam0.unv")


def test_default_band_starts_above_the_dc_lines(dam0):
    ident = identify(dam0)
    lo, hi = ident.band
    # above the DC lines (0 and 0.03 Hz), below the lowest mode (2.48 Hz, half-power width 0.06 Hz)
    assert 0.0625 < lo < 2.4 and hi == 12.5
    assert any(n.startswith(f"the default band starts at {lo:.6g} Hz") for n in ident.notes)
    # the fit explains the measurement: below poor_fit (20 %); 98 % with the DC lines in the band
    assert float(np.median(ident.fit_error)) < 0.20
    # every peer mode found, within 0.5 % (the peers' spread at 8.2-8.7 Hz is ~0.3 %)
    for f in PEER:
        assert np.min(np.abs(ident.natural_freq - f)) < 0.005 * f, f
    # no mode at the spurious 9.483 Hz of the DC-dominated fit (a peer-free gap 8.64..10.21 Hz)
    assert not np.any((ident.natural_freq > 9.0) & (ident.natural_freq < 10.0))


def test_an_explicit_band_over_the_dc_lines_is_kept_and_warned(dam0):
    ident = identify(dam0, band=(0.0, 12.5))
    assert ident.band == (0.0, 12.5)  # the user's band is the user's
    (w,) = [w for w in ident.warnings if "lower residual" in w]
    assert "DC offset" in w and "--band 1.38 12.5" in w
