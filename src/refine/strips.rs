//! The Delaunay triangulation of many points, built in vertical strips in parallel.
//!
//! Seams split the domain into strips of about equal point counts, each seam strictly between
//! the x coordinates of the points on its two sides, so that no point lies on one. Each strip is
//! triangulated on its own (its corners and its points in Morton order); the strips are then
//! glued along their common sides into one triangulation of the domain, which Lawson's edge
//! flips from the seams make Delaunay. The ends of each seam stay as vertices on the domain's
//! bottom and top sides.
//!
//! A strip's side is one edge, so the points next to a seam are fanned to the seam's two ends,
//! and the flips undo those fans. Where points spread over an area the fans are small; where
//! curves leave empty stretches beside a seam they hold thousands of points, and the flips grow
//! with the square of their size (200 000 points on nested rings: 75 million flips, 5.8 s).
//! Graphs, whose points lie on curves, are therefore glued only where their points crowd every
//! seam, and within a budget of flips; elsewhere their points go in one sequence.
//!
//! The strips depend on the points alone, never on the thread count, and the flips run in a
//! fixed order, so the result is the same on any number of threads.

use glam::DVec2;
use rayon::prelude::*;

use super::delaunay::{Store, Triangulation};
use super::{insert_in_one_sequence, insert_in_order};
use crate::error::Error;
use crate::mesh::{Domain, NONE};

/// Points per strip, about: enough that the seams are a small part of the work, few enough
/// that there are strips for every thread.
const POINTS_PER_STRIP: usize = 1 << 15;

/// The most strips.
const MAX_STRIPS: usize = 1 << u8::BITS;

/// How many strips `points` points are split into; one means no split.
pub(super) fn strip_count(points: usize) -> usize {
    (points / POINTS_PER_STRIP).clamp(1, MAX_STRIPS)
}

/// The flips a graph's seams may take, per point, before its strips are given up for one
/// sequence of insertions.
const FLIPS_PER_POINT: usize = 8;

/// Where strips are glued.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Seams {
    /// Wherever they fall: for point sets, spread over an area.
    Always,
    /// Only where the points crowd every seam, and within [`FLIPS_PER_POINT`]; in one sequence
    /// elsewhere: for graphs, whose points lie on curves.
    WhereCrowded,
}

/// One strip's triangulation: local vertices 0 to 3 are its corners, counter-clockwise from
/// the lower left, then its points; `vertex_input` gives their input indices.
struct Strip {
    t: Triangulation,
    vertex_input: Vec<u32>,
    /// The triangle and corner facing the strip's right side, and its left side, where those
    /// are seams.
    right_side: (u32, usize),
    left_side: (u32, usize),
}

/// The Delaunay triangulation of `domain` and the points `order` names (distinct, inside the
/// domain, in Morton order) built in about `count` strips, with room for `capacity` vertices;
/// and the input index of each vertex (`NONE` for the domain's corners and the seams' ends,
/// unless a point lies on a domain corner).
pub(super) fn triangulate(
    points: &[DVec2],
    order: &[u32],
    domain: Domain,
    count: usize,
    capacity: usize,
    glue_at: Seams,
) -> Result<(Triangulation, Vec<u32>), Error> {
    let seams = seams(points, domain, count);
    let budget = match glue_at {
        Seams::Always => usize::MAX,
        Seams::WhereCrowded if crowded(points, order.len(), &seams) => {
            FLIPS_PER_POINT * order.len() + (1 << 16)
        }
        Seams::WhereCrowded => return insert_in_one_sequence(points, order, domain, capacity),
    };
    let orders = strip_orders(points, order, &seams);
    let mut sides = Vec::with_capacity(seams.len() + 2);
    sides.push(domain.lo.x);
    sides.extend_from_slice(&seams);
    sides.push(domain.hi.x);
    let strips: Vec<Strip> = orders
        .par_iter()
        .enumerate()
        .map(|(k, order)| {
            let lo = DVec2::new(sides[k], domain.lo.y);
            let hi = DVec2::new(sides[k + 1], domain.hi.y);
            strip(points, order, (lo, hi), [k > 0, k < seams.len()])
        })
        .collect::<Result<_, _>>()?;
    let (mut t, vertex_input, seam_edges) = glue(&strips, &seams, domain, capacity);
    drop(strips);
    if t.flip_to_delaunay_within(seam_edges, budget) {
        return Ok((t, vertex_input));
    }
    drop(t);
    insert_in_one_sequence(points, order, domain, capacity)
}

