"""The joint map as a picture: light and sound side by side over one floor plan, each on its
own grid (the work plane's cells for light, the receivers for sound), the cells that fail a
criterion crossed in red, and a last panel with each cell's verdict."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sonolux.analysis.joint import LIGHT_VALUES, SOUND_VALUES, JointMap
from sonolux.plotting import pyplot
from sonolux.plotting.maps import cells_image

#: What is drawn, in order, when the map has it.
PANELS = ("illuminance_lx", "daylight_factor_percent", "sti", "c50_db", "g_db", "t30_s")
_CMAPS = {"illuminance_lx": "inferno", "daylight_factor_percent": "inferno", "sti": "RdYlGn",
          "c50_db": "magma", "g_db": "plasma", "t30_s": "viridis"}


def plot_joint_map(joint: JointMap, path: str | Path, outline=None) -> Path:
    """Writes the joint map's picture (PNG) to ``path``; ``outline``: plan segments
    float[n, 2, 2] (see :func:`sonolux.plotting.maps.plan_section`) or None."""
    plt = pyplot()
    from matplotlib.collections import LineCollection

    names = [n for n in PANELS if n in joint.values]
    panels = names + (["verdict"] if joint.criteria else [])
    ncols = min(3, len(panels))
    nrows = int(np.ceil(len(panels) / ncols))
    xy = joint.positions_m[:, :2]
    span = np.ptp(xy, axis=0) + 1.0
    aspect = span[1] / max(span[0], 1e-9)
    fig, axes = plt.subplots(nrows, ncols, squeeze=False,
                             figsize=(5.2 * ncols, (max(2.2, 4.4 * aspect) + 1.0) * nrows + 0.6))
    spacing = joint.spacing_m if joint.spacing_m and np.isfinite(joint.spacing_m) else None
    wp = joint.workplane
    for ax, name in zip(axes.flat, panels):
        if name == "verdict":
            v = np.where(joint.failing, 0.0, 1.0)
            undefined = np.all([joint.verdicts[str(c)] == -1 for c in joint.criteria], axis=0)
            v[undefined & ~joint.failing] = np.nan
            _draw(ax, joint.positions_m, joint.grid_index, spacing, v, "RdYlGn", 0.0, 1.0)
            ax.set_title("criteria: " + ", ".join(str(c) for c in joint.criteria)
                         + "\ngreen pass all, red fail one, blank undefined", fontsize=9)
        else:
            label, unit = {**SOUND_VALUES, **LIGHT_VALUES}[name]
            on_plane = name in LIGHT_VALUES and wp is not None
            if on_plane:  # light on its own grid, at the work plane's height
                pos, gi, s = wp.positions_m, wp.grid_index, wp.spacing_m
                v = np.asarray(getattr(wp, name), float)
            else:
                pos, gi, s, v = joint.positions_m, joint.grid_index, spacing, joint.values[name]
            im = _draw(ax, pos, gi, s, v, _CMAPS.get(name, "viridis"))
            fig.colorbar(im, ax=ax, shrink=0.85)
            ax.set_title(f"{label}" + (f" ({unit})" if unit else "")
                         + (f", work plane {wp.height_m:g} m" if on_plane else ""), fontsize=10)
            for c in joint.criteria:
                if c.name == name:
                    bad = joint.verdicts[str(c)] == 0
                    ax.plot(xy[bad, 0], xy[bad, 1], "x", color="red", ms=6, mew=1.5,
                            label=f"fails {c}")
                    ax.legend(loc="upper right", fontsize=7, framealpha=0.8)
        if outline is not None and len(outline):
            ax.add_collection(LineCollection(outline, colors="black", linewidths=1.2))
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    fig.suptitle(f"{joint.scene_name}: light and sound over one floor plan (seen from above)")
    fig.tight_layout()
    path = Path(path)
    tmp = path.with_name(f".{path.name}.part.png")
    fig.savefig(tmp, dpi=100)
    plt.close(fig)
    tmp.replace(path)
    return path


def _draw(ax, positions_m, grid_index, spacing_m, values, cmap, vmin=None, vmax=None):
    finite = values[np.isfinite(values)]
    if vmin is None and finite.size:
        vmin, vmax = float(finite.min()), float(finite.max())
        if vmax <= vmin:
            vmin, vmax = vmin - 0.5, vmax + 0.5
    if grid_index is not None and spacing_m:
        img, extent = cells_image(positions_m, grid_index, spacing_m, values)
        return ax.imshow(img, origin="lower", extent=extent, cmap=cmap, vmin=vmin, vmax=vmax,
                         interpolation="nearest")
    return ax.scatter(positions_m[:, 0], positions_m[:, 1], c=values, cmap=cmap, vmin=vmin,
                      vmax=vmax, s=80, edgecolors="none")
