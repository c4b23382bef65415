//! The extension module behind the `quadmesh` Python package: one call that takes numpy arrays,
//! meshes with the GIL released on a pool of the threads asked for, and returns numpy arrays
//! that own the mesh's buffers (no copy of vertices, triangles or neighbours).

use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use quadmesh::balance::Separation;
use quadmesh::dynamic::{DynamicDelaunay, DynamicMesh, Edit, TriangleChanges};
use quadmesh::mesh::Domain;
use quadmesh::refine::{RefineDomain, RefineOptions};
use quadmesh::{DVec2, Error, Input, Mesh, MeshReport, Mode, Options, Region, RegionSeed, Segment};

create_exception!(
    _quadmesh,
    QuadmeshError,
    PyValueError,
    "Bad input or options, or a refinement that could not finish; the message says which."
);

/// What `_mesh` asks of the library, apart from the geometry.
struct Asked {
    min_angle: f64,
    max_area: Option<f64>,
    max_vertices: Option<usize>,
    mode: Mode,
    convex_hull: bool,
    no_boundary_steiner: bool,
    split_crossings: bool,
    remove_spare_vertices: bool,
}

impl Asked {
    fn options(&self) -> Options {
        let mut options = Options::default()
            .min_angle(self.min_angle)
            .with_mode(self.mode);
        if let Some(a) = self.max_area {
            options = options.max_area(a);
        }
        if let Some(n) = self.max_vertices {
            options = options.max_vertices(n);
        }
        if self.convex_hull {
            options = options.region(Region::ConvexHull);
        }
        if self.no_boundary_steiner {
            options = options.no_boundary_steiner();
        }
        if self.split_crossings {
            options = options.split_crossings();
        }
        if self.remove_spare_vertices {
            options = options.remove_spare_vertices();
        }
        options
    }
}

/// The rows of an `n × width` array, read straight from its buffer when it is contiguous, or an
/// error naming `what`.
fn rows<T: numpy::Element + Copy, R>(
    array: &PyReadonlyArray2<'_, T>,
    width: usize,
    what: &str,
    row: impl Fn(&[T]) -> R,
) -> PyResult<Vec<R>> {
    let view = array.as_array();
    if view.ncols() != width {
        return Err(QuadmeshError::new_err(format!(
            "{what} must have {width} columns, not {}",
            view.ncols()
        )));
    }
    Ok(match array.as_slice() {
        Ok(flat) => flat.chunks_exact(width).map(row).collect(),
        Err(_) => view.rows().into_iter().map(|r| row(&r.to_vec())).collect(),
    })
}

/// The geometry as the library's input.
fn input_of(
    points: &PyReadonlyArray2<'_, f64>,
    segments: Option<&PyReadonlyArray2<'_, i64>>,
    segment_markers: Option<&PyReadonlyArray1<'_, i64>>,
    holes: Option<&PyReadonlyArray2<'_, f64>>,
    regions: Option<&PyReadonlyArray2<'_, f64>>,
) -> PyResult<Input> {
    let points: Vec<DVec2> = rows(points, 2, "points", |r| DVec2::new(r[0], r[1]))?;
    let mut input = Input::points(points);
    if let Some(segments) = segments {
        let ends = rows(segments, 2, "segments", |r| [r[0], r[1]])?;
        let markers: Vec<i64> = match segment_markers {
            Some(m) => m.as_array().to_vec(),
            None => vec![0; ends.len()],
        };
        if markers.len() != ends.len() {
            return Err(QuadmeshError::new_err(format!(
                "{} segment markers for {} segments",
                markers.len(),
                ends.len()
            )));
        }
        for (k, (e, &marker)) in ends.iter().zip(&markers).enumerate() {
            let index = |i: i64| {
                u32::try_from(i)
                    .ok()
                    .filter(|&i| i != u32::MAX)
                    .ok_or_else(|| {
                        QuadmeshError::new_err(format!(
                            "segment {k} names point {i}, which is not an index"
                        ))
                    })
            };
            let marker = i32::try_from(marker).map_err(|_| {
                QuadmeshError::new_err(format!("segment {k}'s marker {marker} is not an i32"))
            })?;
            input.segments.push(Segment {
                ends: [index(e[0])?, index(e[1])?],
                marker,
            });
        }
    }
    if let Some(holes) = holes {
        input.holes = rows(holes, 2, "holes", |r| DVec2::new(r[0], r[1]))?;
    }
    if let Some(regions) = regions {
        // Triangle's layout: x, y, attribute, area bound (none when not positive).
        input.regions = rows(regions, 4, "regions", |r| RegionSeed {
            seed: DVec2::new(r[0], r[1]),
            attribute: r[2],
            max_area: Some(r[3]).filter(|&a| a > 0.0),
        })?;
    }
    Ok(input)
}