/// Whether `distinct` points crowd the seams: probes along each seam, about the points' mean
/// spacing over their bounding box apart, at most an eighth of them with no point within a
/// spacing. A probe alone marks an empty stretch beside the seam, where the glue's fans grow
/// (the nested rings: most probes alone; a block with many small holes: none).
fn crowded(points: &[DVec2], distinct: usize, seams: &[f64]) -> bool {
    let (lo, hi) = crate::morton::bounding_box(points);
    let size = hi - lo;
    let spacing = (size.x * size.y / distinct.max(1) as f64).sqrt();
    // A NaN count converts to 0, an infinite one to the most.
    let probes = ((size.y / spacing).ceil() as u64).clamp(1, MAX_PROBES);
    if probes < 2 {
        return true;
    }
    let bin = |y: f64| ((y - lo.y) / size.y * probes as f64) as u64;
    // (seam, bin) of every point within a spacing of a seam.
    let mut near: Vec<(u32, u64)> = points
        .par_iter()
        .filter_map(|p| {
            let j = seams.partition_point(|&s| s < p.x);
            [j.checked_sub(1), (j < seams.len()).then_some(j)]
                .into_iter()
                .flatten()
                .find(|&k| (p.x - seams[k]).abs() < spacing)
                .map(|k| (k as u32, bin(p.y)))
        })
        .collect();
    near.par_sort_unstable();
    near.dedup();
    let alone: usize = (0..seams.len() as u32)
        .into_par_iter()
        .map(|k| {
            (1..probes)
                .filter(|&b| {
                    let around = (k, b - 1)..=(k, b + 1);
                    let first = near.partition_point(|e| e < around.start());
                    near.get(first).is_none_or(|e| !around.contains(e))
                })
                .count()
        })
        .sum();
    8 * alone <= seams.len() * (probes as usize - 1)
}

/// The most probes along a seam.
const MAX_PROBES: u64 = 1 << 16;

/// Seam x coordinates, increasing, splitting the points into about `count` strips of equal
/// size: each lies strictly between the largest x on its left and the smallest on its right.
/// Where no float lies between the two, that seam is left out. (Duplicate points count once
/// per copy here, which only shifts the balance.)
fn seams(points: &[DVec2], domain: Domain, count: usize) -> Vec<f64> {
    // Cut at the quantiles of a sample; a point goes left of cut `q` when its x is below `q`.
    const SAMPLE_STEP: usize = 16;
    let mut sample: Vec<f64> = points
        .par_iter()
        .step_by(SAMPLE_STEP)
        .map(|p| p.x)
        .collect();
    sample.par_sort_unstable_by(f64::total_cmp);
    let mut cuts: Vec<f64> = (1..count)
        .map(|k| sample[k * sample.len() / count])
        .collect();
    cuts.dedup();
    // The x range of the points between consecutive cuts.
    let empty = vec![(f64::INFINITY, f64::NEG_INFINITY); cuts.len() + 1];
    let ranges = points
        .par_iter()
        .fold(
            || empty.clone(),
            |mut ranges, p| {
                let r = &mut ranges[cuts.partition_point(|&q| q <= p.x)];
                *r = (r.0.min(p.x), r.1.max(p.x));
                ranges
            },
        )
        .reduce(
            || empty.clone(),
            |mut a, b| {
                for (r, s) in a.iter_mut().zip(b) {
                    *r = (r.0.min(s.0), r.1.max(s.1));
                }
                a
            },
        );
    let mut seams = Vec::new();
    let mut left_max = f64::NEG_INFINITY;
    for &(min, max) in &ranges {
        if min > max {
            continue;
        }
        let seam = 0.5 * left_max + 0.5 * min;
        if left_max > f64::NEG_INFINITY && left_max < seam && seam < min {
            seams.push(seam);
        }
        left_max = left_max.max(max);
    }
    debug_assert!(seams.iter().all(|&s| domain.lo.x < s && s < domain.hi.x));
    seams
}

