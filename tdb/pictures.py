"""PNG pictures: the category atlas and category-coloured hillshades."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tdb.categories import NO_DATA, PEAK, PIT, RIDGE, STEP_DOWN, STEP_UP, VALLEY, all_categories, templates
from tdb.raster import Raster

# Colour per feature sub-indicator (RGB 0..1): planes grey, ridges red, valleys blue, …
FEATURE_COLOURS = {
    0: (0.85, 0.85, 0.85),
    RIDGE: (0.85, 0.2, 0.15),
    VALLEY: (0.15, 0.35, 0.85),
    STEP_UP: (0.1, 0.7, 0.7),
    STEP_DOWN: (0.95, 0.6, 0.1),
    PEAK: (0.6, 0.2, 0.6),
    PIT: (0.1, 0.55, 0.2),
}


def category_colours() -> NDArray[np.float64]:
    """(256, 3) colour of each code; flat is white, no data black."""
    out = np.zeros((256, 3))
    for c in all_categories():
        out[c.code] = FEATURE_COLOURS[c.feature]
    out[0] = (1.0, 1.0, 1.0)
    out[NO_DATA] = (0.0, 0.0, 0.0)
    return out


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def category_atlas(path: str | os.PathLike[str], *, n: int = 5) -> None:
    """All 115 canonical templates: height from dark (0) to light (1), north up, the nodes a
    tile keeps for its feature marked red, the code and description under each."""
    plt = _pyplot()
    from tdb.categories import feature_nodes, subgrid_uv

    t = templates(n)
    marks = feature_nodes(n)
    uv = subgrid_uv(n)
    fig, axes = plt.subplots(10, 12, figsize=(18, 17))
    for ax in axes.ravel():
        ax.axis("off")
    for cat, ax in zip(all_categories(), axes.ravel()):
        z = t[cat.code].reshape(n, n)
        ax.imshow(_upsample(z, 8), cmap="gist_earth", origin="lower", extent=(0, 1, 0, 1), vmin=0, vmax=1.15)
        ax.contour(
            np.linspace(0, 1, n), np.linspace(0, 1, n), z, levels=[0.25, 0.5, 0.75], colors="k", linewidths=0.4
        )
        keep = marks[cat.code]
        ax.plot(uv[keep, 0], uv[keep, 1], "o", color="red", ms=3)
        ax.set_title(f"{cat.code}: {cat.description}", fontsize=5.5, wrap=True)
    fig.suptitle(
        "tdb: the 115 tile categories (north up, dark low to light high; red: feature nodes kept)", fontsize=13
    )
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _upsample(z: NDArray[np.float64], k: int) -> NDArray[np.float64]:
    from scipy import ndimage

    return ndimage.zoom(z, k, order=1)


def _hillshade(ax: Any, surface: Raster) -> None:
    from matplotlib.colors import LightSource

    z = surface.data
    fill = np.where(np.isnan(z), np.nanmin(z) if np.isfinite(z).any() else 0.0, z)
    shade = LightSource(azdeg=315, altdeg=45).hillshade(fill, vert_exag=2, dx=surface.cell, dy=surface.cell)
    x0, y0, x1, y1 = surface.bounds
    ax.imshow(np.where(np.isnan(z), np.nan, shade), cmap="gray", extent=(x0, x1, y0, y1))
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)


# Line colour of each built-in filter's matches on a feature map
KIND_COLOURS = {
    "ditch": (0.1, 0.35, 0.9),
    "ridge": (0.85, 0.15, 0.1),
    "wall": (0.95, 0.55, 0.0),
    "embankment": (0.55, 0.2, 0.7),
    "pit": (0.0, 0.6, 0.8),
    "mound": (0.8, 0.1, 0.5),
}


def feature_map(
    path: str | os.PathLike[str], features: list[dict[str, Any]], surface: Raster, *, title: str
) -> None:
    """Query results drawn over the hillshade of ``surface``: lines along their centre lines,
    polygons outlined, coloured by kind (tiles by their category's feature)."""
    plt = _pyplot()
    import shapely

    x0, y0, x1, y1 = surface.bounds
    fig, ax = plt.subplots(figsize=(9, 9 * (y1 - y0) / max(x1 - x0, 1e-9) + 0.5))
    _hillshade(ax, surface)
    colours = category_colours()
    for f in features:
        geom = shapely.geometry.shape(f["geometry"])
        props = f["properties"]
        colour = colours[props["category"]] if "category" in props else KIND_COLOURS.get(props.get("kind"), "k")
        for part in getattr(geom, "geoms", [geom]):
            if part.is_empty:
                continue
            if isinstance(part, shapely.Polygon):
                px, py = part.exterior.xy
                ax.fill(px, py, color=colour, alpha=0.35, lw=0.8, ec=colour)
            else:
                px, py = part.xy
                ax.plot(px, py, color=colour, lw=1.6)
    kinds = sorted({str(f["properties"].get("kind", "tiles")) for f in features})
    ax.set_title(f"{title}: {len(features)} result(s){' (' + ', '.join(kinds) + ')' if kinds else ''}")
    fig.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(fig)


def area_picture(path: str | os.PathLike[str], area: Any, surface: Raster) -> None:
    """Hillshade of the rebuilt surface with the tiles' category colours laid over it."""
    plt = _pyplot()
    x0, y0, x1, y1 = surface.bounds
    fig, ax = plt.subplots(figsize=(9, 9 * (y1 - y0) / max(x1 - x0, 1e-9) + 0.5))
    _hillshade(ax, surface)
    colours = category_colours()
    tiles = np.zeros((len(area.code), 4))
    tiles[:, :3] = colours[area.code]
    tiles[:, 3] = np.where(area.code == 0, 0.0, 0.45)
    for (xg, yg), rgba in zip(zip(area.xg, area.yg), tiles):
        if rgba[3] > 0:
            ax.add_patch(plt.Rectangle((xg, yg), area.level, area.level, color=rgba, lw=0))
    ax.set_title(f"{area.version}: {area.level} m tiles (red ridge, blue valley, teal/orange steps)")
    fig.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(fig)


def change_map(
    path: str | os.PathLike[str],
    features: list[dict[str, Any]],
    *,
    title: str,
    dod: Raster | None = None,
    lod: float | None = None,
) -> None:
    """Changed regions labelled with their kind: filled by the sign of their height change, or
    outlined over the DEM of difference ``dod`` where one is given (shades within ``lod`` are white)."""
    plt = _pyplot()
    import shapely

    fig, ax = plt.subplots(figsize=(9, 9))
    if dod is not None and np.isfinite(dod.data).any():
        from matplotlib.colors import TwoSlopeNorm

        finite = np.abs(dod.data[np.isfinite(dod.data)])
        reach = max(float(np.percentile(finite, 99.5)), 3 * (lod or 0.1), 1e-3)
        shown = np.where(np.abs(dod.data) < (lod or 0.0), 0.0, dod.data)
        x0, y0, x1, y1 = dod.bounds
        img = ax.imshow(shown, cmap="RdBu", norm=TwoSlopeNorm(0.0, -reach, reach), extent=(x0, x1, y0, y1))
        fig.colorbar(img, ax=ax, shrink=0.7, label="height change (m)")
    for f in features:
        geom = shapely.geometry.shape(f["geometry"])
        colour = (0.8, 0.2, 0.1) if f["properties"]["dz"] < 0 else (0.1, 0.35, 0.8)
        for poly in getattr(geom, "geoms", [geom]):
            x, y = poly.exterior.xy
            if dod is None:
                ax.fill(x, y, color=colour, alpha=0.6, lw=0)
            else:
                ax.plot(x, y, color="black", lw=0.6)
        c = geom.representative_point()
        ax.annotate(f["properties"]["kind"], (c.x, c.y), fontsize=6)
    ax.set_aspect("equal")
    ax.set_title(f"{title} (red lowered, blue raised)")
    fig.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(fig)
