//! Acute corners cut off a graph before the quadtree stage: every property the stage after relies
//! on, checked by brute force on graphs full of acute wedges (Delaunay triangulations of random
//! points, fans of spokes, slivers at 1° and 0.01°), on graphs with none (rings, blocks with
//! holes), on Triangle's examples, and on 1 and 2 threads.

mod common;

use common::graphs::{delaunay_graph, fan, segment, sliver};

use quadmesh::pslg::{
    CAP_FRACTION, CleanOptions, CornerCut, EdgeOrigin, clean, cut_acute_corners, feature_distances,
};
use quadmesh::{DVec2, Error, Input};

/// Cuts on one and two threads, checks both agree and every property, and returns the cut.
fn cut_checked(input: &Input) -> CornerCut {
    let one = common::on_threads(1, || cut_acute_corners(input)).expect("a cut");
    let two = common::on_threads(2, || cut_acute_corners(input)).expect("a cut");
    assert_eq!(one, two, "1 and 2 threads cut differently");
    check_cut(input, &one);
    one
}

fn ends(input: &Input) -> Vec<[u32; 2]> {
    input.segments.iter().map(|s| s.ends).collect()
}

fn segment_distance(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
    p.distance(a + ab * t)
}

/// The distance from each point to the nearest other point or segment not ending at it, by
/// trying them all.
fn brute_feature_distances(input: &Input) -> Vec<f64> {
    let p = &input.points;
    (0..p.len())
        .map(|v| {
            let to_points = (0..p.len())
                .filter(|&u| u != v)
                .map(|u| p[u].distance(p[v]));
            let to_segments = input
                .segments
                .iter()
                .filter(|s| !s.ends.contains(&(v as u32)))
                .map(|s| segment_distance(p[v], p[s.ends[0] as usize], p[s.ends[1] as usize]));
            to_points.chain(to_segments).fold(f64::INFINITY, f64::min)
        })
        .collect()
}

/// The directions of the segments at `v`, as angles in degrees in [0, 360), sorted.
fn star_angles(input: &Input, v: usize) -> Vec<f64> {
    let mut angles: Vec<f64> = input
        .segments
        .iter()
        .filter_map(|s| match s.ends {
            [a, b] if a as usize == v => Some(b),
            [a, b] if b as usize == v => Some(a),
            _ => None,
        })
        .map(|u| {
            let d = input.points[u as usize] - input.points[v];
            d.y.atan2(d.x).to_degrees().rem_euclid(360.0)
        })
        .collect();
    angles.sort_by(f64::total_cmp);
    angles
}

/// The wedges between consecutive directions (the last one wrapping around).
fn wedges(angles: &[f64]) -> Vec<f64> {
    if angles.len() < 2 {
        return Vec::new();
    }
    (0..angles.len())
        .map(|i| (angles[(i + 1) % angles.len()] - angles[i]).rem_euclid(360.0))
        .collect()
}

fn orient(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    robust::orient2d(
        robust::Coord { x: a.x, y: a.y },
        robust::Coord { x: b.x, y: b.y },
        robust::Coord { x: c.x, y: c.y },
    )
}

/// Whether `p` lies in the closed triangle `t` (counterclockwise).
fn in_triangle(p: DVec2, t: [DVec2; 3]) -> bool {
    (0..3).all(|i| orient(t[i], t[(i + 1) % 3], p) >= 0.0)
}

/// Whether the closed segments `ab` and `cd` meet.
fn segments_meet(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    let (o1, o2) = (orient(a, b, c), orient(a, b, d));
    let (o3, o4) = (orient(c, d, a), orient(c, d, b));
    if o1 * o2 < 0.0 && o3 * o4 < 0.0 {
        return true;
    }
    let on = |p: DVec2, q: DVec2, r: DVec2, o: f64| {
        o == 0.0
            && r.x >= p.x.min(q.x)
            && r.x <= p.x.max(q.x)
            && r.y >= p.y.min(q.y)
            && r.y <= p.y.max(q.y)
    };
    on(a, b, c, o1) || on(a, b, d, o2) || on(c, d, a, o3) || on(c, d, b, o4)
}

