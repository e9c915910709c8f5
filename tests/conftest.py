"""Shared pytest fixtures of the ema_rig test suite."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
# The shared folder (real UFF files from other programs, real measured FRFs) lives beside the
# repository as ../shared; EMA_RIG_SHARED points elsewhere, EMA_RIG_UFF_CORPUS at the corpus alone.
# With EMA_RIG_REQUIRE_SHARED=1 (set by .ci/run when ../shared exists) a missing folder fails
# the test instead of skipping it, so CI cannot pass by skipping.
SHARED = Path(os.environ.get("EMA_RIG_SHARED", REPO.parent / "shared"))
CORPUS = Path(os.environ.get("EMA_RIG_UFF_CORPUS", SHARED / "uff-corpus"))
REAL_FRF = SHARED / "real-frf"
_HOW = "set EMA_RIG_SHARED=/path/to/shared (the folder holding uff-corpus/ and real-frf/)"


def _shared_dir(path: Path, what: str) -> Path:
    if not path.is_dir():
        msg = f"{what} not found at {path}; {_HOW}"
        if os.environ.get("EMA_RIG_REQUIRE_SHARED") == "1":
            pytest.fail(msg)
        pytest.skip(msg)
    return path


def pytest_terminal_summary(terminalreporter, exitstatus, config) -> None:  # noqa: ARG001
    """One line per reason for the skipped tests, with how to run them (e.g. the ../shared data)."""
    from collections import Counter

    reasons: Counter[str] = Counter()
    for rep in terminalreporter.stats.get("skipped", []):
        longrepr = getattr(rep, "longrepr", None)
        text = longrepr[2] if isinstance(longrepr, tuple) and len(longrepr) == 3 else str(longrepr)
        text = str(text).removeprefix("Skipped: ")
        # the shared-data skips name their path; one line for all of them
        if _HOW in text:
            text = f"../shared not found ({SHARED}); {_HOW}"
        reasons[text] += 1
    for text, n in reasons.most_common():
        terminalreporter.write_line(f"{n} test{'s' if n != 1 else ''} skipped: {text}")


@pytest.fixture
def corpus_dir() -> Path:
    """The shared UFF conformance corpus; the test is skipped when it is absent."""
    return _shared_dir(CORPUS, "UFF corpus")


@pytest.fixture
def real_frf_dir() -> Path:
    """The shared real measured FRFs (``real-frf/``); the test is skipped when absent."""
    return _shared_dir(REAL_FRF, "real measured FRFs")


@pytest.fixture(scope="session")
def identified_at_defaults():
    """``identify(read_uff58(path), band=band)`` at the defaults, once per test session.

    The result is frozen, so tests that ask for the same file and band share one run (an
    identification of a many-mode real file takes seconds). Warnings are silenced: the tests read
    them from the result's ``warnings``.
    """
    import functools
    import warnings

    @functools.lru_cache(maxsize=8)
    def run(path: Path, band: tuple[float, float] | None = None):
        from ema_rig.identification import identify
        from ema_rig.io.uff import read_uff58

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return identify(read_uff58(path), band=band)

    return run


@pytest.fixture
def mplcleanup():
    """Use the Agg backend and close every figure a test opened."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    yield
    plt.close("all")


@pytest.fixture(scope="session")
def rig_toml_text() -> str:
    """A rig file with Table 1 of the paper and the eight sensors of the paper's rig.

    Housing: three radial (13 mounted along -Y), one lateral, one axial; spindle: two radial,
    one axial. The radial shaker drives node 11 along +Y, the axial shaker node 15 along +X.
    """
    return """
[model]
m_H = 2.566
m_S = 2.8
m_F = 205.0
k_MS = 114e6
k_AS = 650e3
k_S = 348e6
k_B = 180e3

[excitation]
radial = "11+Y"
axial = "15+X"

[[sensor]]
dof = "11+Y"
role = "housing"
axis = "radial"
[[sensor]]
dof = "12+Y"
role = "housing"
axis = "radial"
[[sensor]]
dof = "13-Y"
role = "housing"
axis = "radial"
[[sensor]]
dof = "14+Z"
role = "housing"
axis = "lateral"
[[sensor]]
dof = "15+X"
role = "housing"
axis = "axial"
[[sensor]]
dof = "21+Y"
role = "spindle"
axis = "radial"
[[sensor]]
dof = "22+Y"
role = "spindle"
axis = "radial"
[[sensor]]
dof = "23+X"
role = "spindle"
axis = "axial"
"""


@pytest.fixture
def rig_file(tmp_path: Path, rig_toml_text: str) -> Path:
    """The paper's rig file written to ``tmp_path/rig.toml``."""
    p = tmp_path / "rig.toml"
    p.write_text(rig_toml_text, encoding="utf-8")
    return p


@pytest.fixture
def mpl_texts_on_whole_pixels(monkeypatch):
    """matplotlib's own Agg renderer drawing each text with its origin at the nearest whole pixel.

    The oracle of the report renderer's texts (:func:`ema_rig.plot._render._text_cached` places
    them so, as matplotlib's Agg renderer did up to 3.10): matplotlib 3.11's ``draw_text`` itself,
    given the rounded origin, so every glyph is shaped and rendered by matplotlib and FreeType.
    """
    import math

    from matplotlib.backends.backend_agg import RendererAgg

    own = RendererAgg.draw_text

    def draw_text(self, gc, x, y, s, prop, angle, ismath=False, mtext=None):
        h = self.height
        return own(self, gc, math.floor(x + 0.5), h - math.floor(h - y + 0.5), s, prop, angle, ismath, mtext)

    monkeypatch.setattr(RendererAgg, "draw_text", draw_text)