/// Meshes on a pool of `threads` threads, or on the global pool.
fn run(
    input: &Input,
    options: &Options,
    threads: Option<usize>,
) -> Result<(Mesh, MeshReport), String> {
    match threads {
        None => quadmesh::mesh(input, options).map_err(|e| message(&e)),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| e.to_string())?
            .install(|| quadmesh::mesh(input, options))
            .map_err(|e| message(&e)),
    }
}

/// The library's message for an error, in the Python call's terms.
fn message(e: &Error) -> String {
    match e {
        Error::InvalidOption { option, message } => format!("{option}: {message}"),
        other => other.to_string(),
    }
}

/// A flat vector of `width`-element rows as an `n × width` numpy array that owns its buffer.
fn matrix<'py, T: numpy::Element>(
    py: Python<'py>,
    flat: Vec<T>,
    width: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let rows = flat.len() / width;
    Ok(flat.into_pyarray(py).reshape([rows, width])?.into_any())
}

/// Rows of three `u32` as one flat vector, without a copy.
fn flatten_triples(v: Vec<[u32; 3]>) -> Vec<u32> {
    let mut v = std::mem::ManuallyDrop::new(v);
    let (ptr, len, capacity) = (v.as_mut_ptr(), v.len(), v.capacity());
    // SAFETY: `[u32; 3]` is three `u32` with no padding and the alignment of `u32`, so the
    // allocation of `capacity` triples is one of `3 * capacity` `u32`, with the same size and
    // alignment, and the first `3 * len` of them are initialised. The original vector is not
    // dropped (`ManuallyDrop`), so the buffer has one owner.
    #[allow(unsafe_code)]
    unsafe {
        Vec::from_raw_parts(ptr.cast::<u32>(), 3 * len, 3 * capacity)
    }
}

/// Points as one flat vector of coordinates, without a copy.
fn flatten_points(v: Vec<DVec2>) -> Vec<f64> {
    let mut v = std::mem::ManuallyDrop::new(v);
    let (ptr, len, capacity) = (v.as_mut_ptr(), v.len(), v.capacity());
    // SAFETY: glam's `DVec2` is `#[repr(C)]` with fields `x, y: f64`: two `f64` with no padding
    // and the alignment of `f64`, so the allocation of `capacity` points is one of
    // `2 * capacity` `f64` of the same size and alignment, the first `2 * len` initialised. The
    // original vector is not dropped, so the buffer has one owner.
    #[allow(unsafe_code)]
    unsafe {
        Vec::from_raw_parts(ptr.cast::<f64>(), 2 * len, 2 * capacity)
    }
}

/// `u32` indices with `NONE` as `i64` with -1.
fn signed(v: impl IntoIterator<Item = u32>) -> Vec<i64> {
    v.into_iter()
        .map(|i| {
            if i == quadmesh::NONE {
                -1
            } else {
                i64::from(i)
            }
        })
        .collect()
}