/// Every property of a cut, checked apart from the code that makes it.
fn check_cut(input: &Input, cut: &CornerCut) {
    let n = input.points.len();
    let p = &input.points;
    let q = &cut.points;
    // The input's points come first, bit for bit.
    assert!(q.len() >= n);
    for (a, b) in p.iter().zip(q) {
        assert_eq!(
            (a.x.to_bits(), a.y.to_bits()),
            (b.x.to_bits(), b.y.to_bits())
        );
    }
    let distances = brute_feature_distances(input);
    let mut acute_at = vec![false; n];
    for v in 0..n {
        let w = wedges(&star_angles(input, v));
        // A wedge within 1e-9° of 90° may go either way.
        let clear = w.iter().all(|a| !(90.0 - 1e-9..=90.0 + 1e-9).contains(a));
        acute_at[v] = w.iter().any(|&a| a < 90.0 - 1e-9);
        let r = cut.cap_radius[v];
        if clear {
            assert_eq!(r > 0.0, acute_at[v], "vertex {v}: wedges {w:?}, radius {r}");
        }
        if r > 0.0 {
            let shortest = input
                .segments
                .iter()
                .filter(|s| s.ends.contains(&(v as u32)))
                .map(|s| p[s.ends[0] as usize].distance(p[s.ends[1] as usize]))
                .fold(f64::INFINITY, f64::min);
            let bound = CAP_FRACTION * distances[v].min(shortest);
            assert!(
                (r - bound).abs() <= 1e-12 * bound,
                "vertex {v}: radius {r}, expected {bound}"
            );
        }
    }
    // Each cap: its apex's radius, its ends on its sides, counterclockwise, below 90° at the
    // apex, and nothing else of the input in it.
    for (c, cap) in cut.caps.iter().enumerate() {
        let v = cap.apex as usize;
        let r = cut.cap_radius[v];
        let t = [p[v], q[cap.ends[0] as usize], q[cap.ends[1] as usize]];
        assert!(
            orient(t[0], t[1], t[2]) > 0.0,
            "cap {c} is not counterclockwise"
        );
        assert!(
            (t[1] - t[0]).dot(t[2] - t[0]) > 0.0,
            "cap {c} is not acute at its apex"
        );
        for (k, &s) in cap.sides.iter().enumerate() {
            let [a, b] = input.segments[s as usize].ends;
            assert!(
                a as usize == v || b as usize == v,
                "cap {c} side {s} misses its apex"
            );
            let (a, b) = (p[a as usize], p[b as usize]);
            let at = t[k + 1];
            // Rounding the cut point moves it by an ulp of its coordinates.
            let ulps = 4.0 * f64::EPSILON * at.abs().max(a.abs()).max(b.abs()).max_element();
            let away = segment_distance(at, a, b);
            assert!(away <= ulps, "cap {c}: a cut {away} off its side");
            let off = (at.distance(t[0]) - r).abs();
            assert!(off <= 1e-12 * r + ulps, "cap {c}: a cut off its radius");
        }
        for u in (0..n).filter(|&u| u != v) {
            assert!(!in_triangle(p[u], t), "cap {c} holds point {u}");
        }
        for s in input
            .segments
            .iter()
            .filter(|s| !s.ends.contains(&cap.apex))
        {
            let (a, b) = (p[s.ends[0] as usize], p[s.ends[1] as usize]);
            for i in 0..3 {
                assert!(
                    !segments_meet(a, b, t[i], t[(i + 1) % 3]),
                    "cap {c} meets {s:?}"
                );
            }
        }
    }
    // Caps of different vertices lie in disjoint disks.
    let capped: Vec<usize> = (0..n).filter(|&v| cut.cap_radius[v] > 0.0).collect();
    for (i, &u) in capped.iter().enumerate() {
        for &v in &capped[i + 1..] {
            assert!(p[u].distance(p[v]) > cut.cap_radius[u] + cut.cap_radius[v]);
        }
    }
    check_pieces(input, cut);
    check_wedges_left(cut, &acute_at);
}

