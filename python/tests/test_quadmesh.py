"""The Python package: Triangle's dict interface on Triangle's own examples (read from the
installed ``triangle`` package, never copied), the keyword interface, bad input as exceptions,
the same arrays on any thread count, and meshio."""

import os

import numpy as np
import pytest

import quadmesh

try:
    import triangle

    DATA = os.path.join(os.path.dirname(triangle.__file__), "data")
except ImportError:  # Only the tests on Triangle's examples need it; they say they skipped.
    if os.environ.get("QUADMESH_REQUIRE_TRIANGLE"):
        raise
    triangle = None
needs_triangle = pytest.mark.skipif(triangle is None, reason="the Python package `triangle` is not installed")


def area(vertices, triangles):
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def angles(vertices, triangles):
    """Every triangle's three angles in degrees, one row per corner."""
    p = vertices[triangles]
    rows = []
    for k in range(3):
        u = p[:, (k + 1) % 3] - p[:, k]
        v = p[:, (k + 2) % 3] - p[:, k]
        cos = (u * v).sum(1) / np.linalg.norm(u, axis=1) / np.linalg.norm(v, axis=1)
        rows.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.array(rows)


def min_angles(vertices, triangles):
    return angles(vertices, triangles).min(axis=0)


def max_angles(vertices, triangles):
    return angles(vertices, triangles).max(axis=0)


def same_vertices(out, vertices):
    """Every input vertex is an output vertex, bit for bit."""
    have = {tuple(v) for v in np.asarray(out["vertices"]).view(np.int64)}
    return all(tuple(v) in have for v in np.asarray(vertices, dtype=np.float64).view(np.int64))


@needs_triangle
@pytest.mark.parametrize("name", ["A", "face", "la", "double_hex", "square_circle_hole"])
@pytest.mark.parametrize("opts", ["pq20", "pq30", "pq30a", "pq30ena", "pcq25"])
def test_triangle_examples_have_triangles_semantics(name, opts):
    tri = triangle.load(DATA, name)
    ours = quadmesh.triangulate(tri, opts + "Q")
    theirs = triangle.triangulate(tri, opts + "Q")
    v, t = ours["vertices"], ours["triangles"]
    # The same domain: holes eaten alike, the same area (counter-clockwise triangles).
    assert (area(v, t) > 0).all()
    assert np.isclose(area(v, t).sum(), area(theirs["vertices"], theirs["triangles"]).sum(), rtol=1e-9)
    assert same_vertices(ours, tri["vertices"])
    # Markers: every segment piece keeps its input segment's marker (1 for 0 on the boundary),
    # as Triangle's output segments do.
    assert set(np.unique(ours["segment_markers"])) <= set(np.unique(theirs["segment_markers"])) | {0, 1}
    # The quality asked for, away from input angles smaller than it.
    angle = float(opts.split("q")[1][:2])
    small = min_angles(v, t) < angle - 1e-9
    assert small.sum() <= (min_angles(theirs["vertices"], theirs["triangles"]) < angle - 1e-9).sum() + 8
    if "e" in opts:
        assert len(ours["edges"]) == len(ours["edge_markers"])
    if "n" in opts:
        n = ours["neighbors"]
        assert n.shape == t.shape and (n >= -1).all()


@needs_triangle
def test_regional_attributes_and_area_bounds():
    tri = triangle.load(DATA, "la")
    ours = quadmesh.triangulate(tri, "pq30aAQ")
    attributes = ours["triangle_attributes"][:, 0]
    assert set(np.unique(attributes)) <= set(tri["regions"][:, 2]) | {0.0}
    # Without a bare -a, the regions' bounds do not apply (Triangle's rule): fewer triangles.
    plain = quadmesh.triangulate(tri, "pq30AQ")
    assert len(plain["triangles"]) < len(ours["triangles"])


