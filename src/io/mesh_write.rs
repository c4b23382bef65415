//! Mesh writers: Triangle's `.node`, `.ele`, `.neigh`, `.edge` and (for a planar straight-line
//! graph) `.poly` files, a VTK `.vtu` file for ParaView, a Gmsh `.msh` 4.1 file and an SVG
//! picture.
//!
//! A mesh of a planar straight-line graph (one with [`Mesh::segments`]) carries its segments'
//! markers and its regions into every format, following Triangle's conventions; a point set's
//! files do not change.
//!
//! As in the other writers, text and binary data are produced in parallel blocks and written in
//! order, and floats use Rust's shortest round-trip form, so the bytes do not depend on the
//! thread count. Every writer flushes `w` at the end; `w` is written in large blocks, but a
//! `BufWriter` still helps with the many short header lines.

use std::collections::{BTreeMap, HashSet};
use std::ffi::OsString;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use glam::DVec2;
use rayon::prelude::*;

use crate::mesh::{
    BoundarySide, EdgeLister, Mesh, NONE, angles_deg, edges_listed_with, opposite_edge,
};
use crate::par::exclusive_scan_by;

/// Items formatted per rayon task.
const BLOCK: usize = 1 << 13;
/// Items formatted before their bytes are written, bounding the memory held at once.
const BATCH: usize = 1 << 20;

/// Writes `item(buf, i)` for every `i` in `0..n`: formatted in parallel blocks, written in order.
fn write_items<W, F>(w: &mut W, n: usize, item: F) -> io::Result<()>
where
    W: Write,
    F: Fn(&mut Vec<u8>, usize) -> io::Result<()> + Sync,
{
    for start in (0..n).step_by(BATCH) {
        let end = (start + BATCH).min(n);
        let blocks: Vec<io::Result<Vec<u8>>> = (0..(end - start).div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let first = start + b * BLOCK;
                let last = (first + BLOCK).min(end);
                let mut buf = Vec::with_capacity((last - first) * 48);
                (first..last).try_for_each(|i| item(&mut buf, i))?;
                Ok(buf)
            })
            .collect();
        for block in blocks {
            w.write_all(&block?)?;
        }
    }
    Ok(())
}

/// Appends `fields` in decimal, separated by spaces, and a newline. Lines of integers are most of
/// the Triangle and Gmsh output, and this is about twice as fast as `write!`.
fn push_line(buf: &mut Vec<u8>, fields: &[i64]) {
    for (k, &field) in fields.iter().enumerate() {
        if k > 0 {
            buf.push(b' ');
        }
        push_decimal(buf, field);
    }
    buf.push(b'\n');
}

/// Appends `value` in decimal.
fn push_decimal(buf: &mut Vec<u8>, value: i64) {
    if value < 0 {
        buf.push(b'-');
    }
    let mut digits = [0u8; 20];
    let mut rest = value.unsigned_abs();
    let mut at = digits.len();
    loop {
        at -= 1;
        digits[at] = b'0' + (rest % 10) as u8;
        rest /= 10;
        if rest == 0 {
            break;
        }
    }
    buf.extend_from_slice(&digits[at..]);
}

/// The 1-based number of a vertex or triangle in Triangle's and Gmsh's files, or -1 for [`NONE`].
fn number(index: u32) -> i64 {
    if index == NONE {
        -1
    } else {
        i64::from(index) + 1
    }
}

/// The input index of vertex `v`, or -1 for a Steiner vertex.
fn input_index(mesh: &Mesh, v: usize) -> i64 {
    mesh.input_index(v as u32).map_or(-1, i64::from)
}

/// Writes the vertices as a Triangle `.node` file: the header `<#vertices> 2 1 1`, then
/// `<vertex> <x> <y> <input index> <marker>` per vertex, numbered from 1 as in Triangle's own
/// output. The attribute is the vertex's 0-based input index, or -1 for a Steiner vertex; the
/// boundary marker is [`Mesh::vertex_markers`]'s: 0 inside, and on the boundary the marker of
/// the boundary edge that starts at the vertex (on a rectangle its side, 1 to 4, so a corner
/// gets the side that leaves it counter-clockwise; on the hull 1). In a mesh of a planar
/// straight-line graph a vertex on segments gets the first nonzero marker among theirs, and
/// one on the boundary without such a marker 1 (Triangle's convention). A comment line before
/// the header says so.
///
/// # Errors
/// Whatever `w` returns.
pub fn write_node<W: Write>(mesh: &Mesh, mut w: W) -> io::Result<()> {
    let markers = mesh.vertex_markers();
    writeln!(
        w,
        "# vertex (numbered from 1), x, y, input index (0-based, -1 for none), boundary marker"
    )?;
    writeln!(w, "{} 2 1 1", mesh.vertices.len())?;
    write_items(&mut w, mesh.vertices.len(), |buf, v| {
        let p = mesh.vertices[v];
        let marker = markers[v];
        let input = input_index(mesh, v);
        writeln!(buf, "{} {} {} {input} {marker}", v + 1, p.x, p.y)
    })?;
    w.flush()
}

/// Writes the triangles as a Triangle `.ele` file: the header `<#triangles> 3 0`, then
/// `<triangle> <v0> <v1> <v2>` per triangle, counter-clockwise, all numbered from 1 as in
/// [`write_node`].
///
/// A mesh with regions ([`Mesh::region_attributes`] not empty) has one attribute per triangle,
/// as `triangle -A` writes it: the header `<#triangles> 3 1` and
/// `<triangle> <v0> <v1> <v2> <attribute>`, the attribute [`Mesh::triangle_attribute`]'s (0
/// outside every region).
///
/// # Errors
/// Whatever `w` returns.
pub fn write_ele<W: Write>(mesh: &Mesh, mut w: W) -> io::Result<()> {
    let comment = "# triangle, its vertices counter-clockwise (all numbered from 1)";
    let triangles = mesh.triangles.len();
    if mesh.region_attributes.is_empty() {
        let header = format!("{triangles} 3 0");
        return write_triples(w, comment, &header, &mesh.triangles);
    }
    writeln!(w, "{comment}, regional attribute (0 outside every region)")?;
    writeln!(w, "{triangles} 3 1")?;
    write_items(&mut w, triangles, |buf, t| {
        let [a, b, c] = mesh.triangles[t].map(number);
        let attribute = mesh.triangle_attribute(t);
        writeln!(buf, "{} {a} {b} {c} {attribute}", t + 1)
    })?;
    w.flush()
}

/// Writes a comment line, a header line, then `<i> <a> <b> <c>` per triple, numbered from 1.
fn write_triples<W: Write>(
    mut w: W,
    comment: &str,
    header: &str,
    triples: &[[u32; 3]],
) -> io::Result<()> {
    writeln!(w, "{comment}")?;
    writeln!(w, "{header}")?;
    write_items(&mut w, triples.len(), |buf, t| {
        let [a, b, c] = triples[t].map(number);
        push_line(buf, &[t as i64 + 1, a, b, c]);
        Ok(())
    })?;
    w.flush()
}

/// Writes the neighbours as a Triangle `.neigh` file: the header `<#triangles> 3`, then
/// `<triangle> <n0> <n1> <n2>` per triangle, where neighbour `i` lies across the edge opposite
/// corner `i` (Triangle's convention), -1 on the boundary; numbered from 1 as in [`write_ele`].
///
/// # Errors
/// Whatever `w` returns.
pub fn write_neigh<W: Write>(mesh: &Mesh, w: W) -> io::Result<()> {
    let comment =
        "# triangle, the triangles across from its corners (numbered from 1, -1 for none)";
    let header = format!("{} 3", mesh.triangles.len());
    write_triples(w, comment, &header, &mesh.neighbours)
}

/// Writes every edge of the mesh once as a Triangle `.edge` file: the header `<#edges> 1`, then
/// `<edge> <v0> <v1> <marker>` per edge, where the marker is the boundary edge's marker (on a
/// rectangle its [`BoundarySide`] value, 1 to 4; with a [`Mesh::outline`], 1) and 0 for an
/// interior edge; numbered from 1 as in [`write_node`]. In a mesh of a planar straight-line
/// graph an edge on a segment carries the segment's marker, except that one on the boundary
/// whose segment's marker is 0 carries 1 like the other boundary edges (Triangle's
/// convention). The comment line before the header says which.
///
/// The edges are those of [`Mesh::edges`], in its order: by triangle, then by the corner they
/// are opposite; an interior edge is listed with the lower-numbered of its two triangles, in that
/// triangle's counter-clockwise direction.
///
/// # Errors
/// Whatever `w` returns.
pub fn write_edge<W: Write>(mesh: &Mesh, mut w: W) -> io::Result<()> {
    let lister = EdgeLister::new(mesh);
    let triangles = mesh.triangles.len();
    // The 0-based number of each triangle's first edge, and the edge count after the last.
    let first_edge = exclusive_scan_by(triangles, |t| edges_listed_with(mesh, t));
    let markers = if !mesh.segments.is_empty() {
        "marker (its segment's, 1 if that is 0 on the boundary; else 1 boundary, 0 interior)"
    } else if mesh.outline.is_some() {
        "boundary marker (1 boundary, 0 interior)"
    } else {
        "side marker (1 bottom, 2 right, 3 top, 4 left, 0 interior)"
    };
    writeln!(w, "# edge (numbered from 1), its vertices, {markers}")?;
    writeln!(w, "{} 1", first_edge[triangles])?;
    write_items(&mut w, triangles, |buf, t| {
        for (k, edge) in lister.edges_of(t).enumerate() {
            let [a, b] = edge.vertices.map(number);
            let id = (first_edge[t] + k + 1) as i64;
            push_line(buf, &[id, a, b, i64::from(edge.marker)]);
        }
        Ok(())
    })?;
    w.flush()
}

/// Writes the subsegments and hole seeds of a planar straight-line graph's mesh as a Triangle
/// `.poly` file, as `triangle -p` writes its output:
/// - the header `0 2 1 1`: no vertices here, since they are those of the `.node` file
///   [`write_node`] writes (2 dimensions, its 1 attribute and its markers);
/// - `<#subsegments> 1`, then `<subsegment> <v0> <v1> <marker>` per subsegment in the order of
///   [`Mesh::segments`], its vertices numbered from 1 as in the `.node` file, the marker
///   [`Mesh::segment_markers`]'s (its segment's, or 1 on the boundary for a 0);
/// - `<#holes>`, then `<hole> <x> <y>` per hole seed;
/// - a region count of 0: the mesh does not keep the region seeds (its regional attributes
///   are in the `.ele` file).
///
/// Comment lines say which section is which. A point set's mesh gives a file with no
/// subsegments and no holes.
///
/// # Errors
/// Whatever `w` returns.
pub fn write_poly<W: Write>(mesh: &Mesh, mut w: W) -> io::Result<()> {
    writeln!(w, "# no vertices: they are in the .node file")?;
    writeln!(w, "0 2 1 1")?;
    writeln!(
        w,
        "# subsegment (numbered from 1), its vertices, boundary marker"
    )?;
    writeln!(w, "{} 1", mesh.segments.len())?;
    let markers = mesh.segment_markers();
    write_items(&mut w, mesh.segments.len(), |buf, s| {
        let [a, b] = mesh.segments[s].vertices.map(number);
        push_line(buf, &[s as i64 + 1, a, b, i64::from(markers[s])]);
        Ok(())
    })?;
    writeln!(w, "# hole (numbered from 1), a point in it")?;
    writeln!(w, "{}", mesh.holes.len())?;
    for (k, p) in mesh.holes.iter().enumerate() {
        writeln!(w, "{} {} {}", k + 1, p.x, p.y)?;
    }
    writeln!(
        w,
        "# no regions: the regional attributes are in the .ele file"
    )?;
    writeln!(w, "0")?;
    w.flush()
}

