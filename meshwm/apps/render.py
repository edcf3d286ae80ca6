"""Shaded pictures of meshes, and heat maps of the distance between two meshes (issue #4).

Everything is drawn with matplotlib's Agg backend on a private :class:`~matplotlib.figure.Figure`
(no pyplot, no global state, no display needed).  The projection is done here: each view is an
orthographic projection of the mesh, its triangles flat-shaded (Lambertian, one light fixed
relative to the viewer, two-sided) and painted back to front, sorted by mean depth (the
painter's algorithm), in one call to the renderer's Gouraud-triangle primitive with one colour
per triangle: about 0.2 s per view of a 130k-face mesh, where ``mplot3d`` or a
:class:`~matplotlib.collections.PolyCollection` take seconds.  docs/render.md describes the
pictures and the measured speed.

Conventions: +Y is up unless ``up`` says otherwise; view ``k`` of ``views`` looks from azimuth
``150° + 360° k / views`` around the up axis (0° looks from +Z towards -Z, 90° from +X) and
20° above the horizon.  Coordinates are first normalised to the bounding box of the vertices
the faces use (centred, divided by its diagonal), so a translated or uniformly scaled copy of
a mesh gives the same picture, and each view is framed to the projected extent of the mesh.
"""

from __future__ import annotations

import io
import math

import igl
import numpy as np
from matplotlib import colormaps
from matplotlib.artist import Artist
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Colormap, Normalize
from matplotlib.figure import Figure
from matplotlib.transforms import IdentityTransform
from numpy.typing import ArrayLike, NDArray

from meshwm._validate import check_mesh
from meshwm.metrics import bounding_box_diagonal

__all__ = [
    "ELEVATION",
    "SIZE_RANGE",
    "VIEWS_RANGE",
    "distance_to_surface",
    "render_comparison",
    "render_views",
    "view_azimuths",
]

#: Allowed number of views in one picture (a row of that many panels).
VIEWS_RANGE = (1, 12)
#: Allowed picture width in pixels.
SIZE_RANGE = (100, 4000)
#: Elevation of every view above the horizon, in degrees.
ELEVATION = 20.0

_FIRST_AZIMUTH = 150.0
_DPI = 100.0
_MARGIN = 0.03  # empty border around the mesh, fraction of each panel
_AMBIENT = 0.22  # share of the light that does not depend on the face orientation
_BASE_RGB = np.array([0.74, 0.78, 0.86])  # plain-mesh colour under full light
_SHADE_FLOOR = 0.45  # with values: the darkest a face gets, so colours stay readable
_LIGHT = np.array([-0.4, 0.6, 1.0]) / np.linalg.norm([-0.4, 0.6, 1.0])  # camera frame
_UP_AXES = {"x": 0, "y": 1, "z": 2}


def _check_int(value: object, name: str, bounds: tuple[int, int]) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    low, high = bounds
    if not low <= int(value) <= high:
        raise ValueError(f"{name} must lie in {low}..{high}, got {int(value)}")
    return int(value)


def view_azimuths(views: int) -> list[float]:
    """Azimuths in degrees of the ``views`` views of a picture.

    Examples
    --------
    >>> view_azimuths(3)
    [150.0, 270.0, 30.0]
    """
    views = _check_int(views, "views", VIEWS_RANGE)
    return [(_FIRST_AZIMUTH + 360.0 * k / views) % 360.0 for k in range(views)]


def _camera(azimuth: float, elevation: float, up: int) -> NDArray[np.float64]:
    """Rows: screen right, screen up, towards the viewer, in world coordinates."""
    a, e = math.radians(azimuth), math.radians(elevation)
    # Built for +Y up, then the axes are permuted cyclically so that ``up`` plays Y's part.
    towards = np.array([math.sin(a) * math.cos(e), math.sin(e), math.cos(a) * math.cos(e)])
    right = np.array([math.cos(a), 0.0, -math.sin(a)])
    frame = np.stack([right, np.cross(towards, right), towards])
    return np.roll(frame, up - 1, axis=1)


