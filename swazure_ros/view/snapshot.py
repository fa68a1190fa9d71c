"""A scene drawn in 3D as a PNG (matplotlib's Agg canvas, no pyplot state)."""

from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from .png import save
from .scene import MOVE_COLOUR, Scene

#: Views of a snapshot: (elevation, azimuth) in degrees.
VIEWS = ((20.0, -60.0), (20.0, 30.0))
#: FLSs are drawn at this share of their diameter.
DRAWN_SIZE = 1 / 3


def snapshot_figure(scene: Scene, views: tuple[tuple[float, float], ...] = VIEWS) -> Figure:
    """The scene from each of ``views``, side by side, with one legend."""
    figure = Figure(figsize=(6.0 * len(views), 6.4), layout="constrained")
    points = scene.points
    low, high = points.min(axis=0), points.max(axis=0)
    centre, half = (low + high) / 2, float((high - low).max()) / 2 + scene.radius
    # FLSs at full size touch (beta 0.5) and hide the paths: drawn at a third of
    # their diameter. Points per cm: about 4.5 inches of 72 points span 2 * half.
    diameter_points = DRAWN_SIZE * 2 * scene.radius * 4.5 * 72 / (2 * half)
    size = max(diameter_points**2, 1.0)
    # The faded FLSs first, then the coloured ones over them.
    faded = scene.colours[:, 3] < 1.0
    for column, (elevation, azimuth) in enumerate(views):
        # Drawn in the order given, not sorted by depth: the paths stay on top.
        ax = figure.add_subplot(1, len(views), column + 1, projection="3d", computed_zorder=False)
        for layer in (faded, ~faded):
            ax.scatter(
                *points[layer].T, s=size, c=scene.colours[layer], depthshade=False, linewidths=0
            )
        if scene.highlight is not None:
            ax.scatter(
                *points[scene.highlight], s=size * 9, c=[scene.colours[scene.highlight]],
                edgecolors="black", depthshade=False, zorder=5,
            )  # fmt: skip
        for path in scene.paths:
            ax.plot(*path.points.T, color=path.colour, lw=1.8, marker="o", ms=3, zorder=3)
            ax.scatter(
                *path.points[0], s=70, marker="*", color="black", depthshade=False, zorder=4
            )
        for start, end in scene.moves:
            ax.quiver(*start, *(end - start), color=MOVE_COLOUR, arrow_length_ratio=0.3)
        limits = (ax.set_xlim, ax.set_ylim, ax.set_zlim)
        for axis, set_limits in enumerate(limits):
            set_limits(centre[axis] - half, centre[axis] + half)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=elevation, azim=azimuth)
        ax.set_xlabel("x (cm)")
        ax.set_ylabel("y (cm)")
        ax.set_zlabel("z (cm)")
        ax.set_title(f"elevation {elevation:g}°, azimuth {azimuth:g}°", fontsize=9)
    handles = [
        Line2D([], [], ls="none", marker="o", ms=8, color=colour, label=label)
        for label, colour in scene.legend
    ]
    handles += [
        Line2D([], [], color=path.colour, lw=2, marker="o", ms=3, label=f"path: {path.label}")
        for path in scene.paths
    ]
    if scene.paths:
        handles.append(
            Line2D([], [], ls="none", marker="*", ms=9, color="black", label="a path's source")
        )
    if scene.moves:
        handles.append(Line2D([], [], color=MOVE_COLOUR, lw=2, label="moves"))
    figure.legend(handles=handles, loc="outside lower center", ncols=3, fontsize=8)
    figure.suptitle(f"{scene.title}\n(FLSs drawn at a third of their size)", fontsize=11)
    return figure


def write_snapshot(scene: Scene, path: Path) -> Path:
    """Draw ``scene`` and write it as PNG to ``path``, atomically."""
    return save(snapshot_figure(scene), path)