/// Each segment is its pieces in the cut graph and its caps' sides, end to end; each cut edge
/// is its cap's base.
fn check_pieces(input: &Input, cut: &CornerCut) {
    let mut pieces: Vec<Vec<[u32; 2]>> = vec![Vec::new(); input.segments.len()];
    for e in &cut.edges {
        match e.origin {
            EdgeOrigin::Segment(s) => pieces[s as usize].push(e.ends),
            EdgeOrigin::Cut(c) => assert_eq!(e.ends, cut.caps[c as usize].ends),
        }
    }
    let mut sides: Vec<Vec<[u32; 2]>> = vec![Vec::new(); input.segments.len()];
    for cap in &cut.caps {
        for (k, &s) in cap.sides.iter().enumerate() {
            sides[s as usize].push([cap.apex, cap.ends[k]]);
        }
    }
    // A cap's side is an edge exactly when no other cap lies beyond it: the wedge there is left.
    let mut side_count = std::collections::HashMap::new();
    for cap in &cut.caps {
        for &end in &cap.ends {
            *side_count.entry([cap.apex, end]).or_insert(0) += 1;
        }
    }
    let kept: std::collections::HashSet<[u32; 2]> = cut
        .edges
        .iter()
        .map(|e| [e.ends[0].min(e.ends[1]), e.ends[0].max(e.ends[1])])
        .collect();
    for (&[apex, end], &count) in &side_count {
        let edge = [apex.min(end), apex.max(end)];
        assert_eq!(
            kept.contains(&edge),
            count == 1,
            "side {apex}-{end} of {count} caps"
        );
    }
    for (s, seg) in input.segments.iter().enumerate() {
        let [a, b] = seg.ends;
        // Walk from a to b over pieces (directed as the segment) and cap sides (either way).
        let mut links: Vec<[u32; 2]> = pieces[s].clone();
        for &[apex, end] in &sides[s] {
            links.push(if apex == a { [apex, end] } else { [end, apex] });
        }
        links.sort_unstable();
        links.dedup();
        let mut at = a;
        let mut steps = 0;
        while at != b {
            let next = links
                .iter()
                .find(|l| l[0] == at)
                .unwrap_or_else(|| panic!("segment {s}: no piece from {at}, pieces {links:?}"));
            at = next[1];
            steps += 1;
            assert!(steps <= 3, "segment {s}: more than three pieces");
        }
        assert_eq!(steps, links.len(), "segment {s}: stray pieces {links:?}");
    }
}

/// In the cut graph, no two edges consecutive about a vertex make an angle below 90°, except
/// where caps fill the wedge between them; a vertex whose wedges were all cut is no edge's end.
fn check_wedges_left(cut: &CornerCut, acute_at: &[bool]) {
    let q = &cut.points;
    let mut star: Vec<Vec<(f64, u32)>> = vec![Vec::new(); q.len()];
    for e in &cut.edges {
        let [a, b] = e.ends;
        for (v, u) in [(a, b), (b, a)] {
            let d = q[u as usize] - q[v as usize];
            star[v as usize].push((d.y.atan2(d.x).to_degrees().rem_euclid(360.0), u));
        }
    }
    let mut cap_corners = std::collections::HashSet::new();
    for cap in &cut.caps {
        let t = [cap.apex, cap.ends[0], cap.ends[1]];
        for i in 0..3 {
            // The corner at t[i], counterclockwise from t[i+1] (to t[i+2]).
            cap_corners.insert((t[i], t[(i + 1) % 3]));
        }
    }
    for &v in &cut.enclosed {
        assert!(
            star[v as usize].is_empty(),
            "enclosed vertex {v} ends an edge"
        );
        assert!(acute_at[v as usize]);
    }
    for (v, around) in star.iter_mut().enumerate() {
        around.sort_by(|a, b| a.0.total_cmp(&b.0));
        if around.len() < 2 {
            continue;
        }
        for i in 0..around.len() {
            let (from, to) = (around[i], around[(i + 1) % around.len()]);
            let angle = (to.0 - from.0).rem_euclid(360.0);
            // Caps cover the wedge from an edge that a cap starts at up to the next edge: the
            // pieces between two caps of one vertex are no edges.
            if cap_corners.contains(&(v as u32, from.1)) {
                continue;
            }
            assert!(
                angle >= 90.0 - 1e-6,
                "vertex {v}: {angle}° between edges to {} and {} outside the caps",
                from.1,
                to.1
            );
        }
    }
}

#[test]
fn feature_distances_are_the_nearest_non_incident_point_or_segment() {
    for (input, name) in [
        (delaunay_graph(300, 1), "delaunay"),
        (fan(17), "fan"),
        (sliver(0.5), "sliver"),
        (quadmesh::generate::block_with_holes(30, 2), "holes"),
        (quadmesh::generate::nested_curves(400, 3), "rings"),
    ] {
        let found = feature_distances(&input.points, &ends(&input));
        let brute = brute_feature_distances(&input);
        for (v, (f, b)) in found.iter().zip(&brute).enumerate() {
            assert!(
                (f - b).abs() <= 1e-12 * b,
                "{name}: vertex {v} found {f}, expected {b}"
            );
        }
    }
    let alone = feature_distances(&[DVec2::new(1.0, 2.0)], &[]);
    assert_eq!(alone, vec![f64::INFINITY]);
}