def _normalised(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> NDArray[np.float64]:
    used = vertices[np.unique(faces)]
    low, high = used.min(axis=0), used.max(axis=0)
    diagonal = float(np.linalg.norm(high - low))
    if not diagonal > 0:
        raise ValueError("mesh is degenerate: all its faces collapse to one point")
    return (vertices - (low + high) / 2.0) / diagonal


def _layout(size: int, views: int, title: bool, colorbar: bool) -> dict[str, float]:
    """Pixel sizes of the picture's bands (top to bottom: title, view titles, panels, colorbar)."""
    panel = size / views
    font = min(max(min(panel, size / 3.0) * 0.055, 10.0), 40.0)  # base font, px
    out = {
        "panel": panel,
        "font": font,
        "big": 1.3 * font,  # picture title font, px
        "label": 1.9 * font,  # view titles
        "bar": 5.0 * font if colorbar else 0.0,
    }
    out["top"] = 2.0 * out["big"] if title else 0.4 * font
    out["height"] = float(round(out["top"] + out["label"] + panel + out["bar"]))
    return out


def _fit(text: str, font: float, room: float) -> float:
    """``font`` (px), shrunk so that ``text`` fits in ``room`` px (DejaVu Sans: ≤ 0.62 em/char)."""
    return max(min(font, 0.95 * room / (0.62 * max(len(text), 1))), 5.0)


def _face_values(
    values: ArrayLike | None, faces: NDArray[np.int64], n: int
) -> NDArray[np.float64] | None:
    if values is None:
        return None
    vals = np.asarray(values)
    if vals.ndim != 1 or len(vals) != n:
        raise ValueError(f"values must be one number per vertex, shape ({n},), got {vals.shape}")
    if not np.issubdtype(vals.dtype, np.number) or np.iscomplexobj(vals):
        raise ValueError(f"values must be real numbers, got dtype {vals.dtype}")
    vals = vals.astype(np.float64)
    used = np.unique(faces)
    bad = ~np.isfinite(vals[used])
    if bad.any():
        raise ValueError(f"{int(bad.sum())} values of vertices used by faces are NaN or infinite")
    return vals[faces].mean(axis=1)


def _face_colors(colors: ArrayLike | None, m: int, with_values: bool) -> NDArray | None:
    if colors is None:
        return None
    if with_values:
        raise ValueError("give values or face_colors, not both")
    rgb = np.asarray(colors, dtype=np.float64)
    if rgb.shape != (m, 3) or not np.isfinite(rgb).all() or rgb.min() < 0 or rgb.max() > 1:
        raise ValueError(f"face_colors must be ({m}, 3) numbers in [0, 1], got {rgb.shape}")
    return rgb


class _FlatTriangles(Artist):
    """Triangles in data coordinates, one colour each, painted in the order given.

    Drawn with the renderer's Gouraud-triangle primitive (one call for all of them; every
    corner of a triangle gets the triangle's colour): ten times faster than a
    :class:`~matplotlib.collections.PolyCollection` of 100k+ triangles, and adjacent triangles
    tile without the hairline seams that antialiased polygons leave.
    """

    def __init__(self, triangles: NDArray[np.float64], colours: NDArray[np.float64]) -> None:
        super().__init__()
        self._triangles = triangles  # (m, 3, 2)
        self._colours = colours  # (m, 4)

    def draw(self, renderer) -> None:  # renderer: matplotlib's RendererAgg
        if not self.get_visible():
            return
        gc = renderer.new_gc()
        gc.set_clip_rectangle(self.get_clip_box())
        xy = self.get_transform().transform(self._triangles.reshape(-1, 2))
        corners = np.repeat(self._colours[:, None, :], 3, axis=1)
        renderer.draw_gouraud_triangles(gc, xy.reshape(-1, 3, 2), corners, IdentityTransform())
        gc.restore()
        self.stale = False


def _draw_view(
    ax, v: NDArray[np.float64], faces: NDArray[np.int64], frame, rgb: NDArray[np.float64], shade
) -> None:
    """Project, light and paint one view onto ``ax`` (painter's algorithm)."""
    p = v @ frame.T  # (n, 3): screen x, screen y, depth (larger is nearer)
    tri = p[faces]  # (m, 3, 3)
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normals, axis=1)
    np.divide(normals, length[:, None], out=normals, where=length[:, None] > 0)
    # Two-sided: a face seen from behind is lit as if it faced the viewer.
    lambert = np.abs(normals @ _LIGHT)
    intensity = shade(_AMBIENT + (1.0 - _AMBIENT) * lambert)
    colours = np.empty((len(faces), 4))
    colours[:, :3] = np.clip(rgb * intensity[:, None], 0.0, 1.0)
    colours[:, 3] = 1.0
    order = np.argsort(tri[:, :, 2].mean(axis=1), kind="stable")  # far to near
    ax.add_artist(_FlatTriangles(tri[order, :, :2], colours[order]))
    xy = tri[:, :, :2].reshape(-1, 2)
    low, high = xy.min(axis=0), xy.max(axis=0)
    centre = (low + high) / 2.0
    half = max(float((high - low).max()) / 2.0, 1e-12) / (1.0 - 2.0 * _MARGIN)
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)