/// The mesh and its report as a dict of numpy arrays and numbers; its edges only if asked
/// (listing them costs about a tenth of the meshing).
fn mesh_dict<'py>(
    py: Python<'py>,
    mesh: Mesh,
    report: &MeshReport,
    with_edges: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let edges = if with_edges { mesh.edges() } else { Vec::new() };
    let vertex_markers = mesh.vertex_markers();
    let attributes: Vec<f64> = (0..mesh.triangles.len())
        .map(|t| mesh.triangle_attribute(t))
        .collect();
    let has_regions = !mesh.region_attributes.is_empty();
    out.set_item("vertex_markers", vertex_markers.into_pyarray(py))?;
    if with_edges {
        out.set_item(
            "edges",
            matrix(
                py,
                edges.iter().flat_map(|e| e.vertices).collect::<Vec<u32>>(),
                2,
            )?,
        )?;
        out.set_item(
            "edge_markers",
            edges
                .iter()
                .map(|e| e.marker)
                .collect::<Vec<i32>>()
                .into_pyarray(py),
        )?;
    }
    out.set_item(
        "segments",
        matrix(
            py,
            mesh.segments
                .iter()
                .flat_map(|s| s.vertices)
                .collect::<Vec<u32>>(),
            2,
        )?,
    )?;
    out.set_item("segment_markers", mesh.segment_markers().into_pyarray(py))?;
    out.set_item(
        "segment_index",
        mesh.segments
            .iter()
            .map(|s| s.segment)
            .collect::<Vec<u32>>()
            .into_pyarray(py),
    )?;
    if has_regions {
        out.set_item("triangle_attributes", attributes.into_pyarray(py))?;
        out.set_item(
            "triangle_regions",
            signed(mesh.triangle_regions.iter().copied()).into_pyarray(py),
        )?;
    }
    out.set_item(
        "vertex_input",
        signed(mesh.vertex_input.iter().copied()).into_pyarray(py),
    )?;
    out.set_item(
        "neighbors_raw",
        matrix(py, flatten_triples(mesh.neighbours), 3)?,
    )?;
    out.set_item("triangles", matrix(py, flatten_triples(mesh.triangles), 3)?)?;
    out.set_item("vertices", matrix(py, flatten_points(mesh.vertices), 2)?)?;
    let r = PyDict::new(py);
    r.set_item("points", report.points)?;
    r.set_item("duplicates", report.duplicates)?;
    r.set_item("vertices", report.vertices)?;
    r.set_item("triangles", report.triangles)?;
    r.set_item("min_angle", report.min_angle)?;
    r.set_item("max_angle", report.max_angle)?;
    let bounds = report.angle_bounds.map(|b| (b.min_deg, b.max_deg));
    r.set_item("angle_bounds", bounds)?;
    let stages = PyDict::new(py);
    for (stage, d) in &report.stages {
        stages.set_item(*stage, d.as_secs_f64())?;
    }
    r.set_item("stages", stages)?;
    out.set_item("report", r)?;
    Ok(out)
}