def test_point_sets_and_keyword_interface():
    rng = np.random.default_rng(3)
    points = rng.random((5000, 2))
    m = quadmesh.mesh(points, min_angle=30, max_area=1e-3)
    assert m.triangles.dtype == np.uint32 and m.vertices.dtype == np.float64
    assert (area(m.vertices, m.triangles) > 0).all()
    assert (area(m.vertices, m.triangles) <= 1e-3 + 1e-15).all()
    assert min_angles(m.vertices, m.triangles).min() >= 30 - 1e-9
    inputs = m.vertex_input[m.vertex_input >= 0]
    assert (m.vertices[m.vertex_input >= 0] == points[inputs]).all()
    assert m.report["triangles"] == len(m.triangles)
    # Edges are listed only when asked for: each once, Euler's count on a disk.
    assert m.edges is None
    e = quadmesh.mesh(points[:300], edges=True)
    assert len(e.edges) == len(e.vertices) + len(e.triangles) - 1
    assert len(e.edge_markers) == len(e.edges)
    coarse = quadmesh.mesh(points[:200], mode="warp")
    assert min_angles(coarse.vertices, coarse.triangles).min() >= 20 - 1e-6
    assert max_angles(coarse.vertices, coarse.triangles).max() <= 120 + 1e-6
    warped = quadmesh.mesh(points[:200], mode="compact_warp")
    smallest = min_angles(warped.vertices, warped.triangles)
    assert smallest.min() >= 26 - 1e-6
    assert max_angles(warped.vertices, warped.triangles).max() <= 120 + 1e-6
    assert len(warped.triangles) > 3 * len(coarse.triangles)
    block = quadmesh.mesh(points[:200], mode="block_warp")
    assert min_angles(block.vertices, block.triangles).min() >= 22.5 - 1e-6
    assert len(block.triangles) > 2 * len(warped.triangles)
    # Nonobtuse, split and coarsened: every angle at most 90° (to rounding), and every point a
    # vertex; the coarsening takes away about half the triangles.
    split = quadmesh.mesh(points[:200], mode="nonobtuse_split")
    nonobtuse = quadmesh.mesh(points[:200], mode="nonobtuse")
    for m in (split, nonobtuse):
        assert max_angles(m.vertices, m.triangles).max() <= 90 + 1e-6
        assert (area(m.vertices, m.triangles) > 0).all()
        inputs = m.vertex_input[m.vertex_input >= 0]
        assert sorted(inputs) == list(range(200))
        assert (m.vertices[m.vertex_input >= 0] == points[inputs]).all()
    assert len(nonobtuse.triangles) < 0.6 * len(split.triangles)
    with pytest.raises(quadmesh.QuadmeshError, match="nonobtuse"):
        quadmesh.mesh(points[:10], mode="acute")


def test_a_graph_is_warped_over_what_its_segments_enclose():
    # A square with a square hole: the warp mode meshes the ring, its segments conforming.
    points = np.array([[0, 0], [4, 0], [4, 4], [0, 4], [1, 1], [2, 1], [2, 2], [1, 2]], float)
    segments = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4]])
    m = quadmesh.mesh(points, segments=segments, holes=[[1.5, 1.5]], mode="warp")
    assert (area(m.vertices, m.triangles) > 0).all()
    assert np.isclose(area(m.vertices, m.triangles).sum(), 15.0, rtol=1e-12)
    inputs = m.vertex_input[m.vertex_input >= 0]
    assert sorted(inputs) == list(range(8))
    assert (m.vertices[m.vertex_input >= 0] == points[inputs]).all()
    # No input corner is narrower than the bound: every angle lies within it.
    assert m.report["angle_bounds"] == (20.0, 140.0)
    angles = min_angles(m.vertices, m.triangles)
    assert angles.min() >= 20 - 1e-9 and m.report["min_angle"] >= 20 - 1e-9
    assert m.report["max_angle"] <= 140 + 1e-9
    one = quadmesh.mesh(points, segments=segments, holes=[[1.5, 1.5]], mode="warp", threads=1)
    assert np.array_equal(one.triangles, m.triangles)


def test_spare_vertices_removed_leave_fewer_triangles_with_the_same_bounds():
    # A square with a square hole at 33°: taking spare Steiner vertices out keeps the domain,
    # the input points and the angle bound, with fewer triangles, the same on any thread count.
    points = np.array([[0, 0], [4, 0], [4, 4], [0, 4], [1, 1], [2.3, 1], [2.3, 2.1], [1, 2.1]], float)
    segments = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4]])
    kw = dict(segments=segments, holes=[[1.5, 1.5]], min_angle=33.0, max_area=0.05)
    plain = quadmesh.mesh(points, **kw)
    spare = quadmesh.mesh(points, remove_spare_vertices=True, **kw)
    assert len(spare.triangles) < len(plain.triangles)
    areas = area(spare.vertices, spare.triangles)
    assert (areas > 0).all() and (areas <= 0.05).all()
    assert np.isclose(areas.sum(), 16.0 - 1.3 * 1.1, rtol=1e-12)
    assert min_angles(spare.vertices, spare.triangles).min() >= 33.0 - 1e-9
    inputs = spare.vertex_input[spare.vertex_input >= 0]
    assert sorted(inputs) == list(range(8))
    assert (spare.vertices[spare.vertex_input >= 0] == points[inputs]).all()
    one = quadmesh.mesh(points, remove_spare_vertices=True, threads=1, **kw)
    assert np.array_equal(one.triangles, spare.triangles)
    assert np.array_equal(one.vertices, spare.vertices)


