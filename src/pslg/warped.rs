//! The domain cut out of a graph's warped tree: what its segments enclose, less its holes, with
//! its regions, its caps put back and its segments' markers carried.
//!
//! The triangulated leaves cover the whole root square. The chains of the cut graph's edges
//! split them into pieces (triangles joined across edges that are no chain's). A piece is
//! outside when it reaches the root's side, a hole when it holds a hole seed; a region seed
//! names its piece (the last seed wins, as in Triangle). A cap belongs to the wedge it was cut
//! from: the piece beyond its cutting edge, whose fate and region it takes, and a seed inside
//! it names that piece. (Two caps on both sides of one segment at a vertex share the piece
//! inside them, the segment's short side between them being no wall, so the caps are not
//! joined to faces through it.) The pieces inside caps are dropped, and each cap kept is
//! triangulated again from its apex, its sides and its cutting edge, divided as the mesh
//! beside them divides them.

use std::collections::HashMap;

use glam::DVec2;
use rayon::prelude::*;

use super::{Cap, CornerCut, EdgeOrigin};
use crate::domain::{BoundaryEdge, Domain, SubSegment};
use crate::error::Error;
use crate::mesh::{Mesh, NONE};
use crate::morton::bounding_box;
use crate::options::Input;
use crate::predicates::{Orientation, orientation};
use crate::warp::{GraphTriangulation, best_triangulation};

/// The marker Triangle gives boundary edges that carry none of their own.
const BOUNDARY_MARKER: i32 = 1;

/// The mesh of the cleaned graph `input` from the triangulated leaves `leaves` of its cut
/// graph `cut`, whose graph vertex `f` is cut point `features[f]`; `triangle_at` finds the
/// triangle of `leaves` holding a point (on its closed area), if any.
///
/// # Errors
/// [`Error::SeedOnSegment`] for a hole or region seed on a segment, [`Error::NothingEnclosed`]
/// when nothing is left, [`Error::WarpStuck`] for a cap its divided sides leave no
/// triangulation of.
pub fn carve_warped(
    input: &Input,
    cut: &CornerCut,
    features: &[u32],
    leaves: &GraphTriangulation,
    triangle_at: impl Fn(DVec2) -> Option<u32> + Sync,
) -> Result<Mesh, Error> {
    let walls = Walls::new(cut, leaves);
    let neighbours = neighbours_of(&leaves.triangles);
    check_walls(leaves, &walls)?;
    let (piece, pieces) = pieces(&leaves.triangles, &neighbours, &walls);
    let faces = Faces::new(
        input,
        cut,
        (&piece, pieces),
        &neighbours,
        &walls,
        leaves,
        &triangle_at,
    )?;
    let mut out = Output::new(leaves, input, cut, features);
    for (t, &triangle) in leaves.triangles.iter().enumerate() {
        let p = piece[t] as usize;
        if !faces.cap_piece[p] && faces.kept(p) {
            out.push(triangle, faces.region_of(p));
        }
    }
    for (c, cap) in cut.caps.iter().enumerate() {
        let p = faces.cap_of[c] as usize;
        if faces.kept(p) {
            let polygon = out.cap_polygon(cut, &walls, c, cap);
            let at: Vec<DVec2> = polygon.iter().map(|&v| out.vertices[v as usize]).collect();
            let Some((triangles, _)) = best_triangulation(&at, &[]) else {
                let apex = cut.points[cap.apex as usize];
                return Err(Error::WarpStuck {
                    x: apex.x,
                    y: apex.y,
                    why: "a cap's divided sides leave it no triangulation",
                });
            };
            let region = faces.region_of(p);
            for t in triangles {
                out.push(t.map(|i| polygon[i]), region);
            }
        }
    }
    if out.triangles.is_empty() {
        return Err(Error::NothingEnclosed);
    }
    Ok(out.finish(input, cut, &walls))
}

/// The chains of the cut graph's edges, as walls between the leaves' triangles.
struct Walls<'a> {
    /// The edge of the cut graph each wall lies on, by its two vertices (the smaller first).
    edge_of: HashMap<(u32, u32), u32>,
    /// The leaves, whose chains run along the cut graph's edges.
    leaves: &'a GraphTriangulation,
    /// The cut-graph edge joining two cut points, by its ends (the smaller first).
    by_ends: HashMap<(u32, u32), u32>,
}