/// Each strip's points, in the order given.
fn strip_orders(points: &[DVec2], order: &[u32], seams: &[f64]) -> Vec<Vec<u32>> {
    // Strip numbers in input order first: streaming through the points is cheaper than
    // visiting them in Morton order.
    let strip_of: Vec<u8> = points
        .par_iter()
        .map(|p| seams.partition_point(|&s| s < p.x) as u8)
        .collect();
    let mut orders = vec![Vec::new(); seams.len() + 1];
    for &i in order {
        orders[strip_of[i as usize] as usize].push(i);
    }
    orders
}

/// The Delaunay triangulation of the rectangle `[lo, hi]` and the points `order` names.
/// `inner` says whether its left and its right side are seams.
fn strip(
    points: &[DVec2],
    order: &[u32],
    (lo, hi): (DVec2, DVec2),
    inner: [bool; 2],
) -> Result<Strip, Error> {
    let mut t = Triangulation::rectangle(lo, hi);
    t.reserve(order.len() + 4, order.len() + 4);
    let vertex_input = insert_in_order(&mut t, points, order)?;
    // No point lies on a seam, so a side that is one is still one edge: corners 3 → 0 on the
    // left, 1 → 2 on the right.
    let side = |inner: bool, ends: (u32, u32)| {
        if !inner {
            return (NONE, 0);
        }
        (0..t.len() as u32)
            .find_map(|id| {
                let tri = t.triangle(id);
                (0..3)
                    .find(|&i| tri.n[i] == NONE && tri.edge(i) == ends)
                    .map(|i| (id, i))
            })
            .expect("a seam is one edge of its strips")
    };
    let (left_side, right_side) = (side(inner[0], (3, 0)), side(inner[1], (1, 2)));
    Ok(Strip {
        t,
        vertex_input,
        right_side,
        left_side,
    })
}

