//! The planar straight-line graphs on which peer meshers run out of memory, assert or refine
//! without end, built once for the tests (`tests/peer_failures.rs`) and for the example that
//! writes them as `.poly` files for measuring beside Triangle (`examples/peer_failure_cases.rs`).
//! It uses the library alone.

use quadmesh::{DVec2, Input, Segment};

/// One case: a short name (a file name), the graph, and whether its crossings are to be split
/// (Triangle splits them; quadmesh refuses them unless asked).
pub struct PeerCase {
    pub name: &'static str,
    pub input: Input,
    pub split_crossings: bool,
}

/// The closed polygon through `corners`, every side with `marker`.
pub fn polygon(corners: &[(f64, f64)], marker: i32) -> Input {
    let points: Vec<DVec2> = corners.iter().map(|&(x, y)| DVec2::new(x, y)).collect();
    let n = points.len() as u32;
    let segments = (0..n)
        .map(|k| Segment {
            ends: [k, (k + 1) % n],
            marker,
        })
        .collect();
    Input {
        points,
        segments,
        ..Input::default()
    }
}

/// The unit square (marker 1) with one more segment between points `ends` with `marker`, after
/// `extra` points are added.
fn unit_square_with(extra: &[(f64, f64)], ends: [u32; 2], marker: i32) -> Input {
    let mut input = polygon(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)], 1);
    input
        .points
        .extend(extra.iter().map(|&(x, y)| DVec2::new(x, y)));
    input.segments.push(Segment { ends, marker });
    input
}

/// Adds a loose segment from `a` to `b` (two new points) with marker 7.
pub fn push_segment(input: &mut Input, a: DVec2, b: DVec2) {
    let first = input.points.len() as u32;
    input.points.extend([a, b]);
    input.segments.push(Segment {
        ends: [first, first + 1],
        marker: 7,
    });
}

/// The unit square with two segments 2e-13 apart across its middle (Triangle at `-pq20`
/// allocates until killed: the strip between them needs about 1e12 triangles).
pub fn two_segments_2e_13_apart() -> Input {
    let mut input = polygon(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)], 1);
    push_segment(&mut input, DVec2::new(0.2, 0.5), DVec2::new(0.8, 0.5));
    push_segment(
        &mut input,
        DVec2::new(0.2, 0.5 + 2e-13),
        DVec2::new(0.8, 0.5 + 2e-13),
    );
    input
}

/// A hexagon with a spike of a thousandth of a degree.
pub fn a_spike_of_a_thousandth_of_a_degree() -> Input {
    let spike = 0.001f64.to_radians();
    let tip = DVec2::new(3.0, 1.0);
    let back = tip + 2.0 * DVec2::new(-spike.cos(), -spike.sin());
    polygon(
        &[
            (0.0, 0.0),
            (4.0, 0.0),
            (4.0, 1.0),
            (tip.x, tip.y),
            (back.x, back.y),
            (0.0, 3.0),
        ],
        1,
    )
}

/// A square with a dangling segment from a corner to its middle.
pub fn a_crack_into_the_domain() -> Input {
    let mut input = polygon(&[(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0)], 1);
    input.points.push(DVec2::new(1.0, 1.0));
    input.segments.push(Segment {
        ends: [0, 4],
        marker: 9,
    });
    input
}

/// Six points within 3e-12 of a line, joined by segments, inside a rectangle.
pub fn six_near_collinear_points() -> Input {
    let ys = [0.0, 1e-12, -1e-12, 2e-12, 0.0, -3e-12];
    let mut input = polygon(&[(-1.0, -1.0), (6.0, -1.0), (6.0, 1.0), (-1.0, 1.0)], 1);
    for (k, &y) in ys.iter().enumerate() {
        input.points.push(DVec2::new(k as f64, y));
    }
    for k in 0..5u32 {
        input.segments.push(Segment {
            ends: [4 + k, 5 + k],
            marker: 2,
        });
    }
    input
}

/// The unit square with its corner (1, 1) given twice, the copy used by a segment.
pub fn a_duplicated_vertex_used_by_segments() -> Input {
    unit_square_with(&[(1.0, 1.0), (0.25, 0.5)], [4, 5], 3)
}