/// A writer of one of Triangle's files.
type TriangleFileWriter = fn(&Mesh, BufWriter<File>) -> io::Result<()>;

/// Writes `PREFIX.node`, `PREFIX.ele`, `PREFIX.neigh` and `PREFIX.edge` (see [`write_node`],
/// [`write_ele`], [`write_neigh`] and [`write_edge`]), and for a mesh with
/// [`Mesh::segments`] also `PREFIX.poly` ([`write_poly`]), and returns their paths in that
/// order. The extensions are appended to `prefix`, never substituted for one it has.
///
/// # Errors
/// The first failure to create or write a file, naming the file.
pub fn write_triangle_files(mesh: &Mesh, prefix: &Path) -> io::Result<Vec<PathBuf>> {
    let mut files: Vec<(&str, TriangleFileWriter)> = vec![
        ("node", write_node),
        ("ele", write_ele),
        ("neigh", write_neigh),
        ("edge", write_edge),
    ];
    if !mesh.segments.is_empty() {
        files.push(("poly", write_poly));
    }
    files
        .into_iter()
        .map(|(extension, write)| {
            let path = with_extension_appended(prefix, extension);
            let named = |e: io::Error| io::Error::new(e.kind(), format!("{}: {e}", path.display()));
            let file = File::create(&path).map_err(named)?;
            write(mesh, BufWriter::with_capacity(1 << 20, file)).map_err(named)?;
            Ok(path)
        })
        .collect()
}

/// `prefix` with `.extension` appended (`mesh.1` → `mesh.1.node`; `Path::with_extension` would
/// replace the `.1`).
pub fn with_extension_appended(prefix: &Path, extension: &str) -> PathBuf {
    let mut name = OsString::from(prefix.as_os_str());
    name.push(".");
    name.push(extension);
    PathBuf::from(name)
}

/// The VTK cell type of a linear triangle.
const VTK_TRIANGLE: u8 = 5;

/// Writes the mesh as a VTK XML UnstructuredGrid (`.vtu`) file for ParaView and other VTK
/// readers. The arrays follow the XML header as raw little-endian binary in an
/// `<AppendedData encoding="raw">` block, each preceded by its byte length as a UInt64, so that
/// files of tens of millions of triangles write and load quickly:
/// - the points (Float64, `x y 0`) and the triangles (Int64 `connectivity`, Int64 `offsets`,
///   UInt8 `types`, all VTK_TRIANGLE);
/// - point data `input_index` (Int64): the vertex's 0-based input index, or -1 for a Steiner
///   vertex;
/// - cell data `min_angle` (Float64): the triangle's smallest angle in degrees.
///
/// A mesh of a planar straight-line graph (one with [`Mesh::segments`]) also has point data
/// `marker` (Int32), [`Mesh::vertex_markers`]'s as in the `.node` file; one with regions also
/// has cell data `region` (Int32), the triangle's 0-based region or -1 outside every region,
/// and `attribute` (Float64), its regional attribute as in the `.ele` file.
///
/// # Errors
/// Whatever `w` returns.
pub fn write_vtu<W: Write>(mesh: &Mesh, mut w: W) -> io::Result<()> {
    let sections = vtu_sections(mesh);
    let arrays = || sections.iter().flat_map(|s| &s.arrays);
    // Each array's place in the appended data, after its predecessors and their lengths.
    let mut offsets = Vec::new();
    let mut at = 0;
    for array in arrays() {
        offsets.push(at);
        at += 8 + array.length();
    }
    write_vtu_header(&mut w, mesh, &sections, &offsets)?;
    for array in arrays() {
        w.write_all(&array.length().to_le_bytes())?;
        write_items(&mut w, array.count, |buf, i| {
            (array.item)(buf, i);
            Ok(())
        })?;
    }
    w.write_all(b"\n  </AppendedData>\n</VTKFile>\n")?;
    w.flush()
}

/// Appends the bytes of an array's item `i` to a buffer.
type VtuItem<'a> = Box<dyn Fn(&mut Vec<u8>, usize) + Sync + 'a>;

/// One appended array of a `.vtu` file.
struct VtuArray<'a> {
    /// Its VTK type (`Int64`, `Float64`, ...).
    vtk_type: &'static str,
    name: &'static str,
    /// Components per item, when more than one.
    components: Option<usize>,
    /// The number of items and the bytes of each.
    count: usize,
    item_bytes: usize,
    /// Appends item `i`'s bytes.
    item: VtuItem<'a>,
}

impl VtuArray<'_> {
    /// Its byte length.
    fn length(&self) -> u64 {
        (self.count * self.item_bytes) as u64
    }
}

/// One element of a `.vtu` piece (`PointData`, `CellData`, `Points`, `Cells`) and its arrays.
struct VtuSection<'a> {
    tag: &'static str,
    /// The name of its active scalars, if it says one.
    scalars: Option<&'static str>,
    arrays: Vec<VtuArray<'a>>,
}

/// An array of `count` items of `item_bytes` bytes each, with one component.
fn vtu_array<'a>(
    vtk_type: &'static str,
    name: &'static str,
    count: usize,
    item_bytes: usize,
    item: impl Fn(&mut Vec<u8>, usize) + Sync + 'a,
) -> VtuArray<'a> {
    VtuArray {
        vtk_type,
        name,
        components: None,
        count,
        item_bytes,
        item: Box::new(item),
    }
}

/// The sections of a `.vtu` file of `mesh`, in the order their arrays are appended.
fn vtu_sections(mesh: &Mesh) -> [VtuSection<'_>; 4] {
    let (vertices, triangles) = (mesh.vertices.len(), mesh.triangles.len());
    let mut point_data = vec![vtu_array("Int64", "input_index", vertices, 8, |buf, i| {
        buf.extend_from_slice(&input_index(mesh, i).to_le_bytes());
    })];
    if !mesh.segments.is_empty() {
        let markers = mesh.vertex_markers();
        point_data.push(vtu_array("Int32", "marker", vertices, 4, move |buf, i| {
            buf.extend_from_slice(&markers[i].to_le_bytes());
        }));
    }
    let mut cell_data = vec![vtu_array("Float64", "min_angle", triangles, 8, |buf, i| {
        buf.extend_from_slice(&min_angle(mesh, i).to_le_bytes());
    })];
    if !mesh.region_attributes.is_empty() {
        cell_data.push(vtu_array("Int32", "region", triangles, 4, |buf, i| {
            buf.extend_from_slice(&region_number(mesh, i).to_le_bytes());
        }));
        cell_data.push(vtu_array("Float64", "attribute", triangles, 8, |buf, i| {
            buf.extend_from_slice(&mesh.triangle_attribute(i).to_le_bytes());
        }));
    }
    let points = VtuArray {
        components: Some(3),
        ..vtu_array("Float64", "Points", vertices, 24, |buf, i| {
            let p = mesh.vertices[i];
            for x in [p.x, p.y, 0.0] {
                buf.extend_from_slice(&x.to_le_bytes());
            }
        })
    };
    let cells = vec![
        vtu_array("Int64", "connectivity", triangles, 24, |buf, i| {
            for v in mesh.triangles[i] {
                buf.extend_from_slice(&i64::from(v).to_le_bytes());
            }
        }),
        vtu_array("Int64", "offsets", triangles, 8, |buf, i| {
            buf.extend_from_slice(&(3 * (i as i64 + 1)).to_le_bytes());
        }),
        vtu_array("UInt8", "types", triangles, 1, |buf, _| {
            buf.push(VTK_TRIANGLE);
        }),
    ];
    let section = |tag, scalars, arrays| VtuSection {
        tag,
        scalars,
        arrays,
    };
    [
        section("PointData", Some("input_index"), point_data),
        section("CellData", Some("min_angle"), cell_data),
        section("Points", None, vec![points]),
        section("Cells", None, cells),
    ]
}

/// The smallest angle of triangle `t`, degrees.
fn min_angle(mesh: &Mesh, t: usize) -> f64 {
    let [a, b, c] = mesh.triangles[t].map(|v| mesh.vertices[v as usize]);
    let [x, y, z] = angles_deg(a, b, c);
    x.min(y).min(z)
}

/// The 0-based region of triangle `t`, or -1 outside every region.
fn region_number(mesh: &Mesh, t: usize) -> i32 {
    match mesh.triangle_regions.get(t) {
        Some(&r) if r != NONE => r as i32,
        _ => -1,
    }
}