/// Meshes a point set or a planar straight-line graph; see the package's `mesh`.
#[pyfunction]
#[pyo3(signature = (
    points, segments=None, segment_markers=None, holes=None, regions=None, *,
    min_angle=20.0, max_area=None, max_vertices=None, mode="delaunay", convex_hull=false,
    no_boundary_steiner=false, split_crossings=false, remove_spare_vertices=false, threads=None,
    edges=false
))]
#[allow(clippy::too_many_arguments)]
fn _mesh<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    segments: Option<PyReadonlyArray2<'py, i64>>,
    segment_markers: Option<PyReadonlyArray1<'py, i64>>,
    holes: Option<PyReadonlyArray2<'py, f64>>,
    regions: Option<PyReadonlyArray2<'py, f64>>,
    min_angle: f64,
    max_area: Option<f64>,
    max_vertices: Option<usize>,
    mode: &str,
    convex_hull: bool,
    no_boundary_steiner: bool,
    split_crossings: bool,
    remove_spare_vertices: bool,
    threads: Option<usize>,
    edges: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let mode = match mode {
        "delaunay" => Mode::Delaunay,
        "warp" => Mode::Warp,
        "compact_warp" => Mode::CompactWarp,
        "block_warp" => Mode::BlockWarp,
        "nonobtuse" => Mode::Nonobtuse,
        "nonobtuse_split" => Mode::NonobtuseSplit,
        other => {
            return Err(QuadmeshError::new_err(format!(
                "mode must be \"delaunay\", \"warp\", \"compact_warp\", \"block_warp\", \"nonobtuse\" or \"nonobtuse_split\", not {other:?}"
            )));
        }
    };
    if threads == Some(0) {
        return Err(QuadmeshError::new_err("threads must be at least 1"));
    }
    let input = input_of(
        &points,
        segments.as_ref(),
        segment_markers.as_ref(),
        holes.as_ref(),
        regions.as_ref(),
    )?;
    let asked = Asked {
        min_angle,
        max_area,
        max_vertices,
        mode,
        convex_hull,
        no_boundary_steiner,
        split_crossings,
        remove_spare_vertices,
    };
    let options = asked.options();
    let (mesh, report) = py
        .detach(|| run(&input, &options, threads))
        .map_err(QuadmeshError::new_err)?;
    mesh_dict(py, mesh, &report, edges)
}

/// A dynamic warped mesh; see the package's `DynamicMesh`.
#[pyclass(name = "_DynamicMesh", module = "quadmesh._quadmesh")]
struct PyDynamicMesh {
    inner: DynamicMesh,
}

/// The library's error as the package's exception.
fn raise(e: &Error) -> PyErr {
    QuadmeshError::new_err(message(e))
}

#[pymethods]
impl PyDynamicMesh {
    /// `block`: keep the block warp's tree (which also gives the nonobtuse split) instead of
    /// the compact warp's.
    #[new]
    #[pyo3(signature = (points, domain, block = false))]
    fn new(
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        domain: (f64, f64, f64, f64),
        block: bool,
    ) -> PyResult<Self> {
        let points = rows(&points, 2, "points", |r| DVec2::new(r[0], r[1]))?;
        let (x0, y0, x1, y1) = domain;
        let domain = Domain {
            lo: DVec2::new(x0, y0),
            hi: DVec2::new(x1, y1),
        };
        let separation = if block {
            Separation::Block
        } else {
            Separation::Corner
        };
        let inner = py
            .detach(|| DynamicMesh::with_separation(&points, domain, separation))
            .map_err(|e| raise(&e))?;
        Ok(PyDynamicMesh { inner })
    }

    fn __len__(&self) -> usize {
        self.inner.len()
    }

    fn insert(&mut self, x: f64, y: f64) -> PyResult<u32> {
        let report = self.inner.insert(DVec2::new(x, y)).map_err(|e| raise(&e))?;
        Ok(report.id)
    }

    fn delete(&mut self, id: i64) -> PyResult<()> {
        self.inner.delete(point_id(id)?).map_err(|e| raise(&e))?;
        Ok(())
    }

    fn move_to(&mut self, id: i64, x: f64, y: f64) -> PyResult<()> {
        self.inner
            .move_to(point_id(id)?, DVec2::new(x, y))
            .map_err(|e| raise(&e))?;
        Ok(())
    }

    fn move_all(
        &mut self,
        py: Python<'_>,
        ids: PyReadonlyArray1<'_, i64>,
        displacements: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<()> {
        let (ids, shifts) = moves(&ids, &displacements)?;
        let inner = &mut self.inner;
        py.detach(|| inner.move_all(&ids, &shifts))
            .map_err(refused_move)?;
        Ok(())
    }

    fn track_changes(&mut self, on: bool) {
        self.inner.track_changes(on);
    }

    /// The triangles taken out and put in since the last call, each as three corners: arrays
    /// of shape (k, 3, 2), and the leaves warped to find them.
    #[pyo3(signature = (nonobtuse = false))]
    fn take_changes<'py>(
        &mut self,
        py: Python<'py>,
        nonobtuse: bool,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, usize)> {
        let inner = &mut self.inner;
        let found = py.detach(|| match nonobtuse {
            true => inner.take_nonobtuse_changes(),
            false => inner.take_changes(),
        });
        changes_arrays(py, found)
    }

