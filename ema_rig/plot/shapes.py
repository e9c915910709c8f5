"""Mode shape display (undeformed and deformed geometry) and the AutoMAC matrix.

Functions
---------
plot_mode_shape
    One mode: on the test geometry in 3D (undeformed in grey, deformed in colour) when a
    :class:`~ema_rig.io.geometry.Geometry` is given, else a bar chart of the shape per DOF.
plot_automac
    AutoMAC of the identified modes as an annotated matrix (values from
    :func:`ema_rig.identification.mac`).

Classes
-------
ShapePlot, AutoMACPlot
    What the functions return: figure, axes and artists by kind.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..identification.mac import mac, mpc
from ..mode_shapes import mode_shapes_records, real_shapes

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..dof import DOF
    from ..identification.modal import ModalModel
    from ..io.geometry import Geometry


@dataclass(frozen=True, slots=True)
class ShapePlot:
    """Result of :func:`plot_mode_shape`.

    Attributes
    ----------
    figure : Figure
    ax : Axes
        A 3D axes with geometry, else a 2D bar-chart axes.
    undeformed, deformed : list
        Line / marker artists of the undeformed and deformed geometry (empty in a bar chart).
    bars : list
        Bar containers of the bar chart (empty in 3D).
    displacement : ndarray, shape (n_nodes, 3)
        Drawn displacement of every geometry node (scaled, file length unit); zeros without
        geometry.
    unmapped : tuple of str
        Response DOFs whose node is not in the geometry (not drawn).
    labels : list
        Node-number texts: only the measured nodes, and only when at most
        :data:`MAX_NODE_LABELS` of them (more would be unreadable).
    """

    figure: Figure
    ax: Axes
    undeformed: list[Any] = field(default_factory=list)
    deformed: list[Any] = field(default_factory=list)
    bars: list[Any] = field(default_factory=list)
    displacement: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))
    unmapped: tuple[str, ...] = ()
    labels: list[Any] = field(default_factory=list)


MAX_NODE_LABELS = 40
"""Most node numbers written on a 3D shape plot (at 7 pt on a 6.4 x 5.2 in figure, more overlap)."""
MAX_NODE_MARKERS = 1000
"""Above this many nodes only the measured nodes get a marker (the rest would be a solid blot)."""


@dataclass(frozen=True, slots=True)
class AutoMACPlot:
    """Result of :func:`plot_automac`.

    Attributes
    ----------
    figure : Figure
    ax : Axes
    image : AxesImage
    values : ndarray, shape (n_modes, n_modes)
        The AutoMAC drawn.
    texts : list
        The value annotations.
    """

    figure: Figure
    ax: Axes
    image: Any
    values: NDArray[np.float64]
    texts: list[Any] = field(default_factory=list)


def _mode_title(model: ModalModel, mode: int) -> str:
    return (f"mode {mode + 1}: {model.natural_freq[mode]:.2f} Hz, "
            f"damping {100 * model.damping_ratio[mode]:.2f} %")


def _node_displacement(geometry: Geometry, dofs: tuple[DOF, ...], values: NDArray[np.float64]
                       ) -> tuple[NDArray[np.float64], tuple[str, ...]]:
    disp = np.zeros((geometry.n_nodes, 3))
    rows = geometry.rows([d.node for d in dofs])
    unmapped = []
    for d, v, i in zip(dofs, values, rows, strict=True):
        axis = abs(d.direction)
        if i < 0 or not 1 <= axis <= 3:
            unmapped.append(str(d))
            continue
        disp[i, axis - 1] += d.sign * v
    return disp, tuple(unmapped)


def plot_mode_shape(
    model: ModalModel,
    mode: int,
    *,
    geometry: Geometry | None = None,
    ref: DOF | str | None = None,
    scale: float = 0.15,
    ax: Axes | None = None,
) -> ShapePlot:
    """Draw one mode shape.

    Parameters
    ----------
    model : ModalModel
        Identified modes.
    mode : int
        0-based mode index (modes are sorted by natural frequency).
    geometry : Geometry, optional
        Test geometry (:func:`ema_rig.io.geometry.read_geometry`). Without it, or when no
        response DOF lies on a geometry node, the shape is drawn as bars per DOF.
    ref : DOF or str, optional
        Reference whose residues give the shape (default: the first driving point).
    scale : float, optional
        Largest drawn displacement as a fraction of the geometry's size (default 0.15).
    ax : Axes, optional
        Axes to draw into (a 3D axes when drawing geometry); default a new figure.

    Returns
    -------
    ShapePlot

    Notes
    -----
    The deformed geometry shows the real form of the shape
    (:func:`ema_rig.mode_shapes.real_shapes`); the title gives the MPC, which says how much of
    a complex shape that view leaves out.
    """
    from matplotlib.figure import Figure

    if not 0 <= mode < model.n_modes:
        raise IndexError(f"mode {mode} out of range: the model has {model.n_modes} mode(s)")
    rec = mode_shapes_records(model, ref=ref)[mode]
    phi = np.array([complex(s["re"], s["im"]) for s in rec["shape"]])
    real = real_shapes(phi)[0]
    title = f"{_mode_title(model, mode)}, MPC {float(mpc(phi)[0]):.3f} (ref {rec['reference']})"
    disp = np.zeros((0, 3))
    unmapped: tuple[str, ...] = ()
    if geometry is not None:
        disp, unmapped = _node_displacement(geometry, model.out_dofs, real)
        if len(unmapped) == len(model.out_dofs):
            geometry = None  # nothing to draw on it
    if geometry is None:
        if ax is None:
            fig = Figure(figsize=(max(5.0, 0.6 * len(real) + 2.0), 3.6), layout="constrained")
            ax = fig.add_subplot()
        else:
            fig = ax.get_figure()  # type: ignore[assignment]
        peak = float(np.max(np.abs(real))) or 1.0
        labels = [s["dof"] for s in rec["shape"]]
        bars = ax.bar(range(len(real)), real / peak, color=["tab:blue" if v >= 0 else "tab:red" for v in real])
        ax.axhline(0.0, color="0.3", lw=0.8)
        ax.set_xticks(range(len(real)), labels, rotation=45 if len(real) > 6 else 0)
        ax.set_xlabel("response DOF")
        ax.set_ylabel("real shape / largest [-]")
        ax.set_ylim(-1.1, 1.1)
        ax.set_title(title, fontsize=10)
        return ShapePlot(figure=fig, ax=ax, bars=[bars], unmapped=unmapped)

    if ax is None:
        fig = Figure(figsize=(6.4, 5.2), layout="constrained")
        ax = fig.add_subplot(projection="3d")
    else:
        fig = ax.get_figure()  # type: ignore[assignment]
    ax3: Any = ax  # Axes3D: scatter/text/plot take z, and set_zlabel/set_zlim exist
    peak = float(np.max(np.linalg.norm(disp, axis=1))) or 1.0
    disp = disp * (scale * geometry.size / peak)
    xyz = geometry.coords
    moved = xyz + disp
    und: list[Any] = []
    dfm: list[Any] = []
    measured = np.unique(geometry.rows([d.node for d in model.out_dofs]))
    measured = measured[measured >= 0]
    large = geometry.n_nodes > MAX_NODE_MARKERS
    if geometry.lines:  # one collection per state: a Line3D per trace line took minutes for 10^4 nodes
        from mpl_toolkits.mplot3d.art3d import Line3DCollection

        ij = geometry.rows(np.asarray(geometry.lines).ravel()).reshape(-1, 2)
        und.append(ax3.add_collection3d(Line3DCollection(xyz[ij], colors="0.6", linewidths=0.4 if large else 1.0,
                                                         linestyles="--")))
        dfm.append(ax3.add_collection3d(Line3DCollection(moved[ij], colors="tab:blue",
                                                         linewidths=0.6 if large else 1.8)))
    # a marker per node where they can be told apart; on a large geometry only the measured nodes
    dots = measured if large else np.arange(geometry.n_nodes)
    und.append(ax3.scatter(*xyz[dots].T, color="0.5", s=12, label="undeformed"))
    dfm.append(ax3.scatter(*moved[dots].T, color="tab:blue", s=18, label="deformed" if not large
                           else "deformed (measured nodes marked)"))
    shown = np.arange(geometry.n_nodes) if geometry.n_nodes <= MAX_NODE_LABELS else measured
    labels = [] if shown.size > MAX_NODE_LABELS else [
        ax3.text(*xyz[i], f" {geometry.node_ids[i]}", fontsize=7, color="0.4") for i in shown]
    ax.set_xlabel("X")
    ax.set_ylabel("Y")
    ax3.set_zlabel("Z")
    lo, hi = np.minimum(xyz, moved).min(axis=0), np.maximum(xyz, moved).max(axis=0)
    mid, half = (lo + hi) / 2, max(float((hi - lo).max()) / 2, 1e-12)
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    ax3.set_zlim(mid[2] - half, mid[2] + half)
    ax.set_title(title, fontsize=10)
    ax.legend(loc="upper left", fontsize=8)
    return ShapePlot(figure=fig, ax=ax, undeformed=und, deformed=dfm, displacement=disp, unmapped=unmapped,
                     labels=labels)


def plot_automac(model: ModalModel, *, ref: DOF | str | None = None, ax: Axes | None = None) -> AutoMACPlot:
    """Draw the AutoMAC matrix of the identified mode shapes.

    Parameters
    ----------
    model : ModalModel
        Identified modes (at least one).
    ref : DOF or str, optional
        Reference whose residues give the shapes (MAC does not depend on the scaling).
    ax : Axes, optional
        Axes to draw into; default a new figure.

    Returns
    -------
    AutoMACPlot
        ``values`` is :func:`ema_rig.identification.mac` of the shapes with themselves.
    """
    from matplotlib.figure import Figure

    if model.n_modes == 0:
        raise ValueError("the model has no mode: nothing to correlate")
    recs = mode_shapes_records(model, ref=ref)
    phi = np.array([[complex(s["re"], s["im"]) for s in r["shape"]] for r in recs])
    values = mac(phi)
    n = values.shape[0]
    if ax is None:
        side = min(9.0, 2.5 + 0.55 * n)
        fig = Figure(figsize=(side + 1.0, side), layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.get_figure()  # type: ignore[assignment]
    image = ax.imshow(values, vmin=0.0, vmax=1.0, cmap="viridis", origin="upper")
    fig.colorbar(image, ax=ax, label="MAC [-]")
    labels = [f"{f:.1f}" for f in model.natural_freq]
    ax.set_xticks(range(n), labels, rotation=45 if n > 4 else 0)
    ax.set_yticks(range(n), labels)
    ax.set_xlabel("mode [Hz]")
    ax.set_ylabel("mode [Hz]")
    texts = []
    if n <= 15:
        for i in range(n):
            for j in range(n):
                v = values[i, j]
                texts.append(ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=8,
                                     color="black" if v > 0.6 else "white"))
    ax.set_title(f"AutoMAC, reference {recs[0]['reference']}", fontsize=10)
    return AutoMACPlot(figure=fig, ax=ax, image=image, values=values, texts=texts)


__all__ = ["MAX_NODE_LABELS", "MAX_NODE_MARKERS", "AutoMACPlot", "ShapePlot", "plot_automac", "plot_mode_shape"]