/// The XML of a `.vtu` file up to and including the `_` that starts the appended data, in
/// which the arrays of `sections` start at `offsets`.
fn write_vtu_header<W: Write>(
    w: &mut W,
    mesh: &Mesh,
    sections: &[VtuSection],
    offsets: &[u64],
) -> io::Result<()> {
    let (vertices, triangles) = (mesh.vertices.len(), mesh.triangles.len());
    write!(
        w,
        r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">
  <UnstructuredGrid>
    <Piece NumberOfPoints="{vertices}" NumberOfCells="{triangles}">
"#
    )?;
    let mut offsets = offsets.iter();
    for section in sections {
        let scalars = section
            .scalars
            .map_or(String::new(), |s| format!(r#" Scalars="{s}""#));
        writeln!(w, "      <{}{scalars}>", section.tag)?;
        for (array, offset) in section.arrays.iter().zip(&mut offsets) {
            let components = array
                .components
                .map_or(String::new(), |n| format!(r#" NumberOfComponents="{n}""#));
            writeln!(
                w,
                r#"        <DataArray type="{}" Name="{}"{components} format="appended" offset="{offset}"/>"#,
                array.vtk_type, array.name
            )?;
        }
        writeln!(w, "      </{}>", section.tag)?;
    }
    write!(
        w,
        r#"    </Piece>
  </UnstructuredGrid>
  <AppendedData encoding="raw">
   _"#
    )
}

/// The sides in marker order, with the names the `.msh` file gives their physical groups.
const SIDES: [(BoundarySide, &str); 4] = [
    (BoundarySide::Bottom, "bottom"),
    (BoundarySide::Right, "right"),
    (BoundarySide::Top, "top"),
    (BoundarySide::Left, "left"),
];

/// Writes the mesh as a Gmsh MSH 4.1 ASCII file.
///
/// On a rectangle (no [`Mesh::outline`]) the geometry is the domain: four corner points (entity
/// tags 1 to 4, from the lower-left corner counter-clockwise), four curves, one per side, whose
/// entity and physical tags are the [`BoundarySide`] markers (1 bottom, 2 right, 3 top, 4 left,
/// named in `$PhysicalNames`), and one surface with entity and physical tag 1 (`"domain"`).
/// Elements are the boundary edges as 2-node lines (type 1) on their side's curve, tagged from 1
/// side by side in boundary order.
///
/// With an outline, the boundary is one closed curve: no point entities, one curve with entity
/// and physical tag 1 (`"boundary"`), the outline's bounding box ([`Mesh::domain`]) and no
/// bounding points, and the surface (entity and physical tag 1, `"domain"`) bounded by it. The
/// outline is not split into one curve per side, since the Steiner vertices refinement puts on
/// its sides are rounded and need not lie exactly on them. Elements are all boundary edges as
/// 2-node lines on that curve, in one block, tagged from 1 in boundary order.
///
/// In both cases all vertices are nodes of the surface, tagged 1 to V in vertex order, and the
/// triangles (type 2, counter-clockwise) follow the lines on the surface, tagged on from the
/// last line in triangle order.
///
/// A mesh of a planar straight-line graph (one with [`Mesh::segments`]) has no point entities
/// and a curve and a physical group per marker that the `.edge` file gives an edge on a
/// segment or on the boundary, in increasing marker order: its elements are the subsegments
/// with that marker (see [`Mesh::segment_markers`]), in their order and direction, then the
/// boundary edges on no segment with it. A positive marker is its group's physical tag; since
/// Gmsh's physical tags are positive, marker 0 (interior segments) and negative markers take
/// the tags after the largest positive marker, in increasing marker order. Each group is named
/// `marker <m>`, which records that choice. Its surfaces are one per region with triangles,
/// physical tag the region's number from 1 (its index in [`Mesh::region_attributes`] plus 1),
/// named `region <k>, attribute <a>`, and one of the triangles outside every region, physical
/// tag one past the last region's, named `outside regions`; or, without regions, one surface
/// of all triangles with physical tag 1 named `domain`. Entity tags count from 1 per dimension
/// in that order; each entity has its elements' bounding box and no bounding entities. The
/// nodes are as above; the elements are a block of lines per curve, then a block of triangles
/// per surface (counter-clockwise, in triangle order within it), tagged from 1 in that order.
///
/// # Errors
/// Whatever `w` returns.
pub fn write_msh<W: Write>(mesh: &Mesh, mut w: W) -> io::Result<()> {
    writeln!(w, "$MeshFormat\n4.1 0 8\n$EndMeshFormat")?;
    if !mesh.segments.is_empty() {
        write_msh_graph(&mut w, mesh)?;
        return w.flush();
    }
    if mesh.outline.is_some() {
        writeln!(w, "$PhysicalNames\n2\n1 1 \"boundary\"")?;
    } else {
        writeln!(w, "$PhysicalNames\n{}", SIDES.len() + 1)?;
        for (side, name) in SIDES {
            writeln!(w, "1 {} \"{name}\"", side as u8)?;
        }
    }
    writeln!(w, "2 1 \"domain\"\n$EndPhysicalNames")?;
    if mesh.outline.is_some() {
        write_msh_outline_entities(&mut w, mesh)?;
    } else {
        write_msh_entities(&mut w, mesh)?;
    }
    write_msh_nodes(&mut w, mesh)?;
    write_msh_elements(&mut w, mesh)?;
    w.flush()
}

/// The `$Entities` section of a rectangle: its corners, sides and interior.
fn write_msh_entities<W: Write>(w: &mut W, mesh: &Mesh) -> io::Result<()> {
    let (lo, hi) = (mesh.domain.lo, mesh.domain.hi);
    let corners = [lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)];
    writeln!(w, "$Entities\n4 4 1 0")?;
    for (tag, p) in (1..).zip(corners) {
        writeln!(w, "{tag} {} {} 0 0", p.x, p.y)?;
    }
    // Side k runs from corner k to corner k + 1; the end point's tag is negated, as Gmsh does.
    for (k, (side, _)) in SIDES.into_iter().enumerate() {
        let (a, b) = (corners[k], corners[(k + 1) % 4]);
        let (min, max) = (a.min(b), a.max(b));
        let tag = side as u8;
        let (start, end) = (k + 1, (k + 1) % 4 + 1);
        writeln!(
            w,
            "{tag} {} {} 0 {} {} 0 1 {tag} 2 {start} -{end}",
            min.x, min.y, max.x, max.y
        )?;
    }
    writeln!(
        w,
        "1 {} {} 0 {} {} 0 1 1 4 1 2 3 4\n$EndEntities",
        lo.x, lo.y, hi.x, hi.y
    )
}

/// The `$Entities` section of an outline mesh: one closed boundary curve and the surface inside.
fn write_msh_outline_entities<W: Write>(w: &mut W, mesh: &Mesh) -> io::Result<()> {
    let (lo, hi) = (mesh.domain.lo, mesh.domain.hi);
    let bounds = format!("{} {} 0 {} {} 0", lo.x, lo.y, hi.x, hi.y);
    writeln!(w, "$Entities\n0 1 1 0")?;
    writeln!(w, "1 {bounds} 1 1 0")?;
    writeln!(w, "1 {bounds} 1 1 1 1\n$EndEntities")
}

/// The `$Nodes` section: one block of all vertices on the surface.
fn write_msh_nodes<W: Write>(w: &mut W, mesh: &Mesh) -> io::Result<()> {
    let n = mesh.vertices.len();
    writeln!(w, "$Nodes")?;
    if n == 0 {
        writeln!(w, "0 0 0 0")?;
    } else {
        writeln!(w, "1 {n} 1 {n}\n2 1 0 {n}")?;
        write_items(w, n, |buf, v| {
            push_line(buf, &[v as i64 + 1]);
            Ok(())
        })?;
        write_items(w, n, |buf, v| {
            let p = mesh.vertices[v];
            writeln!(buf, "{} {} 0", p.x, p.y)
        })?;
    }
    writeln!(w, "$EndNodes")
}

/// The `$Elements` section: a block of lines per curve that has boundary edges (per side on a
/// rectangle, all of them on an outline's one curve), then a block of the triangles.
fn write_msh_elements<W: Write>(w: &mut W, mesh: &Mesh) -> io::Result<()> {
    let sides: Vec<(usize, Vec<[u32; 2]>)> = if mesh.outline.is_some() {
        vec![(1, mesh.boundary.iter().map(|e| e.vertices).collect())]
    } else {
        SIDES
            .iter()
            .map(|&(side, _)| {
                let edges = mesh.boundary.iter().filter(|e| e.marker == side.marker());
                (side as usize, edges.map(|e| e.vertices).collect())
            })
            .collect()
    };
    let curves: Vec<(usize, &[[u32; 2]])> = sides.iter().map(|(s, e)| (*s, &e[..])).collect();
    write_msh_element_blocks(w, &curves, &[(1, &mesh.triangles)])
}

/// The `$Elements` section of lines on `curves` and triangles on `surfaces`, each given by its
/// entity tag and elements: a block per entity with elements, tagged from 1 in that order.
fn write_msh_element_blocks<W: Write>(
    w: &mut W,
    curves: &[(usize, &[[u32; 2]])],
    surfaces: &[(usize, &[[u32; 3]])],
) -> io::Result<()> {
    let curves: Vec<_> = curves.iter().filter(|(_, e)| !e.is_empty()).collect();
    let surfaces: Vec<_> = surfaces.iter().filter(|(_, e)| !e.is_empty()).collect();
    let lines: usize = curves.iter().map(|(_, e)| e.len()).sum();
    let triangles: usize = surfaces.iter().map(|(_, e)| e.len()).sum();
    let blocks = curves.len() + surfaces.len();
    let total = lines + triangles;
    writeln!(w, "$Elements\n{blocks} {total} {} {total}", total.min(1))?;
    let mut next_tag = 1;
    for (entity, elements) in curves {
        write_msh_block(w, *entity, elements, next_tag)?;
        next_tag += elements.len();
    }
    for (entity, elements) in surfaces {
        write_msh_block(w, *entity, elements, next_tag)?;
        next_tag += elements.len();
    }
    writeln!(w, "$EndElements")
}

/// One block of elements of `N` nodes (2: lines, type 1, on a curve; 3: triangles, type 2, on
/// a surface) on entity `entity`, tagged from `first_tag`.
fn write_msh_block<W: Write, const N: usize>(
    w: &mut W,
    entity: usize,
    elements: &[[u32; N]],
    first_tag: usize,
) -> io::Result<()> {
    // The entity's dimension and Gmsh's element type are both N - 1.
    writeln!(w, "{} {entity} {} {}", N - 1, N - 1, elements.len())?;
    write_items(w, elements.len(), |buf, e| {
        let mut fields = [0; 4];
        fields[0] = (first_tag + e) as i64;
        for (field, &v) in fields[1..].iter_mut().zip(&elements[e]) {
            *field = number(v);
        }
        push_line(buf, &fields[..=N]);
        Ok(())
    })
}

/// A physical group of a planar straight-line graph's `.msh` file: one entity and its elements
/// of `N` nodes.
struct MshGroup<const N: usize> {
    physical: i64,
    name: String,
    elements: Vec<[u32; N]>,
}

/// The `.msh` sections after `$MeshFormat` of a planar straight-line graph's mesh (see
/// [`write_msh`]).
fn write_msh_graph<W: Write>(w: &mut W, mesh: &Mesh) -> io::Result<()> {
    let curves = msh_marker_curves(mesh);
    let surfaces = msh_region_surfaces(mesh);
    writeln!(w, "$PhysicalNames\n{}", curves.len() + surfaces.len())?;
    let names = curves.iter().map(|g| (1, g.physical, &g.name));
    for (dim, physical, name) in names.chain(surfaces.iter().map(|g| (2, g.physical, &g.name))) {
        writeln!(w, "{dim} {physical} \"{name}\"")?;
    }
    writeln!(w, "$EndPhysicalNames")?;
    writeln!(w, "$Entities\n0 {} {} 0", curves.len(), surfaces.len())?;
    write_msh_group_entities(w, mesh, &curves)?;
    write_msh_group_entities(w, mesh, &surfaces)?;
    writeln!(w, "$EndEntities")?;
    write_msh_nodes(w, mesh)?;
    write_msh_element_blocks(w, &msh_blocks(&curves), &msh_blocks(&surfaces))
}

/// The entity lines of `groups`, tagged from 1: bounding box, physical tag, no bounding entities.
fn write_msh_group_entities<W: Write, const N: usize>(
    w: &mut W,
    mesh: &Mesh,
    groups: &[MshGroup<N>],
) -> io::Result<()> {
    for (tag, group) in (1..).zip(groups) {
        let (lo, hi) = if group.elements.is_empty() {
            (mesh.domain.lo, mesh.domain.hi)
        } else {
            let points = group.elements.iter().flatten();
            let empty = (DVec2::INFINITY, DVec2::NEG_INFINITY);
            points.fold(empty, |(lo, hi), &v| {
                let p = mesh.vertices[v as usize];
                (lo.min(p), hi.max(p))
            })
        };
        let physical = group.physical;
        writeln!(
            w,
            "{tag} {} {} 0 {} {} 0 1 {physical} 0",
            lo.x, lo.y, hi.x, hi.y
        )?;
    }
    Ok(())
}

/// The element blocks of `groups`, their entities tagged from 1.
fn msh_blocks<const N: usize>(groups: &[MshGroup<N>]) -> Vec<(usize, &[[u32; N]])> {
    (1..)
        .zip(groups)
        .map(|(tag, g)| (tag, &g.elements[..]))
        .collect()
}

/// The curves of a planar straight-line graph's `.msh` file, one per marker, in increasing
/// marker order, with their physical tags (see [`write_msh`]).
fn msh_marker_curves(mesh: &Mesh) -> Vec<MshGroup<2>> {
    let mut by_marker: BTreeMap<i32, Vec<[u32; 2]>> = BTreeMap::new();
    for (s, marker) in mesh.segments.iter().zip(mesh.segment_markers()) {
        by_marker.entry(marker).or_default().push(s.vertices);
    }
    let on_segment: HashSet<[u32; 2]> = mesh
        .segments
        .iter()
        .map(|s| undirected(s.vertices))
        .collect();
    for e in &mesh.boundary {
        if !on_segment.contains(&undirected(e.vertices)) {
            by_marker.entry(e.marker).or_default().push(e.vertices);
        }
    }
    let top = by_marker.keys().max().map_or(0, |&m| i64::from(m.max(0)));
    // The markers up to 0 come first, so `rank` counts them.
    (by_marker.into_iter().zip(1..))
        .map(|((marker, elements), rank)| MshGroup {
            physical: if marker > 0 {
                i64::from(marker)
            } else {
                top + rank
            },
            name: format!("marker {marker}"),
            elements,
        })
        .collect()
}

/// The surfaces of a planar straight-line graph's `.msh` file: one per region with triangles
/// and one of those outside every region, or one of all triangles (see [`write_msh`]).
fn msh_region_surfaces(mesh: &Mesh) -> Vec<MshGroup<3>> {
    let regions = mesh.region_attributes.len();
    if regions == 0 || mesh.triangles.is_empty() {
        let elements = mesh.triangles.clone();
        let name = "domain".to_string();
        return vec![MshGroup {
            physical: 1,
            name,
            elements,
        }];
    }
    let mut by_region = vec![Vec::new(); regions + 1];
    for (t, &triangle) in mesh.triangles.iter().enumerate() {
        let r = usize::try_from(region_number(mesh, t)).unwrap_or(regions);
        by_region[r].push(triangle);
    }
    let name = |r: usize| match mesh.region_attributes.get(r) {
        Some(a) => format!("region {}, attribute {a}", r + 1),
        None => "outside regions".to_string(),
    };
    (by_region.into_iter().enumerate())
        .filter(|(_, elements)| !elements.is_empty())
        .map(|(r, elements)| MshGroup {
            physical: r as i64 + 1,
            name: name(r),
            elements,
        })
        .collect()
}

/// An edge's two vertices, the lower first: the same for both directions.
fn undirected([a, b]: [u32; 2]) -> [u32; 2] {
    [a.min(b), a.max(b)]
}

/// Width of the SVG picture, pixels.
const SVG_WIDTH: f64 = 1000.0;

/// What an SVG picture shows: the triangles drawn and the region in view.
struct SvgView {
    /// Which triangles are drawn; `None` when all are.
    keep: Option<Vec<bool>>,
    /// How many triangles are drawn.
    shown: usize,
    /// Lower-left corner of the region in view, before the margin.
    lo: DVec2,
    /// Upper-right corner of the region in view, before the margin.
    hi: DVec2,
}

impl SvgView {
    /// All of `mesh` when it has at most `max_triangles` triangles; otherwise the triangles whose
    /// bounding boxes meet the smallest window, centred on the domain and of its shape, that
    /// holds `max_triangles` of them (a few more on ties), and that window.
    fn new(mesh: &Mesh, max_triangles: usize) -> SvgView {
        let (lo, hi) = (mesh.domain.lo, mesh.domain.hi);
        let triangles = mesh.triangles.len();
        if triangles <= max_triangles {
            return SvgView {
                keep: None,
                shown: triangles,
                lo,
                hi,
            };
        }
        if max_triangles == 0 {
            let keep = Some(vec![false; triangles]);
            return SvgView {
                keep,
                shown: 0,
                lo,
                hi,
            };
        }
        let centre = (lo + hi) / 2.0;
        let half = ((hi - lo) / 2.0).max(DVec2::splat(f64::MIN_POSITIVE));
        let reach: Vec<f64> = (0..triangles)
            .into_par_iter()
            .map(|t| window_reach(mesh, t, centre, half))
            .collect();
        let mut sorted = reach.clone();
        let (_, &mut limit, _) = sorted.select_nth_unstable_by(max_triangles - 1, f64::total_cmp);
        let keep: Vec<bool> = reach.par_iter().map(|&r| r <= limit).collect();
        let shown = keep.par_iter().filter(|&&k| k).count();
        let (lo, hi) = if limit > 0.0 {
            (centre - half * limit, centre + half * limit)
        } else {
            // Every kept triangle touches the centre: show them whole.
            kept_bounds(mesh, &keep)
        };
        SvgView {
            keep: Some(keep),
            shown,
            lo,
            hi,
        }
    }

    fn keeps(&self, t: usize) -> bool {
        self.keep.as_ref().is_none_or(|keep| keep[t])
    }
}

/// The smallest `r` for which triangle `t`'s bounding box meets the window `centre ± r half`.
fn window_reach(mesh: &Mesh, t: usize, centre: DVec2, half: DVec2) -> f64 {
    let [a, b, c] = mesh.triangles[t].map(|v| mesh.vertices[v as usize]);
    let (min, max) = (a.min(b).min(c), a.max(b).max(c));
    let gap = (min - centre).max(centre - max).max(DVec2::ZERO) / half;
    gap.max_element()
}

/// The bounding box of the kept triangles.
fn kept_bounds(mesh: &Mesh, keep: &[bool]) -> (DVec2, DVec2) {
    let empty = || (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    (0..mesh.triangles.len())
        .into_par_iter()
        .filter(|&t| keep[t])
        .flat_map_iter(|t| mesh.triangles[t])
        .map(|v| mesh.vertices[v as usize])
        .fold(empty, |(lo, hi), p| (lo.min(p), hi.max(p)))
        .reduce(empty, |(a, b), (c, d)| (a.min(c), b.max(d)))
}

/// The SVG y coordinate of `y`: flipped so that up is up (`0 - y` keeps 0 from printing as -0).
fn svg_y(y: f64) -> f64 {
    0.0 - y
}

/// Writes an SVG picture of the mesh, about 1000 pixels wide: the triangle edges as one thin
/// black path, the vertices that are input points as small red dots, y pointing up, the view
/// fitted to the domain (with a [`Mesh::outline`], its bounding box) with a small margin.
///
/// A mesh of a planar straight-line graph also shows its subsegments as one thicker dark path
/// over the edges, its hole seeds as small blue crosses and, with regions, its triangles filled
/// by region in pastel colours (one path per colour, under the edges; region `r` takes colour
/// `r` modulo their number; triangles outside every region stay unfilled).
///
/// A mesh of more than `max_triangles` triangles is shown only in part: the triangles that meet
/// the smallest window around the domain's centre, of the domain's shape, that holds about
/// `max_triangles` of them, and the input points in that window. The picture's title and a
/// comment then say so.
///
/// # Errors
/// Whatever `w` returns.
pub fn write_svg<W: Write>(mesh: &Mesh, mut w: W, max_triangles: usize) -> io::Result<()> {
    let view = SvgView::new(mesh, max_triangles);
    let extent = view.hi - view.lo;
    let mut margin = 0.02 * extent.max_element();
    if !(margin.is_finite() && margin > 0.0) {
        margin = 1.0;
    }
    let (lo, size) = (view.lo - margin, extent + 2.0 * margin);
    // Length of a pixel in mesh units, which strokes and dots are measured in.
    let pixel = size.x / SVG_WIDTH;
    let height = (SVG_WIDTH * size.y / size.x)
        .round()
        .clamp(1.0, 100.0 * SVG_WIDTH);
    writeln!(
        w,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{SVG_WIDTH}" height="{height}" viewBox="{} {} {} {}">"#,
        lo.x,
        svg_y(lo.y + size.y),
        size.x,
        size.y
    )?;
    write_svg_title(&mut w, mesh, &view)?;
    write_svg_regions(&mut w, mesh, &view)?;
    write_svg_edges(&mut w, mesh, &view, pixel)?;
    write_svg_segments(&mut w, mesh, lo, lo + size, pixel)?;
    write_svg_holes(&mut w, mesh, pixel)?;
    write_svg_dots(&mut w, mesh, lo, lo + size, pixel)?;
    writeln!(w, "</svg>")?;
    w.flush()
}

/// The title, and a comment when only part of the mesh is drawn.
fn write_svg_title<W: Write>(w: &mut W, mesh: &Mesh, view: &SvgView) -> io::Result<()> {
    let inputs = mesh.vertex_input.par_iter().filter(|&&i| i != NONE).count();
    let mut title = format!(
        "Mesh of {} vertices ({inputs} input points, red) and {} triangles",
        mesh.vertices.len(),
        mesh.triangles.len()
    );
    if !mesh.segments.is_empty() {
        title += &format!(
            ", {} subsegments (dark), {} hole seeds (blue crosses), {} regions (filled)",
            mesh.segments.len(),
            mesh.holes.len(),
            mesh.region_attributes.len()
        );
    }
    if view.keep.is_some() {
        let part = format!(
            "only the {} triangles that meet the window [{}, {}] x [{}, {}] around the domain's \
             centre are drawn",
            view.shown, view.lo.x, view.hi.x, view.lo.y, view.hi.y
        );
        writeln!(w, "<!-- Part of the mesh: {part}. -->")?;
        title = format!("{title}; {part}");
    }
    writeln!(w, "<title>{title}</title>")
}

/// The edges of the drawn triangles as one path, each edge once.
fn write_svg_edges<W: Write>(w: &mut W, mesh: &Mesh, view: &SvgView, pixel: f64) -> io::Result<()> {
    if view.shown == 0 {
        return Ok(());
    }
    writeln!(
        w,
        r#"<path fill="none" stroke="black" stroke-width="{}" stroke-linecap="round" d=""#,
        0.5 * pixel
    )?;
    // An edge is drawn by its lower-numbered drawn triangle.
    let draws = |t: usize, i: usize| {
        let across = mesh.neighbours[t][i];
        across == NONE || !view.keeps(across as usize) || t < across as usize
    };
    write_items(w, mesh.triangles.len(), |buf, t| {
        if !view.keeps(t) {
            return Ok(());
        }
        for i in (0..3).filter(|&i| draws(t, i)) {
            let [a, b] = opposite_edge(mesh.triangles[t], i).map(|v| mesh.vertices[v as usize]);
            writeln!(buf, "M{} {}L{} {}", a.x, svg_y(a.y), b.x, svg_y(b.y))?;
        }
        Ok(())
    })?;
    writeln!(w, r#""/>"#)
}

/// Pastel fills of the regions' triangles in an SVG picture.
const REGION_FILLS: [&str; 6] = [
    "#fbb4ae", "#b3cde3", "#ccebc5", "#decbe4", "#fed9a6", "#ffffcc",
];

/// The drawn triangles that lie in regions, filled by region: a path per colour in use.
fn write_svg_regions<W: Write>(w: &mut W, mesh: &Mesh, view: &SvgView) -> io::Result<()> {
    let colour = |t: usize| match mesh.triangle_regions[t] {
        r if r != NONE && view.keeps(t) => Some(r as usize % REGION_FILLS.len()),
        _ => None,
    };
    let triangles = mesh.triangle_regions.len();
    for (k, fill) in REGION_FILLS.iter().enumerate() {
        if !(0..triangles).into_par_iter().any(|t| colour(t) == Some(k)) {
            continue;
        }
        writeln!(w, r#"<path fill="{fill}" stroke="none" d=""#)?;
        write_items(w, triangles, |buf, t| {
            if colour(t) != Some(k) {
                return Ok(());
            }
            let [a, b, c] = mesh.triangles[t].map(|v| mesh.vertices[v as usize]);
            let (ay, by, cy) = (svg_y(a.y), svg_y(b.y), svg_y(c.y));
            writeln!(buf, "M{} {ay}L{} {by}L{} {cy}Z", a.x, b.x, c.x)
        })?;
        writeln!(w, r#""/>"#)?;
    }
    Ok(())
}

/// The subsegments whose bounding boxes meet `[lo, hi]` as one thick dark path.
fn write_svg_segments<W: Write>(
    w: &mut W,
    mesh: &Mesh,
    lo: DVec2,
    hi: DVec2,
    pixel: f64,
) -> io::Result<()> {
    if mesh.segments.is_empty() {
        return Ok(());
    }
    writeln!(
        w,
        r##"<path fill="none" stroke="#303030" stroke-width="{}" stroke-linecap="round" d=""##,
        2.0 * pixel
    )?;
    write_items(w, mesh.segments.len(), |buf, s| {
        let [a, b] = mesh.segments[s].vertices.map(|v| mesh.vertices[v as usize]);
        if a.min(b).cmpgt(hi).any() || a.max(b).cmplt(lo).any() {
            return Ok(());
        }
        writeln!(buf, "M{} {}L{} {}", a.x, svg_y(a.y), b.x, svg_y(b.y))
    })?;
    writeln!(w, r#""/>"#)
}

/// The hole seeds as small blue crosses, one path.
fn write_svg_holes<W: Write>(w: &mut W, mesh: &Mesh, pixel: f64) -> io::Result<()> {
    if mesh.holes.is_empty() {
        return Ok(());
    }
    writeln!(
        w,
        r#"<path fill="none" stroke="blue" stroke-width="{pixel}" d=""#
    )?;
    let arm = 4.0 * pixel;
    for p in &mesh.holes {
        let (x, y) = (p.x, svg_y(p.y));
        writeln!(
            w,
            "M{} {y}L{} {y}M{x} {}L{x} {}",
            x - arm,
            x + arm,
            y - arm,
            y + arm
        )?;
    }
    writeln!(w, r#""/>"#)
}

/// The input vertices in `[lo, hi]` as red dots.
fn write_svg_dots<W: Write>(
    w: &mut W,
    mesh: &Mesh,
    lo: DVec2,
    hi: DVec2,
    pixel: f64,
) -> io::Result<()> {
    writeln!(w, r#"<g fill="red">"#)?;
    let radius = 1.5 * pixel;
    write_items(w, mesh.vertices.len(), |buf, v| {
        let p = mesh.vertices[v];
        let inside = p.cmpge(lo).all() && p.cmple(hi).all();
        if mesh.vertex_input[v] == NONE || !inside {
            return Ok(());
        }
        writeln!(
            buf,
            r#"<circle cx="{}" cy="{}" r="{radius}"/>"#,
            p.x,
            svg_y(p.y)
        )
    })?;
    writeln!(w, "</g>")
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::*;
    use crate::mesh::fixtures::{bounding_box, four_triangles, pslg_square, two_triangles};
    use crate::mesh::{BoundaryEdge, Domain, SubSegment};

    /// An `n` by `n` grid of unit squares, each cut along the diagonal from its lower-left
    /// corner; every third vertex is an input point.
    fn grid(n: u32) -> Mesh {
        let vertex = |i: u32, j: u32| j * (n + 1) + i;
        let triangle = |i: u32, j: u32, k: u32| {
            if i < n && j < n {
                2 * (j * n + i) + k
            } else {
                NONE
            }
        };
        let mut mesh = Mesh {
            outline: None,
            domain: Domain {
                lo: DVec2::ZERO,
                hi: DVec2::splat(f64::from(n)),
            },
            ..Mesh::default()
        };
        for j in 0..=n {
            for i in 0..=n {
                mesh.vertices.push(DVec2::new(f64::from(i), f64::from(j)));
                let v = vertex(i, j);
                mesh.vertex_input
                    .push(if v.is_multiple_of(3) { v / 3 } else { NONE });
            }
        }
        for j in 0..n {
            for i in 0..n {
                let [a, b, c, d] = [
                    vertex(i, j),
                    vertex(i + 1, j),
                    vertex(i + 1, j + 1),
                    vertex(i, j + 1),
                ];
                mesh.triangles.push([a, b, c]);
                mesh.triangles.push([a, c, d]);
                let below = j.checked_sub(1).map_or(NONE, |j| triangle(i, j, 1));
                let left = i.checked_sub(1).map_or(NONE, |i| triangle(i, j, 0));
                mesh.neighbours
                    .push([triangle(i + 1, j, 1), triangle(i, j, 1), below]);
                mesh.neighbours
                    .push([triangle(i, j + 1, 0), left, triangle(i, j, 0)]);
            }
        }
        let sides = [
            (
                BoundarySide::Bottom,
                (0..n)
                    .map(|i| [vertex(i, 0), vertex(i + 1, 0)])
                    .collect::<Vec<_>>(),
            ),
            (
                BoundarySide::Right,
                (0..n).map(|j| [vertex(n, j), vertex(n, j + 1)]).collect(),
            ),
            (
                BoundarySide::Top,
                (0..n)
                    .rev()
                    .map(|i| [vertex(i + 1, n), vertex(i, n)])
                    .collect(),
            ),
            (
                BoundarySide::Left,
                (0..n)
                    .rev()
                    .map(|j| [vertex(0, j + 1), vertex(0, j)])
                    .collect(),
            ),
        ];
        for (side, edges) in sides {
            let edges = edges.into_iter().map(|vertices| BoundaryEdge {
                vertices,
                marker: side.marker(),
            });
            mesh.boundary.extend(edges);
        }
        mesh
    }

    fn text<F: Fn(&Mesh, &mut Vec<u8>) -> io::Result<()>>(mesh: &Mesh, write: F) -> String {
        let mut out = Vec::new();
        write(mesh, &mut out).unwrap();
        String::from_utf8(out).unwrap()
    }

    type Writer = fn(&Mesh, &mut Vec<u8>) -> io::Result<()>;

    /// The writers of Triangle's files in the order [`write_triangle_files`] writes them, the
    /// last (`.poly`) only for a mesh with segments.
    const TRIANGLE_WRITERS: [Writer; 5] = [
        |m, w| write_node(m, w),
        |m, w| write_ele(m, w),
        |m, w| write_neigh(m, w),
        |m, w| write_edge(m, w),
        |m, w| write_poly(m, w),
    ];

    /// Checks the text of each of Triangle's files of `mesh` (see [`TRIANGLE_WRITERS`]).
    fn assert_triangle_files(mesh: &Mesh, expected: &[&str]) {
        let files = if mesh.segments.is_empty() { 4 } else { 5 };
        assert_eq!(expected.len(), files, "one text per file");
        for (write, expected) in TRIANGLE_WRITERS.iter().zip(expected) {
            assert_eq!(text(mesh, write), *expected);
        }
    }

    #[test]
    fn integer_lines_match_display() {
        let fields = [0, -1, 7, 10, 42, -1000, i64::MAX, i64::MIN];
        let mut buf = Vec::new();
        push_line(&mut buf, &fields);
        push_line(&mut buf, &[]);
        let expected = fields.map(|f| f.to_string()).join(" ") + "\n\n";
        assert_eq!(String::from_utf8(buf).unwrap(), expected);
    }

    #[test]
    fn grid_generator_is_consistent() {
        let mesh = grid(5);
        let mut boundary = 0;
        for (t, across) in mesh.neighbours.iter().enumerate() {
            for (i, &n) in across.iter().enumerate() {
                let [a, b] = opposite_edge(mesh.triangles[t], i);
                if n == NONE {
                    assert!(mesh.boundary.iter().any(|e| e.vertices == [a, b]));
                    boundary += 1;
                } else {
                    let back = mesh.neighbours[n as usize]
                        .iter()
                        .position(|&m| m as usize == t);
                    let j = back.expect("neighbours are mutual");
                    assert_eq!(opposite_edge(mesh.triangles[n as usize], j), [b, a]);
                }
            }
        }
        assert_eq!(boundary, mesh.boundary.len());
    }

    #[test]
    fn triangle_files_of_two_triangles() {
        let node = "\
# vertex (numbered from 1), x, y, input index (0-based, -1 for none), boundary marker
4 2 1 1
1 0 0 0 1
2 1 0 2 2
3 1 1 1 3
4 0 1 -1 4
";
        let ele = "\
# triangle, its vertices counter-clockwise (all numbered from 1)
2 3 0
1 1 2 3
2 1 3 4
";
        let neigh = "\
# triangle, the triangles across from its corners (numbered from 1, -1 for none)
2 3
1 -1 2 -1
2 -1 -1 1
";
        let edge = "\
# edge (numbered from 1), its vertices, side marker (1 bottom, 2 right, 3 top, 4 left, 0 interior)
5 1
1 2 3 2
2 3 1 0
3 1 2 1
4 3 4 3
5 4 1 4
";
        assert_triangle_files(&two_triangles(), &[node, ele, neigh, edge]);
    }

    #[test]
    fn interior_vertices_have_marker_zero() {
        let node = text(&four_triangles(), |m, w| write_node(m, w));
        // The corners carry the side that leaves them counter-clockwise; the centre 0.
        assert!(node.ends_with("\n4 0 1 -1 4\n5 0.5 0.5 0 0\n"), "{node}");
    }

    #[test]
    fn node_file_reads_back() {
        let mesh = grid(40);
        let node = text(&mesh, |m, w| write_node(m, w));
        assert_eq!(super::super::parse_node(&node, "t").unwrap(), mesh.vertices);
    }

    /// The edges of an `.edge` file, by their vertex pair (0-based, in either order), with
    /// their markers; checks the numbering and that no edge comes twice.
    fn read_edges(edge: &str) -> HashMap<[u32; 2], u8> {
        let mut lines = edge.lines().filter(|l| !l.starts_with('#'));
        let header: Vec<usize> = lines
            .next()
            .unwrap()
            .split(' ')
            .map(|f| f.parse().unwrap())
            .collect();
        let mut edges = HashMap::new();
        for (k, line) in lines.enumerate() {
            let f: Vec<u32> = line.split(' ').map(|f| f.parse().unwrap()).collect();
            assert_eq!(f[0] as usize, k + 1, "{line}");
            let key = [f[1].min(f[2]) - 1, f[1].max(f[2]) - 1];
            assert!(edges.insert(key, f[3] as u8).is_none(), "{line} twice");
        }
        assert_eq!(header, [edges.len(), 1]);
        edges
    }

    #[test]
    fn edge_file_lists_every_edge_once() {
        for mesh in [four_triangles(), grid(1), grid(70)] {
            let edges = read_edges(&text(&mesh, |m, w| write_edge(m, w)));
            let mut expected = HashMap::new();
            for triangle in &mesh.triangles {
                for i in 0..3 {
                    let [a, b] = opposite_edge(*triangle, i);
                    expected.insert([a.min(b), a.max(b)], 0);
                }
            }
            for e in &mesh.boundary {
                let [a, b] = e.vertices;
                expected.insert([a.min(b), a.max(b)], e.marker as u8);
            }
            assert_eq!(edges, expected);
            // Euler's formula for a disc.
            assert_eq!(edges.len(), mesh.vertices.len() + mesh.triangles.len() - 1);
        }
    }

    #[test]
    fn triangle_files_are_written_next_to_the_prefix() {
        let dir = std::env::temp_dir().join(format!("quadmesh-mesh-write-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let prefix = dir.join("square.1");
        let paths = write_triangle_files(&two_triangles(), &prefix).unwrap();
        let names: Vec<String> = paths
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            names,
            [
                "square.1.node",
                "square.1.ele",
                "square.1.neigh",
                "square.1.edge"
            ]
        );
        let ele = std::fs::read_to_string(&paths[1]).unwrap();
        assert_eq!(ele, text(&two_triangles(), |m, w| write_ele(m, w)));
        std::fs::remove_dir_all(&dir).unwrap();
        let missing =
            write_triangle_files(&two_triangles(), &dir.join("no/such/dir/x")).unwrap_err();
        assert!(missing.to_string().contains("x.node"), "{missing}");
    }

    /// Checks that the tags of `xml` (no text content, attributes without `<` or `>`) nest, and
    /// returns the names of those left open.
    fn open_tags(xml: &str) -> Vec<String> {
        let mut open = Vec::new();
        for piece in xml.split('<').skip(1) {
            let (tag, _) = piece.split_once('>').expect("tag closed");
            let name = tag
                .trim_start_matches('/')
                .split_whitespace()
                .next()
                .unwrap()
                .trim_end_matches('/');
            if tag.starts_with('?') || tag.starts_with('!') {
                continue;
            } else if tag.starts_with('/') {
                assert_eq!(
                    open.pop().as_deref(),
                    Some(name),
                    "</{name}> closes nothing"
                );
            } else if !tag.ends_with('/') {
                open.push(name.to_string());
            }
        }
        open
    }

    fn u64_at(bytes: &[u8], at: usize) -> u64 {
        u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap())
    }

    #[test]
    fn vtu_arrays_have_the_lengths_their_offsets_say() {
        let mesh = four_triangles();
        let mut out = Vec::new();
        write_vtu(&mesh, &mut out).unwrap();
        let start = b"<AppendedData encoding=\"raw\">\n   _";
        let at = out.windows(start.len()).position(|w| w == start).unwrap() + start.len();
        let header = std::str::from_utf8(&out[..at]).unwrap();
        assert_eq!(open_tags(header), ["VTKFile", "AppendedData"]);
        let tail = "\n  </AppendedData>\n</VTKFile>\n";
        assert!(out.ends_with(tail.as_bytes()));
        assert!(open_tags(&format!("<VTKFile><AppendedData>{tail}")).is_empty());
        let offsets: Vec<usize> = header
            .split("offset=\"")
            .skip(1)
            .map(|s| s.split('"').next().unwrap().parse().unwrap())
            .collect();
        let data = &out[at..out.len() - tail.len()];
        // input_index, min_angle, points, connectivity, offsets, types.
        let lengths = [5 * 8, 4 * 8, 5 * 24, 4 * 24, 4 * 8, 4];
        let mut next = 0;
        for (&offset, length) in offsets.iter().zip(lengths) {
            assert_eq!(offset, next);
            assert_eq!(u64_at(data, offset), length as u64);
            next = offset + 8 + length;
        }
        assert_eq!(next, data.len());
        let array = |k: usize, i: usize| u64_at(data, offsets[k] + 8 + 8 * i);
        assert_eq!(array(0, 3) as i64, -1);
        assert_eq!(array(0, 4), 0);
        assert_eq!(f64::from_bits(array(1, 0)), 45.0);
        assert_eq!(f64::from_bits(array(2, 12)), 0.5);
        assert_eq!(f64::from_bits(array(2, 14)), 0.0);
        assert_eq!(
            (0..12).map(|i| array(3, i)).collect::<Vec<_>>(),
            [0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4]
        );
        assert_eq!(
            (0..4).map(|i| array(4, i)).collect::<Vec<_>>(),
            [3, 6, 9, 12]
        );
        assert_eq!(&data[offsets[5] + 8..], &[VTK_TRIANGLE; 4]);
    }

    /// The lines of `section` in an `.msh` text, without its `$` lines.
    fn msh_section<'a>(msh: &'a str, section: &str) -> Vec<&'a str> {
        let body = msh.split(&format!("${section}\n")).nth(1).unwrap();
        let body = body.split(&format!("$End{section}\n")).next().unwrap();
        body.lines().collect()
    }

    fn fields(line: &str) -> Vec<i64> {
        line.split(' ').map(|f| f.parse().unwrap()).collect()
    }

    #[test]
    fn msh_sections_count_and_tag_right() {
        let mesh = four_triangles();
        let msh = text(&mesh, |m, w| write_msh(m, w));
        assert!(msh.starts_with("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"));
        assert_eq!(msh_section(&msh, "PhysicalNames").len(), 6);
        let entities = msh_section(&msh, "Entities");
        assert_eq!(entities[0], "4 4 1 0");
        assert_eq!(entities[5], "1 0 0 0 1 0 0 1 1 2 1 -2");
        assert_eq!(entities[8], "4 0 0 0 0 1 0 1 4 2 4 -1");
        assert_eq!(entities.len(), 10);
        let nodes = msh_section(&msh, "Nodes");
        assert_eq!(nodes[..2], ["1 5 1 5", "2 1 0 5"]);
        assert_eq!(nodes[2..7], ["1", "2", "3", "4", "5"]);
        assert_eq!(nodes[11], "0.5 0.5 0");
        assert_eq!(nodes.len(), 12);
        let elements = msh_section(&msh, "Elements");
        assert_eq!(elements[0], "5 8 1 8");
        let mut lines = elements[1..].iter();
        let mut tag = 0;
        for (side, expected) in [(1, [1, 2]), (2, [2, 3]), (3, [3, 4]), (4, [4, 1])] {
            assert_eq!(fields(lines.next().unwrap()), [1, side, 1, 1]);
            tag += 1;
            assert_eq!(
                fields(lines.next().unwrap()),
                [tag, expected[0], expected[1]]
            );
        }
        assert_eq!(fields(lines.next().unwrap()), [2, 1, 2, 4]);
        for triangle in &mesh.triangles {
            tag += 1;
            let nodes = triangle.map(|v| i64::from(v) + 1);
            assert_eq!(
                fields(lines.next().unwrap()),
                [tag, nodes[0], nodes[1], nodes[2]]
            );
        }
        assert!(lines.next().is_none());
    }

    #[test]
    fn msh_of_an_empty_mesh_has_empty_sections() {
        let msh = text(&Mesh::default(), |m, w| write_msh(m, w));
        assert_eq!(msh_section(&msh, "Nodes"), ["0 0 0 0"]);
        assert_eq!(msh_section(&msh, "Elements"), ["0 0 0 0"]);
    }

    /// A refined mesh of a pentagon's convex hull with a few points inside, validated.
    fn pentagon() -> Mesh {
        let points: Vec<DVec2> = (0..5)
            .map(|k| {
                let a = f64::from(k) * std::f64::consts::TAU / 5.0 + 0.3;
                DVec2::new(3.0 * a.cos(), 2.0 * a.sin())
            })
            .chain([DVec2::new(0.1, 0.2), DVec2::new(-0.7, 0.4)])
            .collect();
        let options = crate::refine::RefineOptions {
            min_angle_deg: 20.0,
            ..crate::refine::RefineOptions::default()
        };
        let (mesh, _) = crate::refine::refine_points(&points, &options).unwrap();
        let bounds = crate::mesh::AngleBounds {
            min_deg: 20.0,
            max_deg: 140.0,
        };
        mesh.validate(&points, bounds).unwrap();
        assert_eq!(mesh.outline.as_ref().map(Vec::len), Some(5));
        assert!(mesh.boundary.len() > 5, "refinement splits the hull sides");
        mesh
    }

    #[test]
    fn msh_of_an_outline_has_one_boundary_curve() {
        let mesh = pentagon();
        let msh = text(&mesh, |m, w| write_msh(m, w));
        assert!(msh.starts_with("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"));
        assert_eq!(
            msh_section(&msh, "PhysicalNames"),
            ["2", "1 1 \"boundary\"", "2 1 \"domain\""]
        );

        let (lo, hi) = (mesh.domain.lo, mesh.domain.hi);
        let outline = mesh.outline.as_ref().unwrap();
        assert_eq!(
            mesh.domain,
            bounding_box(outline),
            "the domain is the outline's bounding box"
        );
        let entities = msh_section(&msh, "Entities");
        assert_eq!(entities.len(), 3);
        assert_eq!(fields(entities[0]), [0, 1, 1, 0]);
        let bounds = |line: &str| -> Vec<f64> {
            line.split(' ')
                .skip(1)
                .take(6)
                .map(|f| f.parse().unwrap())
                .collect()
        };
        let tail = |line: &str| -> Vec<i64> {
            fields(&line.split(' ').skip(7).collect::<Vec<_>>().join(" "))
        };
        let expected = [lo.x, lo.y, 0.0, hi.x, hi.y, 0.0];
        assert!(entities[1].starts_with("1 ") && entities[2].starts_with("1 "));
        assert_eq!(bounds(entities[1]), expected);
        assert_eq!(bounds(entities[2]), expected);
        // The curve: physical tag 1, no bounding points; the surface: physical tag 1, bounded by
        // curve 1.
        assert_eq!(tail(entities[1]), [1, 1, 0]);
        assert_eq!(tail(entities[2]), [1, 1, 1, 1]);

        let v = mesh.vertices.len() as i64;
        let nodes = msh_section(&msh, "Nodes");
        assert_eq!(fields(nodes[0]), [1, v, 1, v]);
        assert_eq!(fields(nodes[1]), [2, 1, 0, v]);
        assert_eq!(nodes.len(), 2 + 2 * v as usize);

        let elements = msh_section(&msh, "Elements");
        let (lines, triangles) = (mesh.boundary.len(), mesh.triangles.len());
        let total = (lines + triangles) as i64;
        assert_eq!(fields(elements[0]), [2, total, 1, total]);
        assert_eq!(fields(elements[1]), [1, 1, 1, lines as i64]);
        assert_eq!(fields(elements[2 + lines]), [2, 1, 2, triangles as i64]);
        assert_eq!(elements.len(), 3 + lines + triangles);
        let mut tags = Vec::new();
        let mut edges = HashMap::new();
        for line in &elements[2..2 + lines] {
            let f = fields(line);
            assert_eq!(f.len(), 3);
            tags.push(f[0]);
            assert!(edges.insert([f[1], f[2]], ()).is_none(), "{line}");
        }
        let mut cells = HashMap::new();
        for line in &elements[3 + lines..] {
            let f = fields(line);
            assert_eq!(f.len(), 4);
            tags.push(f[0]);
            assert!(cells.insert([f[1], f[2], f[3]], ()).is_none(), "{line}");
        }
        assert_eq!(tags, (1..=total).collect::<Vec<_>>());
        let node = |v: u32| i64::from(v) + 1;
        assert_eq!(edges.len(), lines);
        for e in &mesh.boundary {
            assert!(edges.contains_key(&e.vertices.map(node)), "{e:?}");
        }
        assert_eq!(cells.len(), triangles);
        for t in &mesh.triangles {
            assert!(cells.contains_key(&t.map(node)), "{t:?}");
        }
    }

    #[test]
    fn edge_file_of_an_outline_says_its_markers() {
        let mesh = pentagon();
        let edge = text(&mesh, |m, w| write_edge(m, w));
        assert!(edge.starts_with(
            "# edge (numbered from 1), its vertices, boundary marker (1 boundary, 0 interior)\n"
        ));
        let markers = read_edges(&edge);
        assert_eq!(
            markers.values().filter(|&&m| m == 1).count(),
            mesh.boundary.len()
        );
        assert!(markers.values().all(|&m| m <= 1));
        let square = text(&two_triangles(), |m, w| write_edge(m, w));
        assert!(square.starts_with(
            "# edge (numbered from 1), its vertices, side marker (1 bottom, 2 right, 3 top, 4 \
             left, 0 interior)\n"
        ));
    }

    #[test]
    fn svg_of_an_outline_frames_its_bounding_box() {
        let mesh = pentagon();
        let svg = text(&mesh, |m, w| write_svg(m, w, usize::MAX));
        let (lo, hi) = (mesh.domain.lo, mesh.domain.hi);
        let margin = 0.02 * (hi - lo).max_element();
        let (corner, size) = (lo - margin, hi - lo + 2.0 * margin);
        let view = format!(
            "viewBox=\"{} {} {} {}\"",
            corner.x,
            svg_y(corner.y + size.y),
            size.x,
            size.y
        );
        assert!(
            svg.contains(&view),
            "{view} in {}",
            svg.lines().next().unwrap()
        );
        for [a, b] in svg_path(&svg) {
            for p in [a, b] {
                let p = DVec2::new(p.x, -p.y);
                assert!(p.cmpge(lo).all() && p.cmple(hi).all(), "{p}");
            }
        }
    }

    /// The `d` attribute of the first path in `svg`.
    fn path_d(svg: &str) -> &str {
        let d = svg.split(" d=\"").nth(1).unwrap();
        d.split('"').next().unwrap()
    }

    /// The segments of the path of an SVG picture, in SVG coordinates.
    fn svg_path(svg: &str) -> Vec<[DVec2; 2]> {
        let d = path_d(svg);
        d.lines()
            .filter(|l| !l.is_empty())
            .map(|line| {
                let f: Vec<f64> = line[1..]
                    .split(['L', ' '])
                    .map(|f| f.parse().unwrap())
                    .collect();
                [DVec2::new(f[0], f[1]), DVec2::new(f[2], f[3])]
            })
            .collect()
    }

    #[test]
    fn svg_of_a_small_mesh_draws_it_all() {
        let svg = text(&four_triangles(), |m, w| write_svg(m, w, 100));
        assert!(
            svg.starts_with("<svg ") && svg.ends_with("</svg>\n"),
            "{svg}"
        );
        assert!(open_tags(&svg).is_empty());
        assert_eq!(svg.matches("<circle").count(), 1);
        assert!(svg.contains(r#"<circle cx="0.5" cy="-0.5""#), "{svg}");
        // 8 edges, each once.
        assert_eq!(svg_path(&svg).len(), 8);
        assert!(!svg.contains("<!--"));
    }

    #[test]
    fn svg_of_a_large_mesh_draws_a_window() {
        let mesh = grid(100);
        let svg = text(&mesh, |m, w| write_svg(m, w, 1000));
        assert!(svg.starts_with("<svg ") && svg.ends_with("</svg>\n"));
        assert!(open_tags(&svg).is_empty());
        assert!(svg.contains("<!-- Part of the mesh: only the "), "{svg}");
        let shown: usize = svg
            .split("only the ")
            .nth(1)
            .unwrap()
            .split(' ')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert!((1000..1200).contains(&shown), "{shown}");
        // Every drawn edge lies near the centre.
        let near = |x: f64| (x - 50.0).abs() < 20.0;
        for [a, b] in svg_path(&svg) {
            assert!(
                near(a.x) && near(b.x) && near(-a.y) && near(-b.y),
                "{a} {b}"
            );
        }
        let none = text(&mesh, |m, w| write_svg(m, w, 0));
        assert!(none.contains("only the 0 triangles") && !none.contains("<path"));
    }

    /// [`grid`] as a planar straight-line graph: its bottom side a segment with marker 2, its
    /// diagonal from the origin an interior segment with marker 0, the triangles below the
    /// diagonal in region 0 (attribute 1.5) and those above in region 1 (attribute -2), and a
    /// hole seed outside it.
    fn pslg_grid(n: u32) -> Mesh {
        let mut mesh = grid(n);
        let vertex = |i: u32, j: u32| j * (n + 1) + i;
        let bottom = (0..n).map(|i| SubSegment {
            vertices: [vertex(i, 0), vertex(i + 1, 0)],
            segment: 0,
            marker: 2,
        });
        let diagonal = (0..n).map(|i| SubSegment {
            vertices: [vertex(i, i), vertex(i + 1, i + 1)],
            segment: 1,
            marker: 0,
        });
        mesh.segments = bottom.chain(diagonal).collect();
        for e in &mut mesh.boundary {
            e.marker = if e.marker == BoundarySide::Bottom.marker() {
                2
            } else {
                1
            };
        }
        // Triangle 2 (j n + i) + k is the lower-right (k = 0) or upper-left half of square (i, j).
        mesh.triangle_regions = (0..2 * n * n)
            .map(|t| {
                let (square, k) = (t / 2, t % 2);
                let (i, j) = (square % n, square / n);
                u32::from(j > i || (i == j && k == 1))
            })
            .collect();
        mesh.region_attributes = vec![1.5, -2.0];
        mesh.holes = vec![DVec2::new(-1.0, 0.5)];
        mesh
    }

    #[test]
    fn triangle_files_of_a_pslg_mesh() {
        let node = "\
# vertex (numbered from 1), x, y, input index (0-based, -1 for none), boundary marker
5 2 1 1
1 0 0 0 5
2 1 0 1 5
3 1 1 2 -3
4 0 1 3 1
5 0.5 0.5 4 -3
";
        let ele = "\
# triangle, its vertices counter-clockwise (all numbered from 1), regional attribute (0 \
outside every region)
4 3 1
1 1 2 5 2.5
2 2 3 5 0
3 3 4 5 -1
4 4 1 5 -1
";
        let neigh = "\
# triangle, the triangles across from its corners (numbered from 1, -1 for none)
4 3
1 2 4 -1
2 3 1 -1
3 4 2 -1
4 1 3 -1
";
        let edge = "\
# edge (numbered from 1), its vertices, marker (its segment's, 1 if that is 0 on the boundary; \
else 1 boundary, 0 interior)
8 1
1 2 5 0
2 5 1 -3
3 1 2 5
4 3 5 -3
5 2 3 1
6 4 5 0
7 3 4 1
8 4 1 1
";
        let poly = "\
# no vertices: they are in the .node file
0 2 1 1
# subsegment (numbered from 1), its vertices, boundary marker
5 1
1 1 2 5
2 2 3 1
3 1 5 -3
4 5 3 -3
5 2 5 0
# hole (numbered from 1), a point in it
1
1 2 0.5
# no regions: the regional attributes are in the .ele file
0
";
        assert_triangle_files(&pslg_square(), &[node, ele, neigh, edge, poly]);
    }

    #[test]
    fn poly_file_reads_back_with_its_node_file() {
        let dir = std::env::temp_dir().join(format!("quadmesh-poly-write-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let prefix = dir.join("graph.1");
        for mesh in [pslg_square(), pslg_grid(5)] {
            let paths = write_triangle_files(&mesh, &prefix).unwrap();
            let names: Vec<String> = paths
                .iter()
                .map(|p| p.extension().unwrap().to_string_lossy().into_owned())
                .collect();
            assert_eq!(names, ["node", "ele", "neigh", "edge", "poly"]);
            let input = super::super::read_input(&paths[4]).unwrap();
            assert_eq!(input.points, mesh.vertices);
            let ends: Vec<[u32; 2]> = input.segments.iter().map(|s| s.ends).collect();
            let vertices: Vec<[u32; 2]> = mesh.segments.iter().map(|s| s.vertices).collect();
            assert_eq!(ends, vertices);
            let markers: Vec<i32> = input.segments.iter().map(|s| s.marker).collect();
            assert_eq!(markers, mesh.segment_markers());
            assert_eq!(input.holes, mesh.holes);
            assert!(input.regions.is_empty());
        }
        // A point set's mesh has no .poly file.
        let paths = write_triangle_files(&two_triangles(), &prefix).unwrap();
        assert_eq!(paths.len(), 4);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn ele_file_without_regions_has_no_attribute() {
        let mut mesh = pslg_square();
        mesh.triangle_regions.clear();
        mesh.region_attributes.clear();
        let ele = text(&mesh, |m, w| write_ele(m, w));
        assert!(ele.contains("\n4 3 0\n1 1 2 5\n"), "{ele}");
    }

    /// The name, type and bytes of each appended array of a `.vtu` file, in header order.
    fn vtu_arrays(out: &[u8]) -> Vec<(String, String, Vec<u8>)> {
        let start = b"<AppendedData encoding=\"raw\">\n   _";
        let at = out.windows(start.len()).position(|w| w == start).unwrap() + start.len();
        let header = std::str::from_utf8(&out[..at]).unwrap();
        let data = &out[at..];
        let attribute = |line: &str, key: &str| {
            let value = line.split(&format!(" {key}=\"")).nth(1).unwrap();
            value.split('"').next().unwrap().to_string()
        };
        header
            .lines()
            .filter(|l| l.contains("<DataArray "))
            .map(|line| {
                let offset: usize = attribute(line, "offset").parse().unwrap();
                let length = u64_at(data, offset) as usize;
                let bytes = data[offset + 8..offset + 8 + length].to_vec();
                (attribute(line, "Name"), attribute(line, "type"), bytes)
            })
            .collect()
    }

    #[test]
    fn vtu_of_a_pslg_mesh_has_markers_and_regions() {
        let mut out = Vec::new();
        write_vtu(&pslg_square(), &mut out).unwrap();
        let arrays = vtu_arrays(&out);
        let names: Vec<&str> = arrays.iter().map(|(n, _, _)| n.as_str()).collect();
        assert_eq!(
            names,
            [
                "input_index",
                "marker",
                "min_angle",
                "region",
                "attribute",
                "Points",
                "connectivity",
                "offsets",
                "types"
            ]
        );
        let array = |name: &str| arrays.iter().find(|(n, _, _)| n == name).unwrap();
        let int32 = |name: &str| -> Vec<i32> {
            let (_, vtk_type, bytes) = array(name);
            assert_eq!(vtk_type, "Int32");
            let items = bytes.chunks_exact(4);
            items
                .map(|b| i32::from_le_bytes(b.try_into().unwrap()))
                .collect()
        };
        assert_eq!(int32("marker"), [5, 5, -3, 1, -3]);
        assert_eq!(int32("region"), [0, -1, 1, 1]);
        let (_, vtk_type, bytes) = array("attribute");
        assert_eq!(vtk_type, "Float64");
        let attributes: Vec<f64> = bytes
            .chunks_exact(8)
            .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
            .collect();
        assert_eq!(attributes, [2.5, 0.0, -1.0, -1.0]);
        assert_eq!(array("types").2, [VTK_TRIANGLE; 4]);
        let header_end = out.windows(4).position(|w| w == b"   _").unwrap();
        let header = std::str::from_utf8(&out[..header_end]).unwrap();
        assert_eq!(open_tags(header), ["VTKFile", "AppendedData"]);
        assert!(header.contains("<CellData Scalars=\"min_angle\">"));

        // Without regions, only the markers are added.
        let mut mesh = pslg_square();
        mesh.triangle_regions.clear();
        mesh.region_attributes.clear();
        let mut out = Vec::new();
        write_vtu(&mesh, &mut out).unwrap();
        let names: Vec<String> = vtu_arrays(&out).into_iter().map(|(n, _, _)| n).collect();
        assert_eq!(names[..3], ["input_index", "marker", "min_angle"]);
        assert_eq!(names.len(), 7);
    }

    #[test]
    fn msh_of_a_pslg_mesh_groups_markers_and_regions() {
        let msh = text(&pslg_square(), |m, w| write_msh(m, w));
        let expected = r#"$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
7
1 6 "marker -3"
1 7 "marker 0"
1 1 "marker 1"
1 5 "marker 5"
2 1 "region 1, attribute 2.5"
2 2 "region 2, attribute -1"
2 3 "outside regions"
$EndPhysicalNames
$Entities
0 4 3 0
1 0 0 0 1 1 0 1 6 0
2 0.5 0 0 1 0.5 0 1 7 0
3 0 0 0 1 1 0 1 1 0
4 0 0 0 1 0 0 1 5 0
1 0 0 0 1 0.5 0 1 1 0
2 0 0 0 1 1 0 1 2 0
3 0.5 0 0 1 1 0 1 3 0
$EndEntities
$Nodes
1 5 1 5
2 1 0 5
1
2
3
4
5
0 0 0
1 0 0
1 1 0
0 1 0
0.5 0.5 0
$EndNodes
$Elements
7 11 1 11
1 1 1 2
1 1 5
2 5 3
1 2 1 1
3 2 5
1 3 1 3
4 2 3
5 3 4
6 4 1
1 4 1 1
7 1 2
2 1 2 1
8 1 2 5
2 2 2 2
9 3 4 5
10 4 1 5
2 3 2 1
11 2 3 5
$EndElements
"#;
        assert_eq!(msh, expected);
    }

    #[test]
    fn msh_of_a_pslg_mesh_without_regions_has_one_surface() {
        let mut mesh = pslg_square();
        mesh.triangle_regions.clear();
        mesh.region_attributes.clear();
        // Only positive markers: each is its own physical tag.
        for s in &mut mesh.segments {
            s.marker = s.marker.abs() + 1;
        }
        let msh = text(&mesh, |m, w| write_msh(m, w));
        assert_eq!(
            msh_section(&msh, "PhysicalNames"),
            [
                "4",
                "1 1 \"marker 1\"",
                "1 4 \"marker 4\"",
                "1 6 \"marker 6\"",
                "2 1 \"domain\""
            ]
        );
        let entities = msh_section(&msh, "Entities");
        assert_eq!(entities[0], "0 3 1 0");
        assert_eq!(entities[4], "1 0 0 0 1 1 0 1 1 0");
        let elements = msh_section(&msh, "Elements");
        assert_eq!(elements[0], "4 11 1 11");
        // Marker 1: the right side and the interior piece, then the boundary edges on no
        // segment (the top and left sides).
        assert_eq!(
            elements[1..6],
            ["1 1 1 4", "1 2 3", "2 2 5", "3 3 4", "4 4 1"]
        );
        let triangles = elements.iter().position(|l| *l == "2 1 2 4").unwrap();
        assert_eq!(elements[triangles + 1], "8 1 2 5");
        assert_eq!(elements.len(), triangles + 5);
    }

    /// The `d` attribute of the SVG path whose attributes start with `attributes`, as lists of
    /// the numbers of its lines.
    fn svg_path_with(svg: &str, attributes: &str) -> Vec<Vec<f64>> {
        let d = path_d(svg.split(&format!("<path {attributes}")).nth(1).unwrap());
        d.lines()
            .filter(|l| !l.is_empty())
            .map(|line| {
                line.split(['M', 'L', 'Z', ' '])
                    .filter(|f| !f.is_empty())
                    .map(|f| f.parse().unwrap())
                    .collect()
            })
            .collect()
    }

    #[test]
    fn svg_of_a_pslg_mesh_draws_segments_holes_and_regions() {
        let svg = text(&pslg_square(), |m, w| write_svg(m, w, 100));
        assert!(svg.starts_with("<svg ") && svg.ends_with("</svg>\n"));
        assert!(open_tags(&svg).is_empty());
        assert!(
            svg.contains("5 subsegments (dark), 1 hole seeds (blue crosses), 2 regions (filled)"),
            "{svg}"
        );
        // Region 0's one triangle in the first colour, region 1's two in the second; the
        // triangle outside every region unfilled.
        let first = svg_path_with(&svg, &format!("fill=\"{}\"", REGION_FILLS[0]));
        assert_eq!(first, [vec![0.0, 0.0, 1.0, 0.0, 0.5, -0.5]]);
        let second = svg_path_with(&svg, &format!("fill=\"{}\"", REGION_FILLS[1]));
        assert_eq!(second.len(), 2);
        assert_eq!(svg.matches("stroke=\"none\"").count(), 2);
        // The fills come before the edges, which come before the subsegments.
        let fill = svg.find(REGION_FILLS[0]).unwrap();
        let edges = svg.find("stroke=\"black\"").unwrap();
        let segments = svg.find("stroke=\"#303030\"").unwrap();
        assert!(fill < edges && edges < segments);
        assert_eq!(
            svg_path_with(&svg, "fill=\"none\" stroke=\"black\"").len(),
            8
        );
        let drawn = svg_path_with(&svg, "fill=\"none\" stroke=\"#303030\"");
        assert_eq!(drawn.len(), 5);
        assert_eq!(drawn[3], [0.5, -0.5, 1.0, -1.0]);
        // One cross: a horizontal and a vertical stroke through the seed (2, 0.5).
        let cross = svg_path_with(&svg, "fill=\"none\" stroke=\"blue\"");
        assert_eq!(cross.len(), 1);
        let c = &cross[0];
        assert_eq!(c.len(), 8);
        assert!(
            c[0] < 2.0 && c[2] > 2.0 && c[1] == -0.5 && c[3] == -0.5,
            "{c:?}"
        );
        assert!(
            c[4] == 2.0 && c[6] == 2.0 && c[5] < -0.5 && c[7] > -0.5,
            "{c:?}"
        );
    }

    #[test]
    fn svg_of_a_point_set_draws_no_pslg_parts() {
        let svg = text(&four_triangles(), |m, w| write_svg(m, w, 100));
        assert!(!svg.contains("#303030") && !svg.contains("blue") && !svg.contains("subsegments"));
        assert!(REGION_FILLS.iter().all(|fill| !svg.contains(fill)));
    }

    /// Every writer's bytes for `mesh` on a rayon pool of `threads` threads.
    fn all_bytes(mesh: &Mesh, threads: usize) -> Vec<Vec<u8>> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let others: [Writer; 4] = [
                |m, w| write_vtu(m, w),
                |m, w| write_msh(m, w),
                |m, w| write_svg(m, w, 5000),
                |m, w| write_svg(m, w, 100_000),
            ];
            TRIANGLE_WRITERS
                .iter()
                .chain(&others)
                .map(|write| {
                    let mut out = Vec::new();
                    write(mesh, &mut out).unwrap();
                    out
                })
                .collect()
        })
    }

    #[test]
    fn bytes_do_not_depend_on_the_thread_count() {
        for mesh in [grid(100), pslg_grid(100)] {
            assert!(mesh.triangles.len() > 2 * BLOCK && mesh.vertices.len() > BLOCK);
            assert_eq!(all_bytes(&mesh, 1), all_bytes(&mesh, 2));
        }
    }
}