def _value_norm(face_values: NDArray, value_range: ArrayLike | None) -> Normalize:
    """The colour scale: ``value_range``, or the values' own range (widened if constant)."""
    if value_range is None:
        lo, hi = float(face_values.min()), float(face_values.max())
    else:
        bounds = np.asarray(value_range, dtype=np.float64)
        if bounds.shape != (2,) or not np.isfinite(bounds).all() or bounds[0] > bounds[1]:
            raise ValueError(
                f"value_range must be two finite numbers, low <= high, got {value_range}"
            )
        lo, hi = float(bounds[0]), float(bounds[1])
    if hi <= lo:  # constant values: any range shows them, one where they sit at the bottom
        hi = lo + (abs(lo) if lo != 0 else 1.0)
    return Normalize(lo, hi, clip=True)


def render_views(
    vertices: ArrayLike,
    faces: ArrayLike,
    *,
    values: ArrayLike | None = None,
    views: int = 3,
    size: int = 900,
    title: str | None = None,
    cmap: str | Colormap = "viridis",
    value_label: str | None = None,
    value_range: tuple[float, float] | None = None,
    up: str = "y",
    face_colors: ArrayLike | None = None,
) -> bytes:
    """Draw a row of shaded views of a triangle mesh and return them as PNG bytes.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
        Vertex positions.
    faces : (m, 3) array_like of int
        Triangles.
    values : (n,) array_like of float, optional
        One number per vertex.  When given, each face is coloured by the mean of its three
        vertices' values through ``cmap`` (darkened by the shading, never below 45 % of the
        colour) and a colorbar is drawn under the views.
    views : int, optional
        Number of views, 1..12 (default 3), side by side; see :func:`view_azimuths`.
    size : int, optional
        Width of the picture in pixels, 100..4000 (default 900).  The width is exact; the
        height follows: ``size / views`` for the square panels plus bands for the titles and
        the colorbar.
    title : str, optional
        Title over the whole picture.
    cmap : str or matplotlib.colors.Colormap, optional
        Colormap for ``values`` (default ``"viridis"``).
    value_label : str, optional
        Label of the colorbar.
    value_range : (float, float), optional
        Values mapped to the two ends of the colormap (default: the smallest and largest face
        value); faces outside are clipped to the ends and the colorbar shows arrows.
    up : {"x", "y", "z"}, optional
        World axis drawn upwards (default ``"y"``).
    face_colors : (m, 3) array_like of float, optional
        One RGB colour in [0, 1] per face (a texture sampled per face,
        :func:`meshwm.apps.texture.texture_colors`), shaded like ``values``; not with
        ``values``.

    Returns
    -------
    bytes
        A PNG image, RGBA, white background.

    Raises
    ------
    ValueError
        Empty or malformed mesh, NaN or infinite coordinates, a mesh collapsed to a point,
        ``values`` of the wrong length or not finite, ``views``/``size`` out of range, a bad
        ``value_range``, ``up`` or ``cmap``.
    TypeError
        ``views`` or ``size`` is not an integer.

    Examples
    --------
    >>> tetra = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    >>> tri = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> png = render_views(tetra, tri, views=1, size=120)
    >>> png[:4]
    b'\\x89PNG'
    >>> int.from_bytes(png[16:20], "big")  # the width, from the PNG header
    120
    """
    v, f = check_mesh(np.asarray(vertices), np.asarray(faces))
    views = _check_int(views, "views", VIEWS_RANGE)
    size = _check_int(size, "size", SIZE_RANGE)
    if up not in _UP_AXES:
        raise ValueError(f"up must be one of 'x', 'y', 'z', got {up!r}")
    face_values = _face_values(values, f, len(v))
    colormap = colormaps[cmap] if isinstance(cmap, str) else cmap
    v = _normalised(v, f)

    colors = _face_colors(face_colors, len(f), face_values is not None)
    if face_values is not None or colors is not None:
        if face_values is not None:
            norm = _value_norm(face_values, value_range)
            rgb = colormap(norm(face_values))[:, :3]
        else:
            rgb = colors

        def shade(i: NDArray) -> NDArray:
            return _SHADE_FLOOR + (1.0 - _SHADE_FLOOR) * i

    else:
        rgb = _BASE_RGB

        def shade(i: NDArray) -> NDArray:
            return i

    lay = _layout(size, views, title is not None, face_values is not None)
    width, height, panel, font = float(size), lay["height"], lay["panel"], lay["font"]
    # A hair over the exact size so that Agg's truncation to whole pixels cannot lose one.
    fig = Figure(figsize=((width + 0.01) / _DPI, (height + 0.01) / _DPI), dpi=_DPI)
    FigureCanvasAgg(fig)
    fig.patch.set_facecolor("white")
    pt = 72.0 / _DPI  # points per pixel
    if title is not None:
        fig.text(
            0.5, 1.0 - 0.5 * lay["top"] / height, title, ha="center", va="center",
            fontsize=_fit(title, lay["big"], width) * pt, fontweight="bold",
        )  # fmt: skip
    for k, azimuth in enumerate(view_azimuths(views)):
        ax = fig.add_axes((k * panel / width, lay["bar"] / height, panel / width, panel / height))
        ax.set_axis_off()
        ax.set_aspect("equal", adjustable="box")
        _draw_view(ax, v, f, _camera(azimuth, ELEVATION, _UP_AXES[up]), rgb, shade)
        label = f"azimuth {azimuth:g}°, elevation {ELEVATION:g}°"
        fig.text(
            (k + 0.5) * panel / width, 1.0 - (lay["top"] + 0.45 * lay["label"]) / height, label,
            ha="center", va="center", fontsize=_fit(label, font, panel) * pt, color="0.25",
        )  # fmt: skip
    if face_values is not None:
        bar_width = min(0.7 * width, max(0.45 * width, 40.0 * font))
        cax = fig.add_axes(
            ((width - bar_width) / 2.0 / width, 3.0 * font / height, bar_width / width,
             0.75 * font / height)
        )  # fmt: skip
        below, above = bool(face_values.min() < norm.vmin), bool(face_values.max() > norm.vmax)
        bar = fig.colorbar(
            ScalarMappable(norm=norm, cmap=colormap),
            cax=cax,
            orientation="horizontal",
            extend=("both", "min", "max", "neither")[2 * (not below) + (not above)],
        )
        bar.ax.tick_params(labelsize=0.85 * font * pt, length=0.3 * font, width=0.6)
        bar.outline.set_linewidth(0.6)
        if value_label:
            bar.set_label(
                value_label, fontsize=_fit(value_label, font, width) * pt, labelpad=0.25 * font
            )
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=_DPI, metadata={"Software": None})
    return buffer.getvalue()