    /// The ids of the live points, in increasing order.
    fn live_ids<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        self.inner.live_points().0.into_pyarray(py).into_any()
    }

    /// The warped or nonobtuse mesh, coarsened or not.
    #[pyo3(signature = (nonobtuse = false, coarsen = false))]
    fn mesh<'py>(
        &self,
        py: Python<'py>,
        nonobtuse: bool,
        coarsen: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let inner = &self.inner;
        let meshed = py.detach(|| match (nonobtuse, coarsen) {
            (true, true) => inner.coarsened_nonobtuse_mesh(),
            (true, false) => inner.mesh_nonobtuse(),
            (false, true) => inner.coarsened_mesh(),
            (false, false) => inner.mesh(),
        });
        let mesh = meshed.map_err(|e| raise(&e))?;
        let report = MeshReport {
            points: inner.len(),
            vertices: mesh.vertices.len(),
            triangles: mesh.triangles.len(),
            ..MeshReport::default()
        };
        mesh_dict(py, mesh, &report, false)
    }
}

/// Changes as two arrays of shape (k, 3, 2), the triangles' corners, and the work it took.
#[allow(clippy::type_complexity)]
fn changes_arrays<'py>(
    py: Python<'py>,
    found: Result<TriangleChanges, Error>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, usize)> {
    let changes = found.map_err(|e| raise(&e))?;
    let corners = |triangles: &[[DVec2; 3]]| -> PyResult<Bound<'py, PyAny>> {
        let flat: Vec<f64> = triangles
            .iter()
            .flat_map(|t| t.iter().flat_map(|p| [p.x, p.y]))
            .collect();
        Ok(flat
            .into_pyarray(py)
            .reshape([triangles.len(), 3, 2])?
            .into_any())
    };
    Ok((
        corners(&changes.removed)?,
        corners(&changes.added)?,
        changes.leaves,
    ))
}

/// A dynamic quality Delaunay mesh; see the package's `DynamicDelaunay`.
#[pyclass(name = "_DynamicDelaunay", module = "quadmesh._quadmesh")]
struct PyDynamicDelaunay {
    inner: DynamicDelaunay,
}

#[pymethods]
impl PyDynamicDelaunay {
    #[new]
    #[pyo3(signature = (points, domain, min_angle, max_area = None))]
    fn new(
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        domain: (f64, f64, f64, f64),
        min_angle: f64,
        max_area: Option<f64>,
    ) -> PyResult<Self> {
        let points = rows(&points, 2, "points", |r| DVec2::new(r[0], r[1]))?;
        let (x0, y0, x1, y1) = domain;
        let options = RefineOptions {
            min_angle_deg: min_angle,
            max_area,
            domain: RefineDomain::Rectangle(Domain {
                lo: DVec2::new(x0, y0),
                hi: DVec2::new(x1, y1),
            }),
            ..RefineOptions::default()
        };
        let inner = py
            .detach(|| DynamicDelaunay::new(&points, &options))
            .map_err(|e| raise(&e))?;
        Ok(PyDynamicDelaunay { inner })
    }

    fn __len__(&self) -> usize {
        self.inner.len()
    }

    fn steiner_count(&self) -> usize {
        self.inner.steiner_count()
    }

    fn insert(&mut self, py: Python<'_>, x: f64, y: f64) -> PyResult<u32> {
        let inner = &mut self.inner;
        let report = py.detach(|| inner.insert(DVec2::new(x, y)));
        Ok(report.map_err(|e| raise(&e))?.id)
    }

