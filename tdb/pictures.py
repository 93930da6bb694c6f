"""PNG pictures: the category atlas, and maps of areas, query results and changes.

Every map carries what a surveyor checks before trusting it: full coordinates on both axes,
a scale bar, a north arrow (grid north of the map's CRS), the CRS by name, and a legend for
every colour used. Figures are built without pyplot, so drawing one never changes the
caller's matplotlib backend or state.
"""

from __future__ import annotations

import io
import os
import textwrap
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tdb.atomic import PNG, check_destination, write_bytes
from tdb.categories import NO_DATA, PEAK, PIT, RIDGE, STEP_DOWN, STEP_UP, VALLEY, all_categories, templates
from tdb.raster import Raster
from tdb.tiles import SUBGRID

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
FEATURE_LABELS = {
    0: "plane",
    RIDGE: "ridge",
    VALLEY: "valley",
    STEP_UP: "flat below a rising plane",
    STEP_DOWN: "flat above a falling plane",
    PEAK: "peak",
    PIT: "pit",
}

# Line colour of each built-in filter's matches on a feature map
KIND_COLOURS = {
    "ditch": (0.1, 0.35, 0.9),
    "ridge": (0.85, 0.15, 0.1),
    "wall": (0.95, 0.55, 0.0),
    "embankment": (0.55, 0.2, 0.7),
    "pit": (0.0, 0.6, 0.8),
    "mound": (0.8, 0.1, 0.5),
    "tree": (0.05, 0.45, 0.1),
    "tree new": (0.05, 0.45, 0.1),
    "tree felled": (0.55, 0.35, 0.1),
    "building": (0.75, 0.1, 0.1),
    "building added": (0.75, 0.1, 0.1),
    "building removed": (0.4, 0.4, 0.4),
}
LOWERED, RAISED = (0.8, 0.2, 0.1), (0.1, 0.35, 0.8)
HELD_BACK = (0.45, 0.45, 0.45)  # regions that moved but are not claimed


def category_colours() -> NDArray[np.float64]:
    """(256, 3) colour of each code; flat is white, no data black."""
    out = np.zeros((256, 3))
    for c in all_categories():
        out[c.code] = FEATURE_COLOURS[c.feature]
    out[0] = (1.0, 1.0, 1.0)
    out[NO_DATA] = (0.0, 0.0, 0.0)
    return out


def _figure(width: float, height: float) -> Any:
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height))


def _save(fig: Any, path: str | os.PathLike[str], **kwargs: Any) -> None:
    check_destination(path, PNG, what="a PNG picture")
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", **kwargs)
    write_bytes(path, buffer.getvalue())


def category_atlas(path: str | os.PathLike[str], *, n: int = SUBGRID) -> None:
    """All 115 canonical templates: height from dark (0) to light (1), north up, the nodes a
    tile keeps for its feature marked red, the code and description under each."""
    from tdb.categories import feature_nodes, subgrid_uv

    t = templates(n)
    marks = feature_nodes(n)
    uv = subgrid_uv(n)
    fig = _figure(18, 19)
    axes = fig.subplots(10, 12)
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
        # wrapped by hand: a title wider than its panel runs over its neighbours'
        ax.set_title(textwrap.fill(f"{cat.code}: {cat.description}", 30), fontsize=5.5)
    fig.suptitle(
        "tdb: the 115 tile categories (north up, dark low to light high; red: feature nodes kept)", fontsize=13
    )
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    _save(fig, path, dpi=100)


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


def nice_length(span: float) -> float:
    """A round length (1, 2 or 5 × 10^k m) of about a fifth of ``span``, for a scale bar."""
    target = max(span / 5, 1e-9)
    power = 10.0 ** np.floor(np.log10(target))
    return float(max(m * power for m in (1, 2, 5) if m * power <= target * 1.5))