/// A square of side 3 with two segments crossing where no f64 lies, and a third through
/// their crossing.
pub fn segments_crossing_where_no_float_lies() -> Input {
    let mut input = polygon(&[(0.0, 0.0), (3.0, 0.0), (3.0, 3.0), (0.0, 3.0)], 1);
    push_segment(&mut input, DVec2::new(0.1, 0.3), DVec2::new(2.9, 2.7));
    push_segment(&mut input, DVec2::new(0.3, 2.9), DVec2::new(2.7, 0.1));
    push_segment(&mut input, DVec2::new(1.5, 0.2), DVec2::new(1.5, 2.8));
    input
}

/// A quadrilateral of side `side`.
pub fn a_polygon_of_side(side: f64) -> Input {
    polygon(
        &[(0.0, 0.0), (side, 0.0), (side, side / 2.0), (0.0, side)],
        1,
    )
}

/// A square of side 2 with hole seeds outside it and on a side.
pub fn hole_seeds_outside_and_on_a_segment() -> Input {
    let mut input = polygon(&[(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0)], 1);
    input.holes = vec![DVec2::splat(9.0), DVec2::new(1.0, 0.0)];
    input
}

/// A quadrilateral whose sides cross at its waist.
pub fn a_bow_tie() -> Input {
    polygon(&[(0.0, 0.0), (2.0, 2.0), (2.0, 0.0), (0.0, 2.0)], 1)
}

/// Two sides of a triangle: a graph that encloses nothing.
pub fn an_open_graph() -> Input {
    let mut open = polygon(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)], 1);
    open.segments.pop();
    open
}

/// Three points on a line, joined by two segments.
pub fn all_vertices_collinear() -> Input {
    let mut input = polygon(&[(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)], 1);
    input.segments.pop();
    input
}

/// Three nested squares in a zero-based `.poly` file: the middle one a hole.
pub const NESTED_HOLES_POLY: &str = "\
12 2 0 0
0 0 0
1 6 0
2 6 6
3 0 6
4 1 1
5 5 1
6 5 5
7 1 5
8 2 2
9 4 2
10 4 4
11 2 4
12 0
0 0 1
1 1 2
2 2 3
3 3 0
4 4 5
5 5 6
6 6 7
7 7 4
8 8 9
9 9 10
10 10 11
11 11 8
1
0 1.5 3
";

/// The unit square with a segment from its corner (1, 1) to itself.
pub fn a_zero_length_segment() -> Input {
    unit_square_with(&[], [2, 2], 5)
}

/// The unit square with a segment to a point that is not there.
pub fn an_out_of_range_index() -> Input {
    unit_square_with(&[], [0, 99], 5)
}

/// Every case, in the order of the issue that lists them.
pub fn peer_failure_cases() -> Vec<PeerCase> {
    let case = |name, input, split_crossings| PeerCase {
        name,
        input,
        split_crossings,
    };
    let nested = quadmesh::io::parse_poly_input(NESTED_HOLES_POLY, "nested.poly")
        .expect("a valid .poly file");
    vec![
        case("segments_2e-13_apart", two_segments_2e_13_apart(), false),
        case(
            "spike_0.001_degrees",
            a_spike_of_a_thousandth_of_a_degree(),
            false,
        ),
        case("crack", a_crack_into_the_domain(), false),
        case("six_near_collinear", six_near_collinear_points(), false),
        case(
            "duplicated_vertex",
            a_duplicated_vertex_used_by_segments(),
            false,
        ),
        case(
            "crossing_without_float",
            segments_crossing_where_no_float_lies(),
            true,
        ),
        case("side_1e300", a_polygon_of_side(1e300), false),
        case("side_1e-300", a_polygon_of_side(1e-300), false),
        case(
            "hole_seeds_outside_and_on_segment",
            hole_seeds_outside_and_on_a_segment(),
            false,
        ),
        case("open_graph", an_open_graph(), false),
        case("bow_tie", a_bow_tie(), true),
        case("zero_length_segment", a_zero_length_segment(), false),
        case("out_of_range_index", an_out_of_range_index(), false),
        case("all_collinear", all_vertices_collinear(), false),
        case("nested_holes_zero_based", nested, false),
    ]
}