    fn delete(&mut self, py: Python<'_>, id: i64) -> PyResult<()> {
        let (id, inner) = (point_id(id)?, &mut self.inner);
        py.detach(|| inner.delete(id)).map_err(|e| raise(&e))?;
        Ok(())
    }

    fn move_to(&mut self, py: Python<'_>, id: i64, x: f64, y: f64) -> PyResult<()> {
        let (id, inner) = (point_id(id)?, &mut self.inner);
        py.detach(|| inner.move_to(id, DVec2::new(x, y)))
            .map_err(|e| raise(&e))?;
        Ok(())
    }

    fn move_all(
        &mut self,
        py: Python<'_>,
        ids: PyReadonlyArray1<'_, i64>,
        displacements: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<()> {
        let (ids, shifts) = moves(&ids, &displacements)?;
        if ids.len() != shifts.len() {
            return Err(QuadmeshError::new_err(format!(
                "{} ids but {} displacements",
                ids.len(),
                shifts.len()
            )));
        }
        let mut edits = Vec::with_capacity(ids.len());
        for (k, (&id, &shift)) in ids.iter().zip(&shifts).enumerate() {
            let Some(p) = self.inner.point(id) else {
                return Err(QuadmeshError::new_err(format!(
                    "move {k}: no live point has id {id}"
                )));
            };
            edits.push(Edit::Move(id, p + shift));
        }
        let inner = &mut self.inner;
        py.detach(|| inner.apply(&edits)).map_err(refused_move)?;
        Ok(())
    }

    fn track_changes(&mut self, on: bool) {
        self.inner.track_changes(on);
    }

    /// The triangles taken out and put in since the last call, as `_DynamicMesh` gives them,
    /// and the vertices triangulated to find them.
    #[allow(clippy::type_complexity)]
    fn take_changes<'py>(
        &mut self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, usize)> {
        let inner = &mut self.inner;
        let found = py.detach(|| inner.take_changes());
        changes_arrays(py, found)
    }

    /// The ids of the live points, in increasing order.
    fn live_ids<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        self.inner.live_ids().into_pyarray(py).into_any()
    }

    fn mesh<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let inner = &self.inner;
        let mesh = py.detach(|| inner.mesh()).map_err(|e| raise(&e))?;
        let report = MeshReport {
            points: inner.len(),
            vertices: mesh.vertices.len(),
            triangles: mesh.triangles.len(),
            ..MeshReport::default()
        };
        mesh_dict(py, mesh, &report, false)
    }
}

/// The ids and displacements of a time step.
fn moves(
    ids: &PyReadonlyArray1<'_, i64>,
    displacements: &PyReadonlyArray2<'_, f64>,
) -> PyResult<(Vec<u32>, Vec<DVec2>)> {
    let ids: Vec<u32> = ids
        .as_slice()?
        .iter()
        .map(|&id| point_id(id))
        .collect::<PyResult<_>>()?;
    let shifts = rows(displacements, 2, "displacements", |r| {
        DVec2::new(r[0], r[1])
    })?;
    Ok((ids, shifts))
}

/// The error for move `k` of a time step, refused for `e`.
fn refused_move((k, e): (usize, Error)) -> PyErr {
    QuadmeshError::new_err(format!("move {k}: {}", message(&e)))
}

/// A point id from Python.
fn point_id(id: i64) -> PyResult<u32> {
    u32::try_from(id).map_err(|_| QuadmeshError::new_err(format!("no live point has id {id}")))
}

#[pymodule]
fn _quadmesh(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(_mesh, m)?)?;
    m.add_class::<PyDynamicMesh>()?;
    m.add_class::<PyDynamicDelaunay>()?;
    m.add("QuadmeshError", m.py().get_type::<QuadmeshError>())?;
    m.add("NONE", quadmesh::NONE)?;
    Ok(())
}