fn pair(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

impl Walls<'_> {
    fn new<'a>(cut: &CornerCut, leaves: &'a GraphTriangulation) -> Walls<'a> {
        let mut edge_of = HashMap::new();
        for e in 0..cut.edges.len() {
            for w in leaves.chain(e).windows(2) {
                edge_of.insert(pair(w[0], w[1]), e as u32);
            }
        }
        let by_ends = (0..cut.edges.len())
            .map(|e| {
                let [a, b] = cut.edges[e].ends;
                (pair(a, b), e as u32)
            })
            .collect();
        Walls {
            edge_of,
            leaves,
            by_ends,
        }
    }

    /// The chain of cut-graph edge `e`, from its first end to its second.
    fn chain(&self, e: u32) -> &[u32] {
        self.leaves.chain(e as usize)
    }

    /// The cut-graph edge the mesh edge `a b` lies on, if any.
    fn edge(&self, a: u32, b: u32) -> Option<u32> {
        self.edge_of.get(&pair(a, b)).copied()
    }
}

/// The triangle across the edge opposite each corner, or [`NONE`]: the one with the edge the
/// other way round. Every edge's two sides are found by one sort of the edges by their ends.
pub(crate) fn neighbours_of(triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut sides: Vec<(u64, u32)> = triangles
        .par_iter()
        .enumerate()
        .flat_map_iter(|(t, &[a, b, c])| {
            [(b, c), (c, a), (a, b)]
                .into_iter()
                .enumerate()
                .map(move |(i, (u, w))| {
                    let key = (u64::from(u.min(w)) << 32) | u64::from(u.max(w));
                    (key, (t as u32) * 3 + i as u32)
                })
        })
        .collect();
    sides.par_sort_unstable();
    let mut neighbours = vec![[NONE; 3]; triangles.len()];
    for pair in sides.windows(2) {
        let [(k0, s0), (k1, s1)] = [pair[0], pair[1]];
        if k0 == k1 {
            neighbours[(s0 / 3) as usize][(s0 % 3) as usize] = s1 / 3;
            neighbours[(s1 / 3) as usize][(s1 % 3) as usize] = s0 / 3;
        }
    }
    neighbours
}

/// Every piece of every chain must be an edge of the triangles: a leaf whose bent polygon left
/// an edge piece out would leave the graph unconformed.
fn check_walls(leaves: &GraphTriangulation, walls: &Walls) -> Result<(), Error> {
    let mut sides: Vec<(u32, u32)> = leaves
        .triangles
        .par_iter()
        .flat_map_iter(|&[a, b, c]| [pair(a, b), pair(b, c), pair(c, a)])
        .collect();
    sides.par_sort_unstable();
    sides.dedup();
    for (&(a, b), _) in walls.edge_of.iter() {
        if sides.binary_search(&(a, b)).is_err() {
            let at = (leaves.vertices[a as usize] + leaves.vertices[b as usize]) * 0.5;
            return Err(Error::WarpStuck {
                x: at.x,
                y: at.y,
                why: "a piece of an edge is no edge of the bent leaves' triangles",
            });
        }
    }
    Ok(())
}

/// The pieces the walls cut the triangles into: each triangle's piece, and how many.
fn pieces(triangles: &[[u32; 3]], neighbours: &[[u32; 3]], walls: &Walls) -> (Vec<u32>, usize) {
    let mut piece = vec![NONE; triangles.len()];
    let mut count = 0u32;
    let mut stack = Vec::new();
    for start in 0..triangles.len() {
        if piece[start] != NONE {
            continue;
        }
        piece[start] = count;
        stack.push(start);
        while let Some(t) = stack.pop() {
            let [a, b, c] = triangles[t];
            for (i, (u, w)) in [(b, c), (c, a), (a, b)].into_iter().enumerate() {
                let n = neighbours[t][i];
                if n != NONE && piece[n as usize] == NONE && walls.edge(u, w).is_none() {
                    piece[n as usize] = count;
                    stack.push(n as usize);
                }
            }
        }
        count += 1;
    }
    (piece, count as usize)
}

/// What each piece is: kept or not, in which region, inside caps or not; and the piece each
/// cap belongs to.
struct Faces {
    /// Per piece, whether it is outside the domain (reaches the root's side, or holds a hole
    /// seed).
    dropped: Vec<bool>,
    /// Per piece, its region seed, or [`NONE`].
    region: Vec<u32>,
    /// Per piece, whether it lies inside caps (two caps at one vertex that share a side not
    /// kept share one).
    cap_piece: Vec<bool>,
    /// Per cap, the piece beyond its cutting edge: the face of the wedge it was cut from,
    /// whose fate and region it shares.
    cap_of: Vec<u32>,
}