def distance_to_surface(
    vertices: ArrayLike, faces: ArrayLike, other_vertices: ArrayLike, other_faces: ArrayLike
) -> NDArray[np.float64]:
    """Unsigned distance from every vertex of one mesh to the surface of another.

    Exact point-to-triangle distances (``igl.point_mesh_squared_distance``, an AABB tree over
    the other mesh's triangles), in the units of the meshes.  Vertices of the second mesh that
    no face uses are not part of its surface.

    Parameters
    ----------
    vertices, faces : array_like
        The mesh whose vertices are measured ((n, 3) float, (m, 3) int); only ``vertices`` is
        used, ``faces`` is checked.
    other_vertices, other_faces : array_like
        The surface measured against.

    Returns
    -------
    (n,) float64 ndarray
        Distance of each vertex (unreferenced ones included).

    Raises
    ------
    ValueError
        Either mesh empty or malformed, or with NaN/infinite coordinates.

    Examples
    --------
    >>> square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    >>> two = np.array([[0, 1, 2], [0, 2, 3]])
    >>> points = np.array([[0.5, 0.5, 0.25], [2.0, 0.5, 0.0], [0.0, 0.0, 0.0]])
    >>> distance_to_surface(points, [[0, 1, 2]], square, two).tolist()
    [0.25, 1.0, 0.0]
    """
    v, _ = check_mesh(np.asarray(vertices), np.asarray(faces))
    ov, of = check_mesh(np.asarray(other_vertices), np.asarray(other_faces))
    sq, _, _ = igl.point_mesh_squared_distance(
        np.ascontiguousarray(v, dtype=np.float64),
        np.ascontiguousarray(ov, dtype=np.float64),
        np.ascontiguousarray(of, dtype=np.int64),
    )
    return np.sqrt(np.maximum(np.asarray(sq, dtype=np.float64), 0.0))