/// The strips as one triangulation, each strip's right side linked to the next one's left
/// side. Vertices: the domain's corners, the seams' bottom and top ends, then each strip's
/// points; triangles: each strip's in turn. Also returns the seam edges, as (triangle, corner)
/// of each strip's right side.
fn glue(
    strips: &[Strip],
    seams: &[f64],
    domain: Domain,
    capacity: usize,
) -> (Triangulation, Vec<u32>, Vec<(u32, usize)>) {
    let last = strips.len() - 1;
    let seam_end = |seam: usize, top: bool| (4 + 2 * seam + usize::from(top)) as u32;
    // Global numbers of strip k's corners, counter-clockwise from its lower left.
    let corners_of = |k: usize| -> [u32; 4] {
        [
            if k == 0 { 0 } else { seam_end(k - 1, false) },
            if k == last { 1 } else { seam_end(k, false) },
            if k == last { 2 } else { seam_end(k, true) },
            if k == 0 { 3 } else { seam_end(k - 1, true) },
        ]
    };
    let mut head = Triangulation::rectangle(domain.lo, domain.hi).vertices;
    for &x in seams {
        head.extend([DVec2::new(x, domain.lo.y), DVec2::new(x, domain.hi.y)]);
    }
    let vertex_starts =
        crate::par::exclusive_scan_by(strips.len(), |k| strips[k].t.vertices.len() - 4);
    let triangle_starts = crate::par::exclusive_scan_by(strips.len(), |k| strips[k].t.len());
    let vertex_of = |k: usize, v: u32| -> u32 {
        if v < 4 {
            corners_of(k)[v as usize]
        } else {
            (head.len() + vertex_starts[k]) as u32 + v - 4
        }
    };
    // Vertices: the head, then each strip's points.
    let vertex_offsets: Vec<usize> = std::iter::once(0)
        .chain(vertex_starts.iter().map(|&s| head.len() + s))
        .collect();
    let parts: Vec<&[DVec2]> = std::iter::once(&head[..])
        .chain(strips.iter().map(|s| &s.t.vertices[4..]))
        .collect();
    let vertices = crate::par::collect_segments_with_capacity(&vertex_offsets, capacity, |k| {
        parts[k].iter().copied()
    });
    let triangles = 2 * capacity;
    let corners = crate::par::collect_segments_with_capacity(&triangle_starts, triangles, |k| {
        strips[k]
            .t
            .corners
            .iter()
            .map(move |c| c.map(|v| vertex_of(k, v)))
    });
    let mut across = crate::par::collect_segments_with_capacity(&triangle_starts, triangles, |k| {
        let start = triangle_starts[k] as u32;
        strips[k]
            .t
            .across
            .iter()
            .map(move |n| n.map(|u| if u == NONE { NONE } else { start + u }))
    });
    let mut seam_edges = Vec::with_capacity(last);
    for k in 0..last {
        let (r, i) = strips[k].right_side;
        let (l, j) = strips[k + 1].left_side;
        let (r, l) = (
            triangle_starts[k] as u32 + r,
            triangle_starts[k + 1] as u32 + l,
        );
        across[r as usize][i] = l;
        across[l as usize][j] = r;
        seam_edges.push((r, i));
    }
    let mut vertex_input = vec![NONE; head.len()];
    for (corner, (k, local)) in [(0, 0), (last, 1), (last, 2), (0, 3)]
        .into_iter()
        .enumerate()
    {
        vertex_input[corner] = strips[k].vertex_input[local];
    }
    for s in strips {
        vertex_input.extend_from_slice(&s.vertex_input[4..]);
    }
    let t = Triangulation {
        vertices,
        corners,
        across,
        regions: Vec::new(),
        segment_of: Vec::new(),
        canonical: false,
        free_slots: Vec::new(),
        freed_vertices: Vec::new(),
        vertices_deleted: 0,
    };
    (t, vertex_input, seam_edges)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::{Distribution2d, points as generated};
    use crate::mesh::AngleBounds;
    use crate::morton::{Morton, SortAlgorithm, morton_order};

    fn bounding_box(points: &[DVec2]) -> Domain {
        let (lo, hi) = crate::morton::bounding_box(points);
        Domain { lo, hi }
    }

    /// The strips' triangulation of `points`, as a mesh, with the number of strips made.
    fn mesh_in_strips(points: &[DVec2], domain: Domain, count: usize) -> (crate::Mesh, usize) {
        mesh_glued(points, domain, count, Seams::Always)
    }

    /// As [`mesh_in_strips`], glued at `glue_at`; one strip where the points went in one
    /// sequence.
    fn mesh_glued(
        points: &[DVec2],
        domain: Domain,
        count: usize,
        glue_at: Seams,
    ) -> (crate::Mesh, usize) {
        let order = match morton_order(points, SortAlgorithm::default()).unwrap() {
            Morton::Narrow(m) => m.order,
            Morton::Wide(m) => m.order,
        };
        let seams = seams(points, domain, count).len();
        let (t, vertex_input) = triangulate(points, &order, domain, count, 0, glue_at).unwrap();
        // Every point once, and besides them the seams' ends and the corners no point is on.
        let inputs = vertex_input.iter().filter(|&&i| i != NONE).count();
        assert_eq!(inputs, order.len());
        let others = t.vertices.len() - inputs;
        let strips = if glue_at == Seams::WhereCrowded && others <= 4 && seams > 2 {
            1
        } else {
            assert!((2 * seams..=2 * seams + 4).contains(&others));
            seams + 1
        };
        (
            super::super::into_mesh(t, vertex_input, domain, super::super::Boundary::Rectangle),
            strips,
        )
    }

    fn assert_delaunay_mesh(points: &[DVec2], mesh: &crate::Mesh, what: &str) {
        let any_angle = AngleBounds {
            min_deg: 0.0,
            max_deg: 180.0,
        };
        if let Err(fault) = mesh.validate(points, any_angle) {
            panic!("{what}: invalid: {fault}");
        }
        if let Err(fault) = mesh.check_delaunay() {
            panic!("{what}: not Delaunay: {fault}");
        }
    }

    #[test]
    fn strips_glue_into_a_delaunay_triangulation() {
        for dist in Distribution2d::ALL {
            let points = generated(dist, 6000, 5);
            // The bounding box puts points on every side, and some on its corners.
            let domain = bounding_box(&points);
            for count in [2, 3, 7, 40] {
                let (mesh, strips) = mesh_in_strips(&points, domain, count);
                assert!(strips > 1, "{dist:?} in {count}: no seam placed");
                assert_delaunay_mesh(&points, &mesh, &format!("{dist:?} in {count} strips"));
            }
        }
    }

    #[test]
    fn points_sharing_x_coordinates_never_lie_on_a_seam() {
        // Columns of points: a seam can only go between columns.
        let points: Vec<DVec2> = (0..4000)
            .map(|i| DVec2::new((i % 5) as f64, (i / 5) as f64 * 0.25))
            .collect();
        let domain = Domain {
            lo: DVec2::new(-1.0, -1.0),
            hi: DVec2::new(5.0, 1000.0),
        };
        let seams = seams(&points, domain, 16);
        assert_eq!(seams, vec![0.5, 1.5, 2.5, 3.5]);
        let (mesh, _) = mesh_in_strips(&points, domain, 16);
        assert_delaunay_mesh(&points, &mesh, "columns");
        // One column: no seam at all, and one strip.
        let column: Vec<DVec2> = (0..100).map(|i| DVec2::new(2.0, i as f64)).collect();
        assert!(super::seams(&column, domain, 4).is_empty());
        let (mesh, strips) = mesh_in_strips(&column, domain, 4);
        assert_eq!(strips, 1);
        assert_delaunay_mesh(&column, &mesh, "one column");
    }

    #[test]
    fn strips_give_the_same_triangulation_on_any_thread_count() {
        let points = generated(Distribution2d::Kuzmin, 20_000, 9);
        let domain = bounding_box(&points);
        let on = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| mesh_in_strips(&points, domain, 9).0)
        };
        let one = on(1);
        assert_delaunay_mesh(&points, &one, "Kuzmin in 9 strips");
        assert!(one == on(2) && one == on(3));
    }

    /// Points on `rings` circles around the origin, `per_ring` on each, slightly wavy.
    fn rings(rings: usize, per_ring: usize) -> Vec<DVec2> {
        (1..=rings)
            .flat_map(|r| {
                (0..per_ring).map(move |k| {
                    let a = std::f64::consts::TAU * k as f64 / per_ring as f64;
                    let radius = r as f64 * (1.0 + 0.01 * (7.0 * a).sin());
                    DVec2::new(radius * a.cos(), radius * a.sin())
                })
            })
            .collect()
    }

    #[test]
    fn graph_points_crowding_the_seams_are_glued_in_strips() {
        // Small rings packed in a block, as the sides of many small holes.
        let mut holes = Vec::new();
        for i in 0..30 {
            for j in 0..30 {
                let centre = DVec2::new(i as f64, j as f64);
                holes.extend(rings(1, 8).into_iter().map(|p| centre + 0.3 * p));
            }
        }
        let domain = bounding_box(&holes);
        for count in [2, 5, 16] {
            let (mesh, strips) = mesh_glued(&holes, domain, count, Seams::WhereCrowded);
            assert!(strips > 1, "{count} strips: went in one sequence");
            assert_delaunay_mesh(&holes, &mesh, &format!("holes in {count} strips"));
        }
    }

    #[test]
    fn graph_points_on_far_apart_curves_go_in_one_sequence() {
        // Rings far apart compared with the points' spacing: most of each seam runs through
        // empty stretches between them.
        let points = rings(6, 4000);
        let domain = bounding_box(&points);
        let (mesh, strips) = mesh_glued(&points, domain, 6, Seams::WhereCrowded);
        assert_eq!(strips, 1);
        assert_delaunay_mesh(&points, &mesh, "rings");
        // Glued anyway (only slower), they give a Delaunay triangulation too.
        let (glued, strips) = mesh_in_strips(&points, domain, 6);
        assert!(strips > 1);
        assert_delaunay_mesh(&points, &glued, "rings in strips");
    }
}