impl Faces {
    fn new(
        input: &Input,
        cut: &CornerCut,
        (piece, count): (&[u32], usize),
        neighbours: &[[u32; 3]],
        walls: &Walls,
        leaves: &GraphTriangulation,
        triangle_at: &(impl Fn(DVec2) -> Option<u32> + Sync),
    ) -> Result<Faces, Error> {
        let mut dropped = vec![false; count];
        for (t, across) in neighbours.iter().enumerate() {
            if across.contains(&NONE) {
                dropped[piece[t] as usize] = true;
            }
        }
        let cap_of = beyond_cutting_edges(cut, piece, walls, leaves)?;
        let mut cap_piece = vec![false; count];
        // Per cap, the piece inside it.
        let mut inside = Vec::with_capacity(cut.caps.len());
        for cap in &cut.caps {
            let [a, b, c] = [cap.apex, cap.ends[0], cap.ends[1]].map(|v| cut.points[v as usize]);
            let t = triangle_at((a + b + c) / 3.0).ok_or(Error::WarpStuck {
                x: a.x,
                y: a.y,
                why: "a cap lies outside the warped leaves",
            })?;
            let p = piece[t as usize];
            cap_piece[p as usize] = true;
            inside.push(p);
        }
        // The piece a seed names: none beyond every leaf (outside the domain, as in the
        // Delaunay mode), the face a cap was cut from for a seed inside the cap; refused on a
        // wall or on a cap's side.
        let seed_piece = |kind: &'static str, index: usize, at: DVec2| {
            let on_segment = Error::SeedOnSegment {
                kind,
                index,
                x: at.x,
                y: at.y,
            };
            let Some(t) = triangle_at(at) else {
                return Ok(None);
            };
            if on_wall(leaves, walls, t, at) {
                return Err(on_segment);
            }
            let p = piece[t as usize];
            if !cap_piece[p as usize] {
                return Ok(Some(p));
            }
            for (c, cap) in cut.caps.iter().enumerate().filter(|&(c, _)| inside[c] == p) {
                let [apex, a, b] =
                    [cap.apex, cap.ends[0], cap.ends[1]].map(|v| cut.points[v as usize]);
                let sides = [
                    orientation(apex, a, at),
                    orientation(a, b, at),
                    orientation(b, apex, at),
                ];
                if sides.contains(&Orientation::Right) {
                    continue;
                }
                if sides[0] == Orientation::On || sides[2] == Orientation::On {
                    return Err(on_segment);
                }
                return Ok(Some(cap_of[c]));
            }
            Ok(Some(p))
        };
        for (k, &hole) in input.holes.iter().enumerate() {
            if !hole.is_finite() {
                continue;
            }
            if let Some(p) = seed_piece("hole", k, hole)? {
                dropped[p as usize] = true;
            }
        }
        let mut region = vec![NONE; count];
        for (k, r) in input.regions.iter().enumerate() {
            if let Some(p) = seed_piece("region", k, r.seed)? {
                region[p as usize] = k as u32;
            }
        }
        Ok(Faces {
            dropped,
            region,
            cap_piece,
            cap_of,
        })
    }

    fn kept(&self, piece: usize) -> bool {
        !self.dropped[piece]
    }

    fn region_of(&self, piece: usize) -> u32 {
        self.region[piece]
    }
}

/// Per cap, the piece on the far side of its cutting edge from its apex.
fn beyond_cutting_edges(
    cut: &CornerCut,
    piece: &[u32],
    walls: &Walls,
    leaves: &GraphTriangulation,
) -> Result<Vec<u32>, Error> {
    let mut beyond = vec![NONE; cut.caps.len()];
    for (t, &[a, b, c]) in leaves.triangles.iter().enumerate() {
        // The triangle lies left of each of its sides, taken counterclockwise.
        for (u, w) in [(a, b), (b, c), (c, a)] {
            let Some(e) = walls.edge(u, w) else {
                continue;
            };
            let EdgeOrigin::Cut(k) = cut.edges[e as usize].origin else {
                continue;
            };
            let apex = cut.points[cut.caps[k as usize].apex as usize];
            let (pu, pw) = (leaves.vertices[u as usize], leaves.vertices[w as usize]);
            if beyond[k as usize] == NONE && orientation(pu, pw, apex) == Orientation::Right {
                beyond[k as usize] = piece[t];
            }
        }
    }
    match beyond.iter().position(|&p| p == NONE) {
        None => Ok(beyond),
        Some(k) => {
            let apex = cut.points[cut.caps[k].apex as usize];
            Err(Error::WarpStuck {
                x: apex.x,
                y: apex.y,
                why: "a cap's cutting edge has no leaf beyond it",
            })
        }
    }
}