def _map_frame(ax: Any, crs: Any, bounds: tuple[float, float, float, float]) -> None:
    """Full coordinates on the axes, a scale bar, a north arrow and the CRS's name."""
    from matplotlib.patches import Rectangle
    from matplotlib.ticker import FuncFormatter

    x0, y0, x1, y1 = bounds
    ax.set_aspect("equal")
    plain = FuncFormatter(lambda v, _pos: f"{v:,.0f}")
    ax.xaxis.set_major_formatter(plain)
    ax.yaxis.set_major_formatter(plain)
    ax.tick_params(labelsize=7)
    for label in ax.get_yticklabels():
        label.set_rotation(90)
        label.set_va("center")
    unit = "m"
    ax.set_xlabel(f"easting ({unit})", fontsize=8)
    ax.set_ylabel(f"northing ({unit})", fontsize=8)
    name = getattr(crs, "name", None) or "no coordinate system declared"
    epsg = crs.to_epsg() if crs is not None else None
    ax.text(
        0.01,
        0.01,
        f"CRS: {name}{f' (EPSG:{epsg})' if epsg else ''}",
        transform=ax.transAxes,
        fontsize=7,
        va="bottom",
        bbox={"facecolor": "white", "alpha": 0.8, "lw": 0},
    )
    width, height = x1 - x0, y1 - y0
    length = nice_length(width)
    bx, by = x0 + 0.05 * width, y0 + 0.07 * height
    bar_h = 0.012 * height
    for k in range(2):  # two halves, black and white, as on printed maps
        ax.add_patch(
            Rectangle(
                (bx + k * length / 2, by),
                length / 2,
                bar_h,
                facecolor="k" if k == 0 else "w",
                edgecolor="k",
                lw=0.8,
            )
        )
    label = f"{length:g} m" if length < 1000 else f"{length / 1000:g} km"
    ax.text(
        bx + length / 2,
        by + 1.8 * bar_h,
        label,
        ha="center",
        fontsize=8,
        bbox={"facecolor": "white", "alpha": 0.8, "lw": 0},
    )
    ax.annotate(
        "N",
        xy=(0.95, 0.95),
        xytext=(0.95, 0.83),
        xycoords="axes fraction",
        ha="center",
        va="center",
        fontsize=11,
        fontweight="bold",
        arrowprops={"facecolor": "k", "width": 4, "headwidth": 11, "headlength": 10},
        bbox={"boxstyle": "circle", "facecolor": "white", "alpha": 0.8, "lw": 0},
    )
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)