def render_comparison(
    vertices: ArrayLike,
    faces: ArrayLike,
    other_vertices: ArrayLike,
    other_faces: ArrayLike,
    *,
    views: int = 3,
    size: int = 900,
    title: str | None = None,
    cmap: str | Colormap = "YlOrRd",
    up: str = "y",
) -> tuple[bytes, dict[str, float]]:
    """Heat map, on the first mesh, of its distance to the surface of the second.

    The value at each vertex of the first mesh is its unsigned distance to the second surface
    (:func:`distance_to_surface`) in percent of the bounding-box diagonal of the second mesh;
    faces are coloured by the mean of their vertices (:func:`render_views`).  The colormap runs
    from 0 to the 99th percentile of the vertex values (to the maximum when that percentile is
    0), so that a few outlying vertices do not wash the picture out; larger values get the top
    colour, the colorbar then ends in an arrow, and its label gives the maximum.

    Parameters
    ----------
    vertices, faces : array_like
        The mesh drawn (for example a marked mesh).
    other_vertices, other_faces : array_like
        The reference surface (for example the unmarked remeshed mesh).
    views, size, title, cmap, up
        As for :func:`render_views` (``cmap`` defaults to ``"YlOrRd"``: pale where the
        meshes agree, so the shading still shows the shape, dark red where they differ).

    Returns
    -------
    png : bytes
        The picture.
    stats : dict
        ``max_rel``, ``mean_rel``, ``rms_rel``: maximum, mean and root mean square over the
        vertices of the first mesh used by its faces, of the distance divided by the diagonal
        (fractions, not percent); ``diagonal``: that diagonal, in mesh units.

    Raises
    ------
    ValueError
        As for :func:`render_views` and :func:`distance_to_surface`, or a second mesh
        collapsed to a point.

    Examples
    --------
    >>> tetra = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    >>> tri = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> png, stats = render_comparison(tetra, tri, tetra, tri, views=1, size=120)
    >>> png[:4], stats["max_rel"]
    (b'\\x89PNG', 0.0)
    """
    v, f = check_mesh(np.asarray(vertices), np.asarray(faces))
    ov, of = check_mesh(np.asarray(other_vertices), np.asarray(other_faces))
    used_other = ov[np.unique(of)]
    diagonal = bounding_box_diagonal(used_other)
    if not diagonal > 0:
        raise ValueError("the reference mesh is degenerate: its faces collapse to one point")
    rel = distance_to_surface(v, f, ov, of) / diagonal
    used = rel[np.unique(f)]
    stats = {
        "max_rel": float(used.max()),
        "mean_rel": float(used.mean()),
        "rms_rel": float(np.sqrt(np.mean(used * used))),
        "diagonal": diagonal,
    }
    percent = 100.0 * rel
    top = float(np.percentile(used, 99.0))  # a few outliers must not wash the picture out
    top = 100.0 * (top if top > 0 else stats["max_rel"])
    png = render_views(
        v,
        f,
        values=percent,
        views=views,
        size=size,
        title=title,
        cmap=cmap,
        value_label=(
            "distance to the reference surface, % of its bounding-box diagonal "
            f"(max {100.0 * stats['max_rel']:.3g})"
        ),
        value_range=(0.0, top),
        up=up,
    )
    return png, stats
