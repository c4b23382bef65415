"""Parallel quality triangle meshes of point sets and planar straight-line graphs.

Two ways in:

- ``triangulate(tri, opts)``: the ``triangle`` package's interface, a dict of numpy arrays and
  Triangle's option string, for the switches this mesher supports;
- ``mesh(points, segments=None, ...)``: keyword arguments, returning a :class:`Mesh`.

Meshing runs with the GIL released, on all cores or on ``threads`` threads, and gives the
same arrays on any thread count. Bad input raises :class:`QuadmeshError` (a ``ValueError``)
with the library's message; it never crashes the interpreter.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any, Dict, Optional, Tuple

import numpy as np

from ._quadmesh import NONE, QuadmeshError, _DynamicDelaunay, _DynamicMesh, _mesh

__all__ = ["DynamicDelaunay", "DynamicMesh", "Mesh", "QuadmeshError", "mesh", "triangulate"]


@dataclass
class Mesh:
    """A triangle mesh: numpy arrays, indices from 0.

    ``vertices`` (n × 2 float64) and ``triangles`` (m × 3 uint32, counter-clockwise) own the
    mesher's buffers; ``neighbors`` (m × 3 int64) has -1 on the boundary, opposite each
    corner. ``vertex_input`` gives each vertex's input index (-1 for one the mesher added);
    every input point is a vertex with bit-identical coordinates. For a planar straight-line
    graph, ``segments`` lists every mesh edge on an input segment (``segment_index`` names
    it) with ``segment_markers``, and with regions ``triangle_attributes`` and
    ``triangle_regions`` (-1 outside every region) are set. ``edges`` (every edge once) and
    ``edge_markers`` are listed when asked for (``edges=True``).
    """

    vertices: np.ndarray
    triangles: np.ndarray
    neighbors: np.ndarray
    vertex_input: np.ndarray
    vertex_markers: np.ndarray
    segments: np.ndarray
    segment_markers: np.ndarray
    segment_index: np.ndarray
    triangle_attributes: Optional[np.ndarray] = None
    triangle_regions: Optional[np.ndarray] = None
    edges: Optional[np.ndarray] = None
    edge_markers: Optional[np.ndarray] = None
    report: Dict[str, Any] = field(default_factory=dict)

    def to_meshio(self):
        """The mesh as a ``meshio.Mesh`` (meshio must be installed): triangles as cells, the
        vertex markers as point data, attributes and regions as cell data."""
        import meshio

        points = np.column_stack([self.vertices, np.zeros(len(self.vertices))])
        cell_data = {}
        if self.triangle_attributes is not None:
            cell_data["attribute"] = [self.triangle_attributes]
            cell_data["region"] = [self.triangle_regions]
        return meshio.Mesh(
            points,
            [("triangle", self.triangles.astype(np.int64))],
            point_data={"marker": self.vertex_markers},
            cell_data=cell_data,
        )


def _as_points(array, name: str, required: bool = True):
    if array is None:
        if required:
            raise QuadmeshError(f"{name} are required")
        return None
    a = np.ascontiguousarray(array, dtype=np.float64)
    if a.ndim != 2 or (a.size and a.shape[1] != 2):
        raise QuadmeshError(f"{name} must be an n × 2 array, not of shape {a.shape}")
    return a.reshape(-1, 2)


def _as_indices(array, name: str, width: int):
    if array is None:
        return None
    a = np.asarray(array)
    if a.size and not np.issubdtype(a.dtype, np.integer):
        raise QuadmeshError(f"{name} must hold integers, not {a.dtype}")
    a = np.ascontiguousarray(a, dtype=np.int64)
    if width == 1:
        return a.reshape(-1)
    if a.ndim != 2 or (a.size and a.shape[1] != width):
        raise QuadmeshError(f"{name} must be an n × {width} array, not of shape {a.shape}")
    return a.reshape(-1, width)


def _regions(regions):
    if regions is None:
        return None
    a = np.ascontiguousarray(regions, dtype=np.float64)
    if a.ndim != 2 or (a.size and a.shape[1] != 4):
        raise QuadmeshError(
            f"regions must be an n × 4 array (x, y, attribute, max area), not of shape {a.shape}"
        )
    return a.reshape(-1, 4)


def mesh(
    points,
    segments=None,
    segment_markers=None,
    holes=None,
    regions=None,
    *,
    min_angle: float = 20.0,
    max_area: Optional[float] = None,
    max_vertices: Optional[int] = None,
    mode: str = "delaunay",
    convex_hull: bool = False,
    no_boundary_steiner: bool = False,
    split_crossings: bool = False,
    remove_spare_vertices: bool = False,
    threads: Optional[int] = None,
    edges: bool = False,
) -> Mesh:
    """Meshes ``points`` (n × 2), or the planar straight-line graph they make with
    ``segments`` (m × 2 point indices, with ``segment_markers``), ``holes`` (seeds) and
    ``regions`` (rows of x, y, attribute, max area; a max area ≤ 0 bounds nothing).

    ``mode="delaunay"`` (the default) gives a Delaunay mesh with every angle at least
    ``min_angle`` (0 to 45; input angles smaller than it are kept) and every area at most
    ``max_area``; a point set's domain is its convex hull, a graph's what its segments enclose
    (``convex_hull=True``: the hull minus the holes). ``mode="warp"`` gives the warped quadtree
    mesh of a point set coarsened, every angle in [20°, 120°] (about 7 triangles per point),
    or of what a graph's segments enclose (a quadtree bent onto the graph, every angle in
    [20°, 140°] outside input corners narrower than 20°); ``mode="compact_warp"`` the warp
    before coarsening, every angle in [26°, 120°] (a graph's: [20°, 140°]) (about 36 triangles per point, several times
    faster); ``mode="block_warp"`` the older warp, every angle in [22.5°, 112.5°] (about 104 triangles
    per point); ``mode="nonobtuse"`` a mesh with every angle at most 90° (none bounded below:
    a point near a grid line of its leaf makes thin triangles; about 47–57 triangles per point):
    ``mode="nonobtuse_split"``, the block warp's quadtree split into right triangles at the
    points (about 114 triangles per point, several times faster), coarsened with no new angle
    under 20°.
    ``remove_spare_vertices=True`` (a graph, Delaunay mode) takes out, after refinement, the
    Steiner vertices on no segment wherever the mesh left still meets every bound: a smaller
    mesh, for more time.
    The ``report`` gives counts, the angles reached, the bounds the mode guarantees
    (``angle_bounds``) and stage times.
    ``threads`` sets the number of threads
    for this call (by default, all cores). ``edges=True`` also lists every edge with its
    marker.
    """
    raw = _mesh(
        _as_points(points, "points"),
        _as_indices(segments, "segments", 2),
        _as_indices(segment_markers, "segment_markers", 1),
        _as_points(holes, "holes", required=False),
        _regions(regions),
        min_angle=float(min_angle),
        max_area=None if max_area is None else float(max_area),
        max_vertices=max_vertices,
        mode=mode,
        convex_hull=convex_hull,
        no_boundary_steiner=no_boundary_steiner,
        split_crossings=split_crossings,
        remove_spare_vertices=remove_spare_vertices,
        threads=threads,
        edges=edges,
    )
    return _mesh_of(raw)


def _mesh_of(raw) -> Mesh:
    neighbors = raw.pop("neighbors_raw").astype(np.int64)
    neighbors[neighbors == NONE] = -1
    return Mesh(neighbors=neighbors, **raw)


class _Dynamic:
    """What both dynamic meshes share: ids, edits and change tracking."""

    _inner: Any

    def __len__(self) -> int:
        return len(self._inner)

    def insert(self, x: float, y: float) -> int:
        """Adds a point; returns its id."""
        return self._inner.insert(float(x), float(y))

    def delete(self, id: int) -> None:
        """Deletes the live point ``id``."""
        self._inner.delete(int(id))

    def move_to(self, id: int, x: float, y: float) -> None:
        """Moves the live point ``id`` to (x, y)."""
        self._inner.move_to(int(id), float(x), float(y))

    def move_all(self, ids, displacements) -> None:
        """Moves each point ``ids[k]`` by ``displacements[k]`` (a time step), all or none."""
        ids = np.ascontiguousarray(ids, dtype=np.int64).reshape(-1)
        self._inner.move_all(ids, _as_points(displacements, "displacements"))

    def live_ids(self) -> np.ndarray:
        """The ids of the live points, in increasing order."""
        return self._inner.live_ids()

    def track_changes(self, on: bool = True) -> None:
        """Starts (or with ``on=False`` stops) recording what edits change, for
        ``take_changes``."""
        self._inner.track_changes(bool(on))


class DynamicMesh(_Dynamic):
    """A warped quadtree mesh of points on a fixed rectangle ``domain`` (x0, y0, x1, y1), kept
    current while points are inserted, deleted and moved: the compact warp (``mode="warp"``,
    every angle in [26°, 120°], not coarsened: ``quadmesh.mesh(..., mode="compact_warp")``) or the block warp (``mode="block_warp"``, [22.5°, 112.5°],
    about three times the triangles, on a square only, and the only one that also gives the
    nonobtuse mesh),
    as ``mesh(..., mode=...)`` gives them on that domain.

    The initial points have ids ``0 .. n-1``; each insertion takes the next id, and a deleted
    id is never given out again. After any edits, ``mesh()`` is exactly the mesh that a new
    ``DynamicMesh`` of the live points (in id order) gives; its ``vertex_input`` numbers the
    live points in id order (``live_ids()``). A bad edit (outside the domain, NaN, the place of
    a live point, an unknown id) raises ``QuadmeshError`` and changes nothing; ``move_all`` moves
    all points or none.
    """

    def __init__(self, points, domain, mode: str = "warp"):
        if mode not in ("warp", "block_warp"):
            raise ValueError(f"mode must be 'warp' or 'block_warp', not {mode!r}")
        x0, y0, x1, y1 = (float(v) for v in domain)
        self._inner = _DynamicMesh(
            _as_points(points, "points"), (x0, y0, x1, y1), mode == "block_warp"
        )

    def mesh(self, nonobtuse: bool = False, coarsen: bool = False) -> Mesh:
        """The current mesh: the warped one, or with ``nonobtuse=True`` (``mode="block_warp"``
        only) the nonobtuse split of the same quadtree (every angle at most 90°), as
        ``mesh(..., mode="compact_warp")`` (or ``"block_warp"``, ``"nonobtuse_split"``) gives;
        with ``coarsen=True`` coarsened, as ``mode="warp"`` (``mode="warp"`` only) or
        ``mode="nonobtuse"`` gives. The coarsening is made from the whole mesh each time."""
        return _mesh_of(self._inner.mesh(bool(nonobtuse), bool(coarsen)))

    def take_changes(self, nonobtuse: bool = False) -> Tuple[np.ndarray, np.ndarray]:
        """The triangles of ``mesh()`` (or ``mesh(nonobtuse=True)``; never coarsened) that the edits since
        ``track_changes`` or the last call took out and put in, as two arrays of shape
        (k, 3, 2): each triangle's corners, counter-clockwise. Taking ``removed`` out of the
        mesh as it was and putting ``added`` in gives the mesh as it is. Found by re-meshing
        only around the change, in time that does not grow with the number of points (a large
        ``move_all`` that rebuilds the tree costs two whole meshes)."""
        removed, added, _ = self._inner.take_changes(bool(nonobtuse))
        return removed, added


class DynamicDelaunay(_Dynamic):
    """A quality Delaunay mesh (every angle at least ``min_angle`` degrees, every triangle at
    most ``max_area`` where given) of points in a fixed rectangle ``domain`` (x0, y0, x1, y1),
    kept current while points are inserted, deleted and moved.

    Ids work as in ``DynamicMesh``. An edit re-refines only a window around the change where
    it can (near the rectangle's sides, or between clusters, the window may grow to the whole
    domain). After any edits, ``mesh()`` is exactly the mesh that a new ``DynamicDelaunay`` of
    the live points (in id order) gives. A bad edit (outside the domain, NaN, the place of a
    live point or too close to one, an unknown id) raises ``QuadmeshError`` and changes
    nothing; ``move_all`` moves all points or none.
    """

    def __init__(self, points, domain, min_angle: float = 30.0, max_area: Optional[float] = None):
        x0, y0, x1, y1 = (float(v) for v in domain)
        area = None if max_area is None else float(max_area)
        self._inner = _DynamicDelaunay(
            _as_points(points, "points"), (x0, y0, x1, y1), float(min_angle), area
        )

    def steiner_count(self) -> int:
        """How many vertices refinement added."""
        return self._inner.steiner_count()

    def mesh(self) -> Mesh:
        """The current mesh; its ``vertex_input`` numbers the live points in id order."""
        return _mesh_of(self._inner.mesh())

    def take_changes(self) -> Tuple[np.ndarray, np.ndarray]:
        """The triangles of ``mesh()`` that the edits since ``track_changes`` or the last call
        took out and put in, as ``DynamicMesh.take_changes`` gives them; found from the
        vertices around the change (after a ``move_all`` that refined everything again, from
        two triangulations of the whole domain)."""
        removed, added, _ = self._inner.take_changes()
        return removed, added


# Switches of Triangle's option string this mesher supports, and those it refuses by name.
_FLAGS = set("pqacenAYQzjV")
_REFUSED = {
    "r": "refinement of an existing mesh",
    "D": "conforming Delaunay meshes",
    "u": "a user-defined triangle test",
    "o": "second-order triangles",
    "v": "Voronoi diagrams",
    "S": "a Steiner point count",
    "i": "the incremental algorithm",
    "F": "Fortune's sweepline",
    "l": "vertical cuts only",
    "s": "segment splitting off",
    "C": "consistency checks",
    "P": "no output segments",
    "N": "no output vertices",
    "E": "no output triangles",
    "I": "no iteration numbers",
    "O": "no holes",
    "X": "exact arithmetic off",
    "B": "no boundary markers",
    "k": "keeping only mesh boundary",
}


def _parse_switches(opts: str) -> Dict[str, Any]:
    """Triangle's switches, with their numbers (``q30``, ``a0.1``, ``q`` alone is 20°); as in
    Triangle, a number is digits and points only."""
    found: Dict[str, Any] = {}
    for letter, number in re.findall(r"([A-Za-z])([0-9.]*)", opts):
        if letter in _REFUSED:
            raise QuadmeshError(f"switch -{letter} ({_REFUSED[letter]}) is not supported")
        if letter not in _FLAGS:
            raise QuadmeshError(f"switch -{letter} is not a switch this mesher knows")
        if letter in "qa" and number:
            try:
                found[letter] = float(number)
            except ValueError:
                raise QuadmeshError(f"switch -{letter}{number}: {number!r} is not a number") from None
        else:
            if number:
                raise QuadmeshError(f"switch -{letter} takes no number, got {number!r}")
            found.setdefault(letter, True)
    if re.sub(r"[A-Za-z][0-9.]*", "", opts).strip():
        raise QuadmeshError(f"cannot read the option string {opts!r}")
    return found


def triangulate(tri: Dict[str, Any], opts: str = "") -> Dict[str, np.ndarray]:
    """The ``triangle`` package's ``triangulate``: ``tri`` holds ``vertices`` and, for ``-p``,
    ``segments``, ``segment_markers``, ``holes`` and ``regions``; ``opts`` is Triangle's
    option string. Supported: ``p`` (a planar straight-line graph), ``q[angle]`` (default 20),
    ``a[area]`` (a number: every triangle; alone: the regions' bounds), ``c`` (convex hull),
    ``Y`` (no boundary Steiner points), ``e`` (edges), ``n`` (neighbors), ``A`` (regional
    attributes), ``Q``, ``z``, ``j`` and ``V`` (accepted, no effect). Other switches raise
    :class:`QuadmeshError`. The output dict has Triangle's keys: ``vertices``,
    ``vertex_markers``, ``triangles``, and as asked ``segments``/``segment_markers``,
    ``edges``/``edge_markers``, ``neighbors``, ``triangle_attributes``, ``holes``,
    ``regions``. Indices are 0-based int32, -1 for none.
    """
    s = _parse_switches(opts)
    vertices = tri.get("vertices")
    graph = "p" in s
    angle = s.get("q")
    min_angle = 0.0 if angle is None else (20.0 if angle is True else angle)
    area = s.get("a")
    regions = tri.get("regions") if graph else None
    if regions is not None:
        regions = np.array(regions, dtype=np.float64).reshape(-1, 4)
        if area is not True:
            # Triangle applies the regions' bounds only with a bare -a.
            regions[:, 3] = -1.0
    m = mesh(
        vertices,
        segments=tri.get("segments") if graph else None,
        segment_markers=_markers(tri.get("segment_markers")) if graph else None,
        holes=tri.get("holes") if graph else None,
        regions=regions,
        min_angle=min_angle,
        max_area=area if isinstance(area, float) else None,
        convex_hull="c" in s,
        no_boundary_steiner="Y" in s,
        edges="e" in s,
    )
    out: Dict[str, np.ndarray] = {
        "vertices": m.vertices,
        "vertex_markers": m.vertex_markers.astype(np.int32).reshape(-1, 1),
        "triangles": m.triangles.astype(np.int32),
    }
    if graph:
        out["segments"] = m.segments.astype(np.int32)
        out["segment_markers"] = m.segment_markers.astype(np.int32).reshape(-1, 1)
        if tri.get("holes") is not None:
            out["holes"] = np.asarray(tri["holes"], dtype=np.float64)
        if tri.get("regions") is not None:
            out["regions"] = np.asarray(tri["regions"], dtype=np.float64)
    if "e" in s:
        out["edges"] = m.edges.astype(np.int32)
        out["edge_markers"] = m.edge_markers.astype(np.int32).reshape(-1, 1)
    if "n" in s:
        out["neighbors"] = m.neighbors.astype(np.int32)
    if "A" in s and m.triangle_attributes is not None:
        out["triangle_attributes"] = m.triangle_attributes.reshape(-1, 1)
    return out


def _markers(markers):
    if markers is None:
        return None
    return np.asarray(markers).reshape(-1)