def _legend(ax: Any, entries: list[tuple[str, Any, str]], *, title: str) -> None:
    """A legend of (label, colour, 'line' | 'dashed' | 'patch') entries, outside the map on the right."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = [
        Line2D([0], [0], color=colour, lw=2, ls="--" if kind == "dashed" else "-")
        if kind in ("line", "dashed")
        else Patch(facecolor=colour, edgecolor="0.3", lw=0.5)
        for _label, colour, kind in entries
    ]
    ax.legend(
        handles,
        [label for label, _c, _k in entries],
        title=title,
        loc="upper left",
        bbox_to_anchor=(1.02, 1.0),
        fontsize=8,
        title_fontsize=8,
        frameon=False,
    )


def _map_size(bounds: tuple[float, float, float, float]) -> tuple[float, float]:
    x0, y0, x1, y1 = bounds
    return 11.0, 8.5 * (y1 - y0) / max(x1 - x0, 1e-9) + 1.0


def feature_map(
    path: str | os.PathLike[str], features: list[dict[str, Any]], surface: Raster, *, title: str
) -> None:
    """Query results drawn over the hillshade of ``surface``: lines along their centre lines,
    polygons outlined, coloured by kind (tiles by their category's feature)."""
    import shapely

    fig = _figure(*_map_size(surface.bounds))
    ax = fig.add_subplot()
    _hillshade(ax, surface)
    colours = category_colours()
    used: dict[str, tuple[Any, str]] = {}
    for f in features:
        geom = shapely.geometry.shape(f["geometry"])
        props = f["properties"]
        if "category" in props:
            code = int(props["category"])
            colour = colours[code]
            label = (
                "no data"
                if code == NO_DATA
                else "flat"
                if code == 0
                else FEATURE_LABELS[all_categories()[code].feature]
            )
        else:
            kind = str(props.get("kind", "result"))
            colour, label = KIND_COLOURS.get(kind, (0.0, 0.0, 0.0)), kind
        for part in getattr(geom, "geoms", [geom]):
            if part.is_empty:
                continue
            if isinstance(part, shapely.Polygon):
                px, py = part.exterior.xy
                ax.fill(px, py, color=colour, alpha=0.35, lw=0.8, ec=colour)
                used.setdefault(label, (colour, "patch"))
            else:
                px, py = part.xy
                ax.plot(px, py, color=colour, lw=1.6)
                used.setdefault(label, (colour, "line"))
    _map_frame(ax, surface.crs, surface.bounds)
    if used:
        _legend(ax, [(k, c, kind) for k, (c, kind) in sorted(used.items())], title="results")
    ax.set_title(f"{title}: {len(features)} result(s) over the hillshade of the rebuilt surface", fontsize=10)
    _save(fig, path, dpi=100, bbox_inches="tight")


def area_picture(path: str | os.PathLike[str], area: Any, surface: Raster) -> None:
    """Hillshade of the rebuilt surface with the tiles' category colours laid over it."""
    from matplotlib.patches import Rectangle

    fig = _figure(*_map_size(surface.bounds))
    ax = fig.add_subplot()
    _hillshade(ax, surface)
    colours = category_colours()
    cats = all_categories()
    tiles = np.zeros((len(area.code), 4))
    tiles[:, :3] = colours[area.code]
    tiles[:, 3] = np.where(area.code == 0, 0.0, 0.45)
    for (xg, yg), rgba in zip(zip(area.xg, area.yg), tiles):
        if rgba[3] > 0:
            ax.add_patch(Rectangle((xg, yg), area.level, area.level, color=rgba, lw=0))
    present = {int(c) for c in np.unique(area.code)}
    features = {cats[c].feature for c in present if c != NO_DATA and c != 0}
    entries: list[tuple[str, tuple[float, ...], str]] = (
        [("flat (no colour)", (1.0, 1.0, 1.0), "patch")] if 0 in present else []
    )
    entries += [(FEATURE_LABELS[f], (*FEATURE_COLOURS[f], 0.45), "patch") for f in sorted(features)]
    if NO_DATA in present:
        entries.append(("no data", (0.0, 0.0, 0.0, 0.45), "patch"))
    entries += _draw_objects(ax, getattr(area, "trees", []), getattr(area, "buildings", []))
    _map_frame(ax, surface.crs, surface.bounds)
    _legend(ax, entries, title=f"{area.level} m tile category")
    ax.set_title(f"version {area.version}: {area.level} m tile categories over the rebuilt surface", fontsize=10)
    _save(fig, path, dpi=100, bbox_inches="tight")


TREE_COLOUR, BUILDING_COLOUR = KIND_COLOURS["tree"], KIND_COLOURS["building"]


def _draw_objects(ax: Any, trees: list[Any], buildings: list[Any]) -> list[tuple[str, Any, str]]:
    """Crowns outlined in green with their tops, footprints outlined in red; their legend entries."""
    entries: list[tuple[str, Any, str]] = []
    for what, colour, shapes in (
        ("tree crowns", TREE_COLOUR, [t.crown for t in trees]),
        ("buildings", BUILDING_COLOUR, [b.footprint for b in buildings]),
    ):
        for shape in shapes:
            for part in getattr(shape, "geoms", [shape]):
                px, py = part.exterior.xy
                ax.plot(px, py, color=colour, lw=0.7)
        if shapes:
            entries.append((f"{what} ({len(shapes)})", colour, "line"))
    if trees:
        ax.plot([t.x for t in trees], [t.y for t in trees], "+", color=TREE_COLOUR, ms=3, mew=0.6)
    return entries


def change_map(  # noqa: PLR0913 (the picture, its regions, and what goes under and beside them)
    path: str | os.PathLike[str],
    features: list[dict[str, Any]],
    *,
    title: str,
    dod: Raster | None = None,
    lod: float | None = None,
    crs: Any = None,
    bounds: tuple[float, float, float, float] | None = None,
    held_back: list[Any] | None = None,
) -> None:
    """Changed regions labelled with their kind: filled by the sign of their height change, or
    outlined over the DEM of difference ``dod`` where one is given (shades within ``lod`` are white).
    ``crs`` names the coordinates where there is no ``dod``; ``bounds`` default to the DEM's or the
    regions' own. A second line of ``title`` (the co-registration) goes under the count.
    ``held_back``: outlines (shapely) of regions that moved but are not claimed, dashed grey."""
    import shapely
    from matplotlib.colors import TwoSlopeNorm

    geoms = [shapely.geometry.shape(f["geometry"]) for f in features]
    box = bounds or (dod.bounds if dod is not None else _grown(shapely.total_bounds(geoms) if geoms else None))
    fig = _figure(*_map_size(box))
    ax = fig.add_subplot()
    if dod is not None and np.isfinite(dod.data).any():
        finite = np.abs(dod.data[np.isfinite(dod.data)])
        reach = max(float(np.percentile(finite, 99.5)), 3 * (lod or 0.1), 1e-3)
        shown = np.where(np.abs(dod.data) < (lod or 0.0), 0.0, dod.data)
        x0, y0, x1, y1 = dod.bounds
        img = ax.imshow(shown, cmap="RdBu", norm=TwoSlopeNorm(0.0, -reach, reach), extent=(x0, x1, y0, y1))
        bar = fig.colorbar(img, ax=ax, shrink=0.6, pad=0.08, location="bottom", aspect=40)
        bar.set_label(f"height change, after − before (m); white within ±{lod or 0:.2f} m", fontsize=8)
    for f, geom in zip(features, geoms):
        colour = LOWERED if f["properties"]["dz"] < 0 else RAISED
        for poly in getattr(geom, "geoms", [geom]):
            x, y = poly.exterior.xy
            if dod is None:
                ax.fill(x, y, color=colour, alpha=0.6, lw=0)
            else:
                ax.plot(x, y, color="black", lw=0.6)
        c = geom.representative_point()
        ax.annotate(
            f["properties"]["kind"],
            (c.x, c.y),
            fontsize=7,
            bbox={"facecolor": "white", "alpha": 0.6, "lw": 0, "pad": 1},
        )
    for geom in held_back or []:
        for poly in getattr(geom, "geoms", [geom]):
            ax.plot(*poly.exterior.xy, color=HELD_BACK, lw=0.8, ls="--")
    _map_frame(ax, dod.crs if dod is not None and dod.crs is not None else crs, box)
    entries: list[tuple[str, tuple[float, ...], str]] = (
        [("lowered", (*LOWERED, 0.6), "patch"), ("raised", (*RAISED, 0.6), "patch")]
        if dod is None
        else [("changed region (labelled by kind)", (0.0, 0.0, 0.0), "line")]
    )
    if held_back:
        entries.append(("moved, not claimed (the ground evidence\ndoes not support it)", HELD_BACK, "dashed"))
    _legend(ax, entries, title="changes")
    head, _, below = title.partition("\n")
    head = f"{head}: {len(features)} changed region(s)"
    ax.set_title(f"{head}\n{below}" if below else head, fontsize=9 if below else 10)
    _save(fig, path, dpi=100, bbox_inches="tight")


def _grown(bounds: Any) -> tuple[float, float, float, float]:
    if bounds is None or not np.isfinite(bounds).all():
        return (0.0, 0.0, 1.0, 1.0)
    x0, y0, x1, y1 = (float(v) for v in bounds)
    pad = 0.05 * max(x1 - x0, y1 - y0, 10.0)
    return (x0 - pad, y0 - pad, x1 + pad, y1 + pad)


def agreement_map(  # noqa: PLR0913 (the tiles, where they differ, and the frame)
    path: str | os.PathLike[str],
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    same: NDArray[np.bool_],
    *,
    level: int,
    edges: tuple[NDArray[np.float64], NDArray[np.float64]],
    crs: Any,
    title: str,
) -> None:
    """Tiles of ``level`` (corners ``xg``, ``yg``) that two models agree on (grey) and differ on
    (red), with lines at ``edges`` (x positions, y positions: where the models were cut), so that
    a seam along a cut shows."""
    from matplotlib.colors import ListedColormap

    x0, y0 = int(xg.min()), int(yg.min())
    x1, y1 = int(xg.max()) + level, int(yg.max()) + level
    raster = np.zeros(((y1 - y0) // level, (x1 - x0) // level), np.uint8)
    raster[(yg - y0) // level, (xg - x0) // level] = np.where(same, 1, 2)
    bounds = (float(x0), float(y0), float(x1), float(y1))
    fig = _figure(*_map_size(bounds))
    ax = fig.add_subplot()
    colours = ListedColormap([(1, 1, 1), (0.78, 0.78, 0.78), (0.85, 0.1, 0.1)])
    ax.imshow(
        raster, origin="lower", extent=(x0, x1, y0, y1), cmap=colours, vmin=0, vmax=2, interpolation="nearest"
    )
    # a differing tile is a pixel or two at this scale: ringed so that none is lost
    dx, dy = xg[~same] + level / 2, yg[~same] + level / 2
    ax.scatter(dx, dy, s=14, facecolors="none", edgecolors=(0.85, 0.1, 0.1), lw=0.6)
    for x in edges[0]:
        ax.axvline(x, color=(0.1, 0.3, 0.8), lw=0.8, ls="--")
    for y in edges[1]:
        ax.axhline(y, color=(0.1, 0.3, 0.8), lw=0.8, ls="--")
    _map_frame(ax, crs, bounds)
    _legend(
        ax,
        [
            (f"same category ({int(same.sum()):,})", (0.78, 0.78, 0.78), "patch"),
            (f"different ({int((~same).sum()):,})", (0.85, 0.1, 0.1), "patch"),
            ("block edges", (0.1, 0.3, 0.8), "line"),
        ],
        title=f"{level} m tiles",
    )
    ax.set_title(title, fontsize=10)
    _save(fig, path, dpi=100, bbox_inches="tight")


def ground_change_map(
    path: str | os.PathLike[str],
    xy: NDArray[np.float64],
    before: NDArray[np.bool_],
    after: NDArray[np.bool_],
    *,
    crs: Any,
    title: str,
    names: tuple[str, str] = ("before", "after"),
) -> None:
    """Points that two ground labellings ``before`` and ``after`` agree are ground (grey), and
    those only one of them calls ground (red: only ``before``; blue: only ``after``)."""
    bounds = _grown((*xy.min(axis=0), *xy.max(axis=0)))
    fig = _figure(*_map_size(bounds))
    ax = fig.add_subplot()
    kinds = [
        (before & after, (0.75, 0.75, 0.75), 0.4, f"ground in both ({int((before & after).sum()):,})"),
        (before & ~after, (0.85, 0.1, 0.1), 1.5, f"ground {names[0]} only ({int((before & ~after).sum()):,})"),
        (after & ~before, (0.1, 0.3, 0.8), 1.5, f"ground {names[1]} only ({int((after & ~before).sum()):,})"),
    ]
    for mask, colour, size, _label in kinds:
        ax.scatter(xy[mask, 0], xy[mask, 1], s=size, color=colour, lw=0, rasterized=True)
    _map_frame(ax, crs, bounds)
    _legend(ax, [(label, colour, "patch") for _m, colour, _s, label in kinds], title="ground points")
    ax.set_title(title, fontsize=10)
    _save(fig, path, dpi=100, bbox_inches="tight")
