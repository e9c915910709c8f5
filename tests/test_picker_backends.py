"""The pole picker in the two places a test engineer uses it (issue 20): Jupyter with ipympl, and a
desktop window (TkAgg).

ipympl: the clicks and keys are the JSON messages its browser front end sends to the kernel
(``{"type": "button_press", "x": ..., "y": ...}``, y from the top of the canvas), handed to the
canvas widget's message handler as the comm would; no browser is needed. TkAgg: a real Tk window in
a child process on the X display (``DISPLAY``, or a virtual one from ``xvfb-run``), the clicks and
keys generated as X events on the canvas widget. Each test skips with its reason when the backend
cannot run here (``pip install ipympl``; ``apt-get install xvfb``), unless
``EMA_RIG_REQUIRE_DESKTOP=1`` (set by CI), which turns that skip into a failure.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]


def _skip(reason: str) -> None:
    if os.environ.get("EMA_RIG_REQUIRE_DESKTOP") == "1":
        pytest.fail(f"EMA_RIG_REQUIRE_DESKTOP=1 but {reason}")
    pytest.skip(reason)


def _case():
    from lumped import five_mode_system

    from ema_rig.identification import identify

    data = five_mode_system().frf(np.arange(0.0, 1000.5, 0.5), inputs=(0, 1), noise=0.01,
                                  rng=np.random.default_rng(4))
    return data, identify(data, band=(100.0, 900.0))


def _stable_pole(chart, near_freq: float) -> tuple[float, float]:
    """(freq, order) of the stable pole at the highest order nearest ``near_freq`` [Hz]."""
    line = chart.poles["s"]
    f, o = np.asarray(line.get_xdata()), np.asarray(line.get_ydata())
    k = int(np.argmin(np.abs(f - near_freq) / near_freq + 1e-4 * (o.max() - o)))
    return float(f[k]), float(o[k])


# ipympl's Toolbar passes its canvas on to traitlets' HasTraits (its own code, any use of ipympl)
@pytest.mark.filterwarnings(r"ignore:Passing unrecognized arguments to super\(Toolbar\):DeprecationWarning")
def test_picker_through_ipympl_messages(mplcleanup) -> None:
    try:
        from ipympl.backend_nbagg import _Backend_ipympl
    except ImportError:
        _skip("ipympl is not installed (pip install ipympl)")
    from ema_rig.plot.picker import PolePicker
    from ema_rig.plot.stabilization import plot_stabilization

    data, ident = _case()
    chart = plot_stabilization(ident.stabilization, data, selection=ident.selection)
    manager = _Backend_ipympl.new_figure_manager_given_figure(1, chart.figure)
    canvas = manager.canvas
    try:
        assert type(canvas).__module__ == "ipympl.backend_nbagg"
        picker = PolePicker(chart)
        canvas.draw()
        height = canvas.get_renderer().height

        def send(**content):  # what the front end sends over the widget's comm
            canvas._handle_message(canvas, {"modifiers": [], "buttons": 0, "button": 0, **content}, [])

        def click(f, o):
            x, y = chart.axes.transData.transform((f, o))
            send(type="button_press", x=float(x), y=float(height - y), buttons=1)
            send(type="button_release", x=float(x), y=float(height - y))

        limits = (chart.axes.get_xlim(), chart.axes.get_ylim())
        a, b = _stable_pole(chart, 640.0), _stable_pole(chart, 300.0)
        click(*a)
        assert len(picker.picks) == 1 and picker.picks[0][0] == int(a[1])
        assert (chart.axes.get_xlim(), chart.axes.get_ylim()) == limits  # the chart held still
        click(*a)  # the same place again: un-picked
        assert picker.picks == [] and (chart.axes.get_xlim(), chart.axes.get_ylim()) == limits
        click(*a)
        click(*b)
        first = picker.picks[0]
        send(type="key_press", key="ku")  # undo the second pick ("k" + the browser's key name)
        assert picker.picks == [first]
        send(type="key_press", key="kEscape")  # matplotlib names it "escape"
        assert picker.picks == []
        assert [m.provenance for m in PolePicker(chart).selection.modes] == []
    finally:
        canvas.close()


_TK_SCRIPT = r"""
import json, sys
import matplotlib
matplotlib.use("TkAgg")
import matplotlib.pyplot as plt
import numpy as np
sys.path[:0] = sys.argv[1:3]
from test_picker_backends import _case, _stable_pole
from ema_rig.plot.picker import PolePicker
from ema_rig.plot.stabilization import plot_stabilization