/// Whether `at`, in triangle `t`, lies on one of its sides that is a wall (a point on a side
/// between two triangles of one piece names that piece either way).
fn on_wall(leaves: &GraphTriangulation, walls: &Walls, t: u32, at: DVec2) -> bool {
    let [a, b, c] = leaves.triangles[t as usize];
    [(a, b), (b, c), (c, a)].into_iter().any(|(u, w)| {
        let (pu, pw) = (leaves.vertices[u as usize], leaves.vertices[w as usize]);
        orientation(pu, pw, at) == Orientation::On && walls.edge(u, w).is_some()
    })
}

/// The mesh being written: the leaves' vertices (and the apexes of enclosed vertices' caps),
/// the triangles kept, their regions.
struct Output {
    vertices: Vec<DVec2>,
    /// Per vertex, the cleaned input point it is, or [`NONE`].
    vertex_input: Vec<u32>,
    /// Per cut point, its vertex once it has one.
    point_vertex: Vec<u32>,
    triangles: Vec<[u32; 3]>,
    regions: Vec<u32>,
}

impl Output {
    fn new(
        leaves: &GraphTriangulation,
        input: &Input,
        cut: &CornerCut,
        features: &[u32],
    ) -> Output {
        let inputs = input.points.len() as u32;
        let mut point_vertex = vec![NONE; cut.points.len()];
        let vertex_input = leaves
            .vertex_point
            .iter()
            .map(|&f| {
                if f == NONE {
                    return NONE;
                }
                let p = features[f as usize];
                if p < inputs { p } else { NONE }
            })
            .collect();
        for (f, &p) in features.iter().enumerate() {
            point_vertex[p as usize] = leaves.point_vertex[f];
        }
        Output {
            vertices: leaves.vertices.clone(),
            vertex_input,
            point_vertex,
            triangles: Vec::new(),
            regions: Vec::new(),
        }
    }

    fn push(&mut self, triangle: [u32; 3], region: u32) {
        self.triangles.push(triangle);
        self.regions.push(region);
    }

    /// The vertex of cut point `p`, made for an enclosed apex the first time it is asked for.
    fn vertex_of(&mut self, cut: &CornerCut, p: u32) -> u32 {
        if self.point_vertex[p as usize] == NONE {
            self.point_vertex[p as usize] = self.vertices.len() as u32;
            self.vertices.push(cut.points[p as usize]);
            self.vertex_input.push(p);
        }
        self.point_vertex[p as usize]
    }

    /// The polygon of a cap, counter-clockwise from its apex: along its first side (as the
    /// mesh divides it, where it is an edge of the cut graph), along its cutting edge, back
    /// along its second side.
    fn cap_polygon(&mut self, cut: &CornerCut, walls: &Walls, c: usize, cap: &Cap) -> Vec<u32> {
        let apex = self.vertex_of(cut, cap.apex);
        let side = |k: usize| -> Vec<u32> {
            match walls.by_ends.get(&pair(cap.apex, cap.ends[k])) {
                Some(&e) => {
                    let mut chain = walls.chain(e).to_vec();
                    if cut.edges[e as usize].ends[0] != cap.apex {
                        chain.reverse();
                    }
                    chain
                }
                None => vec![apex, self.point_vertex[cap.ends[k] as usize]],
            }
        };
        let first = side(0);
        let mut second = side(1);
        second.reverse();
        let cutting = walls
            .by_ends
            .get(&pair(cap.ends[0], cap.ends[1]))
            .filter(|&&e| cut.edges[e as usize].origin == EdgeOrigin::Cut(c as u32))
            .map(|&e| walls.chain(e).to_vec())
            .expect("every cap has its cutting edge");
        let mut polygon = first;
        polygon.extend(&cutting[1..]);
        polygon.extend(&second[1..second.len() - 1]);
        polygon
    }