#[test]
fn triangulations_lose_their_acute_corners() {
    for (n, seed) in [(3, 1), (4, 2), (40, 3), (400, 4)] {
        let input = delaunay_graph(n, seed);
        let cut = cut_checked(&input);
        assert!(!cut.caps.is_empty(), "{n} points: nothing cut");
        // An interior vertex of a Delaunay triangulation has all its wedges acute as a rule.
        if n >= 40 {
            assert!(!cut.enclosed.is_empty());
        }
    }
}

#[test]
fn fans_and_slivers_keep_90_degrees_outside_their_caps() {
    for k in [3, 4, 5, 12, 40] {
        let cut = cut_checked(&fan(k));
        // The hub's wedges are all acute from five spokes on: it ends up enclosed.
        assert_eq!(cut.enclosed.contains(&0), k >= 5, "{k} spokes");
    }
    for degrees in [60.0, 10.0, 1.0, 0.01] {
        let cut = cut_checked(&sliver(degrees));
        assert_eq!(
            cut.caps.iter().filter(|c| c.apex == 0).count(),
            1,
            "{degrees}°: the sliver's tip"
        );
        // The segment passing at 0.5 from the tip bounds its radius.
        assert!(cut.cap_radius[0] <= CAP_FRACTION * 0.5 * (1.0 + 1e-15));
    }
}

#[test]
fn graphs_without_acute_wedges_are_left_as_they_are() {
    for input in [
        quadmesh::generate::block_with_holes(50, 5),
        quadmesh::generate::nested_curves(2_000, 6),
    ] {
        let cut = cut_checked(&input);
        assert!(cut.caps.is_empty());
        assert_eq!(cut.points, input.points);
        let kept: Vec<[u32; 2]> = cut.edges.iter().map(|e| e.ends).collect();
        assert_eq!(kept, ends(&input));
    }
}

#[test]
fn triangle_examples_are_cut() {
    let Some(dir) = common::triangle_examples() else {
        eprintln!("skipped: the Python package `triangle` is not installed");
        return;
    };
    for name in ["A", "face", "la", "double_hex", "double_hex2", "box"] {
        let path = dir.join(format!("{name}.poly"));
        let text = std::fs::read_to_string(&path).expect("the example");
        let read = quadmesh::io::parse_poly_input(&text, name).expect("a graph");
        let (input, _) = clean(&read, CleanOptions::default()).expect("a clean graph");
        cut_checked(&input);
    }
}

#[test]
fn a_cap_f64_cannot_place_is_refused_by_name() {
    // A 45° wedge 1e16 from the origin, one unit long: its cut points round onto the apex.
    let input = Input {
        points: vec![
            DVec2::new(1e16, 0.0),
            DVec2::new(1e16 + 2.0, 0.0),
            DVec2::new(1e16 + 2.0, 2.0),
        ],
        segments: vec![segment([0, 1]), segment([0, 2])],
        ..Input::default()
    };
    match cut_acute_corners(&input) {
        Err(Error::Unresolvable { index: 0, .. }) => {}
        other => panic!("expected the apex refused, got {other:?}"),
    }
}

#[test]
fn bad_graphs_are_refused_by_name() {
    let triangle = |points: Vec<DVec2>, ends: Vec<[u32; 2]>| Input {
        points,
        segments: ends.into_iter().map(segment).collect(),
        ..Input::default()
    };
    let p = vec![DVec2::ZERO, DVec2::new(1.0, 0.0), DVec2::new(0.0, 1.0)];
    let nan = vec![DVec2::ZERO, DVec2::new(f64::NAN, 0.0), DVec2::new(0.0, 1.0)];
    match cut_acute_corners(&triangle(nan, vec![[0, 1]])) {
        Err(Error::NonFinite { index: 1, .. }) => {}
        other => panic!("expected the NaN point refused, got {other:?}"),
    }
    match cut_acute_corners(&triangle(p.clone(), vec![[0, 1], [1, 3]])) {
        Err(Error::SegmentIndex {
            segment: 1,
            index: 3,
            points: 3,
        }) => {}
        other => panic!("expected the index refused, got {other:?}"),
    }
    match cut_acute_corners(&triangle(p, vec![[0, 1], [2, 2]])) {
        Err(Error::ZeroLengthSegment { segment: 1 }) => {}
        other => panic!("expected the empty segment refused, got {other:?}"),
    }
}
