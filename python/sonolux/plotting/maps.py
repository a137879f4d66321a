"""Parameter maps over the floor plan: one coloured cell per receiver, x along the plot's
width, y up (as the scene is seen from above), the room's outline cut at the receivers' height
and the sources marked with stars."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sonolux.analysis.params import PARAMETERS, RoomParameters
from sonolux.outputs import write_atomically
from sonolux.plotting import pyplot
from sonolux.sound.field import SoundField

MAP_NAMES = ("t30_s", "c80_db", "d50", "g_db")
_CMAPS = {"t30_s": "viridis", "edt_s": "viridis", "t20_s": "viridis", "c80_db": "magma",
          "c50_db": "magma", "d50": "cividis", "g_db": "plasma", "ts_s": "viridis",
          "jlf": "cividis", "jlfc": "cividis"}


def plan_section(vertices_m: np.ndarray, triangles: np.ndarray, height_m: float) -> np.ndarray:
    """Segments float[n, 2, 2] (xy) where the triangles cross the plane z = height_m."""
    h = height_m + 1e-7  # off any vertex that lies exactly on the plane
    tri = vertices_m[triangles]  # [n, 3 corners, 3]
    d = tri[..., 2] - h
    points = []
    for a, b in ((0, 1), (1, 2), (2, 0)):
        da, db = d[:, a], d[:, b]
        cross = da * db < 0
        with np.errstate(invalid="ignore", divide="ignore"):
            f = np.where(cross, da / (da - db), 0.0)
        p = tri[:, a, :2] + (tri[:, b, :2] - tri[:, a, :2]) * f[:, None]
        points.append(np.where(cross[:, None], p, np.nan))
    pts = np.stack(points, axis=1)  # [n, 3 edges, 2]
    ok = np.isfinite(pts[..., 0])
    keep = ok.sum(axis=1) == 2
    return np.stack([pts[k][ok[k]] for k in np.nonzero(keep)[0]]) if keep.any() \
        else np.zeros((0, 2, 2))


def grid_image(field: SoundField, receivers: np.ndarray, values: np.ndarray):
    """(image float[ny, nx] with NaN where no receiver, extent (x0, x1, y0, y1)) for a grid."""
    return cells_image(field.positions_m[receivers], field.grid_index[receivers],
                       field.grid_spacing_m, values)


def cells_image(positions_m: np.ndarray, grid_index: np.ndarray, spacing_m: float,
                values: np.ndarray):
    """(image float[ny, nx] with NaN where no cell, extent (x0, x1, y0, y1)) of values on the
    cells of a regular grid (centres ``positions_m``, indices ``grid_index`` (i along x, j
    along y), ``spacing_m`` apart): x along the columns, y along the rows."""
    gi = np.asarray(grid_index)
    s = spacing_m
    origin = np.asarray(positions_m)[0, :2] - s * gi[0]
    lo, hi = gi.min(axis=0), gi.max(axis=0)
    img = np.full((hi[1] - lo[1] + 1, hi[0] - lo[0] + 1), np.nan)
    img[gi[:, 1] - lo[1], gi[:, 0] - lo[0]] = values
    x0, y0 = origin + s * lo - s / 2
    x1, y1 = origin + s * hi + s / 2
    return img, (x0, x1, y0, y1)


def _limits(values: np.ndarray, excluded: np.ndarray) -> tuple[float, float]:
    v = values[~excluded & np.isfinite(values)]
    if v.size == 0:
        v = values[np.isfinite(values)]
    if v.size == 0:
        return 0.0, 1.0
    lo, hi = float(v.min()), float(v.max())
    return (lo, hi) if hi > lo else (lo - 0.5, hi + 0.5)


def _undefined_areas(fig, axes, names, params: RoomParameters, column: int,
                     field: SoundField) -> list[dict]:
    """Pixel boxes (from the image's top left) of the undefined receivers on each map."""
    half = 0.5 * (field.grid_spacing_m or 2 * field.radius_m)
    height_px = fig.get_size_inches()[1] * fig.dpi
    out = []
    for ax, name in zip(axes, names):
        label = PARAMETERS[name][0]
        reasons = params.reasons.get(name.removesuffix("_s"))
        for r in np.nonzero(~np.isfinite(params.values[name][:, column]))[0]:
            x, y = params.positions_m[r, :2]
            (x0, y0), (x1, y1) = ax.transData.transform([(x - half, y - half),
                                                         (x + half, y + half)])
            why = (reasons[r, column] if reasons is not None else "") or "not defined here"
            out.append({"box_px": (round(x0), round(height_px - y1), round(x1),
                                   round(height_px - y0)),
                        "title": f"{label} undefined at #{params.receivers[r]}: {why}"})
    return out


def plot_parameter_maps(field: SoundField, params: RoomParameters, path: str | Path, *,
                        names=MAP_NAMES, column: int = -1, outline=None,
                        mark_m: tuple[float, float] | None = None,
                        undefined_areas: list | None = None) -> Path:
    """Maps of ``names`` (keys of PARAMETERS) for one column (default broadband).

    Receivers where a value is undefined (a fit failed its checks, see ``params.reasons``)
    are marked with a grey cross, never coloured. ``undefined_areas``: when a list is given,
    one dict per such receiver and map is appended to it, {'box_px': (x0, y0, x1, y1) in the
    saved image's pixels from its top left, 'title': 'T30 undefined at #12: why'}, so that an
    HTML page can show the reason on hover (an image map).

    ``outline``: segments float[n, 2, 2] (see :func:`plan_section`) or None for the grid's
    extent. The colour scale leaves out the receivers whose sphere holds a source (their
    direct sound is seen from within: G and C80 shoot up there); they show at the scale's end.
    """
    plt = pyplot()
    from matplotlib.collections import LineCollection
    from matplotlib.patches import Rectangle

    rcv = params.receivers
    src = field.source_positions_m
    excluded = (np.linalg.norm(params.positions_m[:, None, :] - src[None], axis=2)
                <= field.radius_m).any(axis=1)
    span = np.ptp(params.positions_m[:, :2], axis=0) + (field.grid_spacing_m or 1.0)
    ncols = 2 if len(names) > 1 else 1
    nrows = int(np.ceil(len(names) / ncols))
    aspect = span[1] / max(span[0], 1e-9)
    fig, axes = plt.subplots(nrows, ncols, squeeze=False,
                             figsize=(6.2 * ncols, (max(2.2, 5.2 * aspect) + 0.9) * nrows + 0.8))
    column_label = params.columns[column]
    for ax, name in zip(axes.flat, names):
        label, unit, scale, _ = PARAMETERS[name]
        v = params.values[name][:, column] * scale
        vmin, vmax = _limits(v, excluded)
        extend = ("both" if v[excluded].size and np.nanmin(v[excluded], initial=np.inf) < vmin
                  and np.nanmax(v[excluded], initial=-np.inf) > vmax else
                  "max" if np.any(v[excluded] > vmax) else
                  "min" if np.any(v[excluded] < vmin) else "neither")
        cmap = _CMAPS.get(name, "viridis")
        if field.grid_index is not None and field.grid_spacing_m:
            img, extent = grid_image(field, rcv, v)
            im = ax.imshow(img, origin="lower", extent=extent, cmap=cmap, vmin=vmin, vmax=vmax,
                           interpolation="nearest")
            if outline is not None and len(outline):  # cells end at the walls
                xy = outline.reshape(-1, 2)
                lo, hi = xy.min(axis=0), xy.max(axis=0)
                im.set_clip_path(Rectangle(lo, *(hi - lo), transform=ax.transData))
        else:
            im = ax.scatter(params.positions_m[:, 0], params.positions_m[:, 1], c=v, cmap=cmap,
                            vmin=vmin, vmax=vmax, s=80, edgecolors="none")
        if outline is not None and len(outline):
            ax.add_collection(LineCollection(outline, colors="black", linewidths=1.5))
        ax.plot(src[:, 0], src[:, 1], marker="*", ls="none", ms=15, mfc="white", mec="black",
                label="source")
        if mark_m is not None:
            ax.plot(*mark_m, marker="o", ls="none", ms=9, mfc="none", mec="red", mew=1.5,
                    label="shown cell")
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(f"{label} ({column_label})" + (f", {unit}" if unit else ""), fontsize=10)
        fig.colorbar(im, ax=ax, shrink=0.85, extend=extend)
        undefined = ~np.isfinite(v)
        if undefined.any():
            ax.plot(params.positions_m[undefined, 0], params.positions_m[undefined, 1],
                    marker="x", ls="none", ms=7, mec="0.45", mew=1.5, label="undefined")
        if outline is not None and len(outline):
            xy = outline.reshape(-1, 2)
            pad = 0.03 * np.ptp(xy, axis=0).max()
            ax.set_xlim(xy[:, 0].min() - pad, xy[:, 0].max() + pad)
            ax.set_ylim(xy[:, 1].min() - pad, xy[:, 1].max() + pad)
    for ax in axes.flat[len(names):]:
        ax.set_visible(False)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=8, frameon=False)
    fig.suptitle(f"{field.scene_name}: parameters over the floor plan at "
                 f"{np.mean(params.positions_m[:, 2]):.2g} m (seen from above)")
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    path = Path(path)
    fig.set_dpi(100)
    if undefined_areas is not None:
        fig.canvas.draw()
        undefined_areas += _undefined_areas(fig, axes.flat, names, params, column, field)
    write_atomically(path, lambda tmp: fig.savefig(tmp, dpi=100, format="png"))
    plt.close(fig)
    return path