def test_the_same_arrays_on_any_thread_count():
    rng = np.random.default_rng(5)
    points = rng.random((40000, 2))
    one = quadmesh.mesh(points, min_angle=28, threads=1)
    two = quadmesh.mesh(points, min_angle=28, threads=2)
    for key in ["vertices", "triangles", "neighbors", "vertex_input"]:
        assert np.array_equal(getattr(one, key), getattr(two, key)), key


def test_bad_input_raises_and_never_crashes():
    square = {"vertices": [[0, 0], [1, 0], [1, 1], [0, 1]], "segments": [[0, 1], [1, 2], [2, 3], [3, 0]]}
    cases = [
        (dict(square, segments=[[0, 9]]), "p", "names point 9"),
        (dict(square, segments=[[0, 2], [1, 3]]), "p", "cross"),
        (dict(square, segments=[[0, 0]]), "p", "no length"),
        (dict(square, segments=[[0, -1]]), "p", "not an index"),
        ({"vertices": [[0, 0], [np.nan, 1], [1, 1]]}, "", "NaN"),
        ({"vertices": np.zeros((0, 2))}, "", "no points"),
        ({"vertices": [[0, 0], [1, 1], [2, 2]]}, "", "collinear"),
        (square, "pq50", "min_angle"),
        (square, "pr", "-r"),
        (square, "pw", "-w"),
        (square, "pqx", "-x"),
        ({"vertices": [[0, 0, 0]]}, "", "n × 2 array"),
    ]
    for tri, opts, words in cases:
        with pytest.raises(quadmesh.QuadmeshError, match=words):
            quadmesh.triangulate(tri, opts)
    with pytest.raises(ValueError):
        quadmesh.mesh([[0, 0], [1, 0], [0, 1]], mode="nonsense")
    with pytest.raises(ValueError, match="vertex budget|vertices"):
        quadmesh.mesh(np.random.default_rng(1).random((100, 2)), max_area=1e-6, max_vertices=500)


@needs_triangle
def test_meshio_round_trip(tmp_path):
    meshio = pytest.importorskip("meshio")
    tri = triangle.load(DATA, "la")
    m = quadmesh.mesh(
        tri["vertices"], tri["segments"], tri.get("segment_markers"), regions=tri["regions"], min_angle=25
    )
    path = tmp_path / "la.vtu"
    m.to_meshio().write(path)
    back = meshio.read(path)
    assert np.array_equal(back.points[:, :2], m.vertices)
    assert np.array_equal(back.cells_dict["triangle"], m.triangles)
    assert np.array_equal(back.cell_data["attribute"][0], m.triangle_attributes)