data, ident = _case()
fig, ax = plt.subplots(figsize=(8, 5))
chart = plot_stabilization(ident.stabilization, data, ax=ax, selection=ident.selection)
picker = PolePicker(chart)
plt.show(block=False)
canvas = fig.canvas
widget = canvas.get_tk_widget()
widget.update()
widget.focus_force()
widget.update()
out = {"backend": type(canvas).__name__, "limits": [list(ax.get_xlim()), list(ax.get_ylim())]}

def click(f, o):
    x, y = ax.transData.transform((f, o))
    tx, ty = int(round(x)), int(round(fig.bbox.height - y))  # Tk: pixels from the top left
    widget.event_generate("<Motion>", x=tx, y=ty, warp=True)
    widget.event_generate("<ButtonPress-1>", x=tx, y=ty)
    widget.event_generate("<ButtonRelease-1>", x=tx, y=ty)
    widget.update()

def key(sym):
    widget.event_generate("<KeyPress>", keysym=sym)
    widget.event_generate("<KeyRelease>", keysym=sym)
    widget.update()

a, b = _stable_pole(chart, 640.0), _stable_pole(chart, 300.0)
click(*a)
out["after_one"] = [list(p) for p in picker.picks]
out["limits_after"] = [list(ax.get_xlim()), list(ax.get_ylim())]
click(*a)
out["after_two"] = [list(p) for p in picker.picks]
click(*a)
click(*b)
out["after_four"] = [list(p) for p in picker.picks]
key("u")
out["after_undo"] = [list(p) for p in picker.picks]
key("Escape")
out["after_escape"] = [list(p) for p in picker.picks]
out["order_a"] = a[1]
plt.close(fig)
print(json.dumps(out))
"""


def test_picker_in_a_tk_window(tmp_path: Path) -> None:
    try:
        import tkinter  # noqa: F401
    except ImportError:
        _skip("tkinter is not available (apt-get install python3-tk)")
    cmd = [sys.executable, "-c", _TK_SCRIPT, str(REPO), str(REPO / "tests")]
    if not os.environ.get("DISPLAY"):
        if shutil.which("xvfb-run") is None:
            _skip("no X display and no xvfb-run (apt-get install xvfb)")
        # -a alone starts its search at display 99 in every process, so two test runs started at once can
        # race for the same display; starting from a number drawn from the pid spreads them apart, and
        # -e keeps the X server's own messages for the assertion below
        cmd = ["xvfb-run", "-a", "-n", str(100 + os.getpid() % 800), "-e", str(tmp_path / "xvfb.log"),
               "-s", "-screen 0 1280x1024x24", *cmd]
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=tmp_path, env=env)
    xlog = tmp_path / "xvfb.log"
    assert r.returncode == 0, r.stderr[-2000:] + (xlog.read_text()[-1000:] if xlog.exists() else "")
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["backend"] == "FigureCanvasTkAgg"
    assert len(out["after_one"]) == 1 and out["after_one"][0][0] == int(out["order_a"])  # the clicked pole
    assert out["limits_after"] == out["limits"]  # the chart held still
    assert out["after_two"] == []  # a second click on the same spot un-picks
    assert len(out["after_four"]) == 2 and out["after_undo"] == out["after_four"][:1]  # "u" undoes
    assert out["after_escape"] == []