    /// The mesh: the vertices the kept triangles use, renumbered in order; the segments'
    /// pieces; the boundary; the regions.
    fn finish(self, input: &Input, cut: &CornerCut, walls: &Walls) -> Mesh {
        let mut new_index = vec![NONE; self.vertices.len()];
        for t in &self.triangles {
            for &v in t {
                new_index[v as usize] = 0;
            }
        }
        let mut vertices = Vec::new();
        let mut vertex_input = Vec::new();
        for (v, slot) in new_index.iter_mut().enumerate() {
            if *slot == 0 {
                *slot = vertices.len() as u32;
                vertices.push(self.vertices[v]);
                vertex_input.push(self.vertex_input[v]);
            }
        }
        let triangles: Vec<[u32; 3]> = self
            .triangles
            .iter()
            .map(|t| t.map(|v| new_index[v as usize]))
            .collect();
        let neighbours = neighbours_of(&triangles);
        let pieces = segment_pieces(
            input,
            cut,
            walls,
            (&self.point_vertex, &new_index),
            &triangles,
        );
        let marker_of: HashMap<(u32, u32), i32> = pieces
            .iter()
            .map(|s| (pair(s.vertices[0], s.vertices[1]), s.marker))
            .collect();
        let boundary = boundary_edges(&triangles, &neighbours, &marker_of);
        let (lo, hi) = bounding_box(&vertices);
        let has_regions = !input.regions.is_empty();
        Mesh {
            vertices,
            vertex_input,
            triangles,
            neighbours,
            boundary,
            domain: Domain { lo, hi },
            outline: None,
            segments: pieces,
            triangle_regions: if has_regions {
                self.regions
            } else {
                Vec::new()
            },
            region_attributes: input.regions.iter().map(|r| r.attribute).collect(),
            holes: input.holes.clone(),
        }
    }
}

/// The pieces of each segment that borders the domain, in segment order and along each from
/// its first end: the chains of its cut-graph edges and its sides of caps that are none.
fn segment_pieces(
    input: &Input,
    cut: &CornerCut,
    walls: &Walls,
    (point_vertex, new_index): (&[u32], &[u32]),
    triangles: &[[u32; 3]],
) -> Vec<SubSegment> {
    let renumbered = |v: u32| {
        if v == NONE {
            NONE
        } else {
            new_index[v as usize]
        }
    };
    let mut runs: Vec<Vec<(u32, Vec<u32>)>> = vec![Vec::new(); input.segments.len()];
    for (e, edge) in cut.edges.iter().enumerate() {
        if let EdgeOrigin::Segment(s) = edge.origin {
            runs[s as usize].push((edge.ends[0], walls.chain(e as u32).to_vec()));
        }
    }
    for cap in &cut.caps {
        for k in 0..2 {
            let s = cap.sides[k];
            if walls.by_ends.contains_key(&pair(cap.apex, cap.ends[k])) {
                continue;
            }
            let (apex, end) = (
                point_vertex[cap.apex as usize],
                point_vertex[cap.ends[k] as usize],
            );
            let run = if input.segments[s as usize].ends[0] == cap.apex {
                (cap.apex, vec![apex, end])
            } else {
                (cap.ends[k], vec![end, apex])
            };
            if !runs[s as usize].iter().any(|(from, _)| *from == run.0) {
                runs[s as usize].push(run);
            }
        }
    }
    let mut edges: Vec<(u32, u32)> = triangles
        .iter()
        .flat_map(|&[a, b, c]| [pair(a, b), pair(b, c), pair(c, a)])
        .collect();
    edges.par_sort_unstable();
    edges.dedup();
    let mut out = Vec::new();
    for (s, run) in runs.iter_mut().enumerate() {
        let first = cut.points[input.segments[s].ends[0] as usize];
        run.sort_by(|x, y| {
            let (px, py) = (cut.points[x.0 as usize], cut.points[y.0 as usize]);
            first
                .distance_squared(px)
                .total_cmp(&first.distance_squared(py))
        });
        let marker = input.segments[s].marker;
        let pieces: Vec<SubSegment> = run
            .iter()
            .flat_map(|(_, chain)| chain.windows(2).map(|w| [w[0], w[1]]))
            .map(|[a, b]| SubSegment {
                vertices: [renumbered(a), renumbered(b)],
                segment: s as u32,
                marker,
            })
            .collect();
        let borders = pieces.iter().any(|p| {
            let [a, b] = p.vertices;
            a != NONE && b != NONE && edges.binary_search(&pair(a, b)).is_ok()
        });
        if borders {
            out.extend(pieces);
        }
    }
    out
}

/// The edges with a triangle on one side only, the domain on their left, with their segment's
/// marker ([`BOUNDARY_MARKER`] for a segment marked 0).
fn boundary_edges(
    triangles: &[[u32; 3]],
    neighbours: &[[u32; 3]],
    marker_of: &HashMap<(u32, u32), i32>,
) -> Vec<BoundaryEdge> {
    let mut boundary = Vec::new();
    for (t, &[a, b, c]) in triangles.iter().enumerate() {
        for (i, (u, w)) in [(b, c), (c, a), (a, b)].into_iter().enumerate() {
            if neighbours[t][i] == NONE {
                let marker = match marker_of.get(&pair(u, w)) {
                    Some(&m) if m != 0 => m,
                    _ => BOUNDARY_MARKER,
                };
                boundary.push(BoundaryEdge {
                    vertices: [u, w],
                    marker,
                });
            }
        }
    }
    boundary
}