def _same_mesh(a, b):
    for name in ("vertices", "triangles", "neighbors", "vertex_input", "vertex_markers"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


@pytest.mark.parametrize("mode", ["warp", "block_warp"])
def test_a_dynamic_mesh_after_edits_is_a_fresh_one_of_its_live_points(mode):
    rng = np.random.default_rng(3)
    start = rng.random((300, 2))
    dynamic = quadmesh.DynamicMesh(start, (0, 0, 1, 1), mode=mode)
    where = {i: tuple(p) for i, p in enumerate(start)}
    for k in range(60):
        ids = list(where)
        if k % 3 == 0:
            x, y = rng.random(2)
            where[dynamic.insert(x, y)] = (x, y)
        elif k % 3 == 1:
            gone = ids[int(rng.integers(len(ids)))]
            dynamic.delete(gone)
            del where[gone]
        else:
            moved = ids[int(rng.integers(len(ids)))]
            x, y = rng.random(2)
            dynamic.move_to(moved, x, y)
            where[moved] = (x, y)
    live = dynamic.live_ids()
    assert list(live) == sorted(where)
    assert len(dynamic) == len(where)
    points = np.array([where[i] for i in live])
    mesh = dynamic.mesh()
    _same_mesh(mesh, quadmesh.DynamicMesh(points, (0, 0, 1, 1), mode=mode).mesh())
    assert 20 < len(mesh.triangles) / len(points) < (50 if mode == "warp" else 150)
    if mode == "warp":
        with pytest.raises(quadmesh.QuadmeshError, match="nonobtuse"):
            dynamic.mesh(nonobtuse=True)
        coarse = dynamic.mesh(coarsen=True)
        again = quadmesh.DynamicMesh(points, (0, 0, 1, 1), mode=mode)
        _same_mesh(coarse, again.mesh(coarsen=True))
        assert min_angles(coarse.vertices, coarse.triangles).min() >= 20 - 1e-6
        assert len(coarse.triangles) < len(mesh.triangles) / 3
    else:
        # The nonobtuse mesh of the same tree: a rebuild's, every angle at most 90°.
        split = dynamic.mesh(nonobtuse=True)
        again = quadmesh.DynamicMesh(points, (0, 0, 1, 1), mode=mode)
        _same_mesh(split, again.mesh(nonobtuse=True))
        assert max_angles(split.vertices, split.triangles).max() <= 90 + 1e-6
        assert len(split.triangles) > len(mesh.triangles)
        coarse = dynamic.mesh(nonobtuse=True, coarsen=True)
        _same_mesh(coarse, again.mesh(nonobtuse=True, coarsen=True))
        assert len(coarse.triangles) < 0.6 * len(split.triangles)
        assert max_angles(coarse.vertices, coarse.triangles).max() <= 90 + 1e-6
        with pytest.raises(quadmesh.QuadmeshError, match="warp"):
            dynamic.mesh(coarsen=True)
    # Every live point is a vertex, numbered in id order.
    vertex_of = {int(v): i for i, v in enumerate(mesh.vertex_input) if v >= 0}
    np.testing.assert_array_equal(mesh.vertices[[vertex_of[k] for k in range(len(live))]], points)


def _triangle_rows(vertices, triangles):
    """Each triangle as its corners from the least one on (orientation kept), as tuples."""
    rows = []
    for t in triangles:
        corners = [tuple(vertices[v]) for v in t]
        k = corners.index(min(corners))
        rows.append(tuple(corners[k:] + corners[:k]))
    return rows


def _corner_row(corners):
    """A (3, 2) array of corners as a row of ``_triangle_rows``."""
    k = min(range(3), key=lambda i: tuple(corners[i]))
    return tuple(tuple(p) for p in np.roll(corners, -k, axis=0))


@pytest.mark.parametrize("mode", ["warp", "block_warp"])
def test_tracked_changes_turn_the_old_mesh_into_the_new(mode):
    rng = np.random.default_rng(8)
    dynamic = quadmesh.DynamicMesh(rng.random((500, 2)), (0, 0, 1, 1), mode=mode)
    dynamic.track_changes()
    for nonobtuse in (False, True) if mode == "block_warp" else (False,):
        before = dynamic.mesh(nonobtuse=nonobtuse)
        dynamic.take_changes(nonobtuse)  # from here on
        x, y = rng.random(2)
        new = dynamic.insert(x, y)
        dynamic.move_to(int(dynamic.live_ids()[7]), *rng.random(2))
        removed, added = dynamic.take_changes(nonobtuse)
        assert removed.shape[1:] == (3, 2) and added.shape[1:] == (3, 2)
        after = dynamic.mesh(nonobtuse=nonobtuse)
        rows = _triangle_rows(before.vertices, before.triangles)
        for t in removed:
            rows.remove(_corner_row(t))
        rows += [_corner_row(t) for t in added]
        assert sorted(rows) == sorted(_triangle_rows(after.vertices, after.triangles))
        # Far fewer than the whole mesh changed.
        assert len(removed) + len(added) < len(after.triangles) // 10
        dynamic.delete(new)
    dynamic.track_changes(False)
    with pytest.raises(quadmesh.QuadmeshError):
        dynamic.take_changes()


def test_bad_dynamic_edits_raise_and_change_nothing():
    dynamic = quadmesh.DynamicMesh([[0.2, 0.3], [0.7, 0.8]], (0, 0, 1, 1))
    before = dynamic.mesh()
    for edit in (
        lambda: dynamic.insert(1.5, 0.5),
        lambda: dynamic.insert(float("nan"), 0.5),
        lambda: dynamic.insert(0.7, 0.8),
        lambda: dynamic.delete(5),
        lambda: dynamic.delete(-1),
        lambda: dynamic.move_to(0, 0.7, 0.8),
        lambda: dynamic.move_all([0, 1], [[0.1, 0.1], [0.5, 0.0]]),
    ):
        with pytest.raises(quadmesh.QuadmeshError):
            edit()
        _same_mesh(dynamic.mesh(), before)
    with pytest.raises(quadmesh.QuadmeshError, match="square"):
        quadmesh.DynamicMesh([[0.5, 0.5]], (0, 0, 2, 1), mode="block_warp")


def test_a_dynamic_warp_of_a_rectangle_is_the_static_warp_of_its_live_points():
    rng = np.random.default_rng(11)
    domain = (0.0, 0.0, 2.0, 0.7)
    start = rng.random((300, 2)) * [2.0, 0.7]
    dynamic = quadmesh.DynamicMesh(start, domain)
    dynamic.insert(2.0, 0.35)
    dynamic.delete(3)
    dynamic.move_to(5, 1.0, 0.0)
    live = np.delete(np.vstack([start, [[2.0, 0.35]]]), 3, axis=0)
    live[4] = [1.0, 0.0]
    mesh = dynamic.mesh()
    _same_mesh(mesh, quadmesh.DynamicMesh(live, domain).mesh())
    # It covers the rectangle exactly, its corners among its vertices.
    assert mesh.vertices.min(axis=0).tolist() == [0.0, 0.0]
    assert mesh.vertices.max(axis=0).tolist() == [2.0, 0.7]
    corners = mesh.vertices[mesh.triangles]
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    cross = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    assert abs(cross.sum() / 2 - 2.0 * 0.7) < 1e-12


def test_a_time_step_moves_every_point():
    rng = np.random.default_rng(8)
    start = 0.1 + 0.8 * rng.random((200, 2))
    dynamic = quadmesh.DynamicMesh(start, (0, 0, 1, 1))
    shift = (rng.random((200, 2)) - 0.5) * 1e-3
    dynamic.move_all(np.arange(200), shift)
    _same_mesh(dynamic.mesh(), quadmesh.DynamicMesh(start + shift, (0, 0, 1, 1)).mesh())


def test_a_dynamic_delaunay_mesh_after_edits_is_a_fresh_one_of_its_live_points():
    rng = np.random.default_rng(5)
    domain = (0, 0, 2, 1)
    start = rng.random((400, 2)) * [2, 1]
    dynamic = quadmesh.DynamicDelaunay(start, domain, min_angle=30)
    dynamic.track_changes()
    where = {i: tuple(p) for i, p in enumerate(start)}
    before = dynamic.mesh()
    for k in range(12):
        ids = list(where)
        if k % 3 == 0:
            x, y = rng.random(2) * [2, 1]
            where[dynamic.insert(x, y)] = (x, y)
        elif k % 3 == 1:
            gone = ids[int(rng.integers(len(ids)))]
            dynamic.delete(gone)
            del where[gone]
        else:
            moved = ids[int(rng.integers(len(ids)))]
            x, y = np.clip(np.array(where[moved]) + (rng.random(2) - 0.5) * 0.01, 0, [2, 1])
            dynamic.move_to(moved, x, y)
            where[moved] = (x, y)
        # The changes turn the mesh before into the mesh after.
        removed, added = dynamic.take_changes()
        after = dynamic.mesh()
        rows = _triangle_rows(before.vertices, before.triangles)
        for t in removed:
            rows.remove(_corner_row(t))
        rows += [_corner_row(t) for t in added]
        assert sorted(rows) == sorted(_triangle_rows(after.vertices, after.triangles))
        before = after
    live = dynamic.live_ids()
    assert list(live) == sorted(where) and len(dynamic) == len(where)
    points = np.array([where[i] for i in live])
    _same_mesh(before, quadmesh.DynamicDelaunay(points, domain, min_angle=30).mesh())
    assert min_angles(before.vertices, before.triangles).min() >= 30 - 1e-9
    # The vertices: the rectangle's corners, the live points and the Steiner points.
    assert dynamic.steiner_count() == len(before.vertices) - len(live) - 4
    # A time step moves every point at once, all or none.
    shift = (rng.random((len(live), 2)) - 0.5) * 1e-3
    moved = np.clip(points + shift, 0, [2, 1])
    dynamic.move_all(live, moved - points)
    _same_mesh(dynamic.mesh(), quadmesh.DynamicDelaunay(moved, domain, min_angle=30).mesh())
    mesh = dynamic.mesh()
    for edit in (
        lambda: dynamic.insert(2.5, 0.5),
        lambda: dynamic.insert(float("nan"), 0.5),
        lambda: dynamic.delete(10_000),
        lambda: dynamic.move_all(live[:2], [[0.0, 0.0], [5.0, 0.0]]),
    ):
        with pytest.raises(quadmesh.QuadmeshError):
            edit()
        _same_mesh(dynamic.mesh(), mesh)
    with pytest.raises(quadmesh.QuadmeshError):
        quadmesh.DynamicDelaunay([[0.5, 0.5], [0.5, 0.5]], domain)
