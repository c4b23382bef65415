//! Any bytes as a small graph (points on a fine grid, or raw f64 bits, and segments between
//! them): cleaned (crossings split or refused), its acute corners cut, its features separated
//! in the quadtree. Each stage answers with its result or a typed error, never a panic; the
//! tree must be valid, its crowded squares those of the brute force, its leaves uncrowded, and
//! every edge's pieces must run from end to end without a gap. The tree is then bent onto the
//! graph and the domain cut out (the warp mode's stages): a mesh must pass the PSLG check, and
//! so must the mesh coarsened, with no angle beyond both the warp's and the coarsening's bounds.
//! At the warp's clearance, the front door's warp of the graph (its thin triangles refined)
//! must pass the check with the mode's angle bounds, or stop with a typed error.
#![no_main]

use libfuzzer_sys::fuzz_target;
use quadmesh::balance::reference::graph_crowded_squares;
use quadmesh::mesh::{AngleBounds, angles_deg, validate_pslg};
use quadmesh::morton::MortonKey;
use quadmesh::pipeline::{
    GraphTree, GraphTreeBuild, GraphTreeOptions, StageTimes, WARP_CLEARANCE, graph_tree,
    warped_graph,
};
use quadmesh::pslg::{CleanOptions, CornerCut, clean, cut_acute_corners};
use quadmesh::warp::{COARSE_ANGLE_BOUNDS, coarsen, finest_resolved_level};
use quadmesh::{DVec2, Error, Input, Options, Segment};

/// Points from 4 bytes each (two i16 on a 1/64 grid), or from 16 (raw f64 bits) when `raw`.
fn points_of(bytes: &[u8], count: usize, raw: bool) -> Vec<DVec2> {
    let width = if raw { 16 } else { 4 };
    bytes
        .chunks_exact(width)
        .take(count)
        .map(|c| {
            if raw {
                let x = f64::from_le_bytes(c[..8].try_into().unwrap());
                let y = f64::from_le_bytes(c[8..].try_into().unwrap());
                DVec2::new(x, y)
            } else {
                let x = i16::from_le_bytes([c[0], c[1]]);
                let y = i16::from_le_bytes([c[2], c[3]]);
                DVec2::new(f64::from(x), f64::from(y)) / 64.0
            }
        })
        .collect()
}

/// The most crowded squares a tree may have, and the most the brute force retraces.
const MAX_SQUARES: usize = 200_000;
const BRUTE_FORCE_SQUARES: usize = 5_000;

fn check<K: MortonKey>(cut: &CornerCut, build: &GraphTreeBuild<K>) {
    build
        .tree
        .check(&build.morton.keys)
        .unwrap_or_else(|e| panic!("invalid tree: {e}"));
    check_pieces(build);
    if build.crowded > BRUTE_FORCE_SQUARES {
        return;
    }
    let points: Vec<DVec2> = build
        .vertices
        .iter()
        .map(|&v| cut.points[v as usize])
        .collect();
    let finest = finest_resolved_level::<K>(false);
    let brute = graph_crowded_squares::<K>(
        &build.morton.grid,
        &points,
        &build.edges,
        (build.clearance, finest),
    )
    .expect("separable by the brute force too");
    assert_eq!(
        brute.len(),
        build.crowded,
        "crowded squares differ from the brute force"
    );
}

/// The most leaves a tree may have for its warp to be checked (a run stays well under the
/// time limit with the sanitizers on).
const WARP_LEAVES: usize = 40_000;

/// The warp of the tree and the domain cut out of it: a typed error, or a valid mesh.
fn check_warp<K: MortonKey>(graph: &Input, cut: &CornerCut, build: &GraphTreeBuild<K>) {
    if build.tree.tree.leaves.len() > WARP_LEAVES {
        return;
    }
    if let Ok(mesh) = warped_graph(build, (graph, cut), &mut StageTimes::default()) {
        let any = AngleBounds {
            min_deg: 0.0,
            max_deg: 180.0,
        };
        validate_pslg(&mesh, graph, any).unwrap_or_else(|e| panic!("invalid warped mesh: {e}"));
        // Coarsened (vertices inside a segment going along it), still valid, and no angle
        // beyond both the warp's and the coarsening's bounds.
        let (fine_min, fine_max) = angle_range(&mesh);
        let mut coarse = mesh;
        coarsen(&mut coarse, COARSE_ANGLE_BOUNDS);
        validate_pslg(&coarse, graph, any)
            .unwrap_or_else(|e| panic!("invalid coarsened mesh: {e}"));
        let (min, max) = angle_range(&coarse);
        let (low, high) = COARSE_ANGLE_BOUNDS;
        assert!(
            min >= fine_min.min(low) - 1e-9,
            "coarsened to {min}° from {fine_min}°"
        );
        assert!(
            max <= fine_max.max(high) + 1e-9,
            "coarsened to {max}° from {fine_max}°"
        );
    }
}

/// The front door's warp and compact warp of `graph`: a typed error, or a mesh that passes the
/// check with the bounds the options state.
fn check_front_door(graph: &Input) {
    // Points alone are meshed as a point set, which other targets check.
    if graph.segments.is_empty() {
        return;
    }
    for options in [Options::default().warp(), Options::default().compact_warp()] {
        match quadmesh::mesh(graph, &options) {
            Ok((mesh, report)) => {
                let bounds = options.angle_bounds_of(graph);
                assert_eq!(report.angle_bounds, Some(bounds));
                validate_pslg(&mesh, graph, bounds)
                    .unwrap_or_else(|e| panic!("invalid front door warp of {graph:?}: {e}"));
            }
            Err(Error::VertexBudget(partial)) => panic!(
                "the warp's refinement ran away: {} vertices",
                partial.mesh.vertices.len()
            ),
            Err(_) => {}
        }
    }
}

/// The smallest and largest angle of `mesh`'s triangles, in degrees.
fn angle_range(mesh: &quadmesh::Mesh) -> (f64, f64) {
    (mesh.triangles.iter())
        .flat_map(|t| {
            let [a, b, c] = t.map(|v| mesh.vertices[v as usize]);
            angles_deg(a, b, c)
        })
        .fold((f64::INFINITY, 0.0), |(lo, hi), x| (lo.min(x), hi.max(x)))
}

fn check_pieces<K: MortonKey>(build: &GraphTreeBuild<K>) {
    for e in 0..build.edges.len() {
        let row = build.pieces.of(e);
        assert!(!row.is_empty(), "edge {e} has no piece");
        assert_eq!((row[0].from, row[row.len() - 1].to), (0.0, 1.0));
        for pair in row.windows(2) {
            assert_eq!(pair[0].to, pair[1].from, "edge {e}: a gap");
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&choice, rest)) = data.split_first() else {
        return;
    };
    let Some((&count, rest)) = rest.split_first() else {
        return;
    };
    let raw = choice & 0x80 != 0;
    let count = usize::from(count % 24);
    let width = if raw { 16 } else { 4 };
    let (point_bytes, segment_bytes) = rest.split_at(rest.len().min(count * width));
    let points = points_of(point_bytes, count, raw);
    if points.is_empty() {
        return;
    }
    let n = points.len() as u32;
    // Segment ends may name missing points: the cleaning refuses them.
    let segments: Vec<Segment> = segment_bytes
        .chunks_exact(2)
        .take(32)
        .map(|c| Segment {
            ends: [u32::from(c[0]) % (n + 1), u32::from(c[1]) % (n + 1)],
            marker: 1,
        })
        .collect();
    let input = Input {
        points,
        segments,
        ..Input::default()
    };
    let options = CleanOptions {
        split_crossings: choice & 0x40 != 0,
    };
    // Uncleaned input goes to the cut as well: it must refuse or cut, never panic.
    if choice & 0x20 != 0 {
        let _ = cut_acute_corners(&input);
    }
    let Ok((graph, _)) = clean(&input, options) else {
        return;
    };
    let Ok(cut) = cut_acute_corners(&graph) else {
        return;
    };
    let clearance = [0.5, 1.0, 2.0, 3.0][usize::from(choice & 3)];
    // Thin wedges ask for squares all along their edges: a budget keeps a run bounded.
    let options = GraphTreeOptions {
        clearance,
        max_squares: Some(MAX_SQUARES),
    };
    let leaves = match graph_tree(&cut, options, &mut StageTimes::default()) {
        Ok(GraphTree::Narrow(build)) => {
            check(&cut, &build);
            check_warp(&graph, &cut, &build);
            build.tree.tree.leaves.len()
        }
        Ok(GraphTree::Wide(build)) => {
            check(&cut, &build);
            check_warp(&graph, &cut, &build);
            build.tree.tree.leaves.len()
        }
        Err(_) => return,
    };
    if clearance == WARP_CLEARANCE && leaves <= WARP_LEAVES {
        check_front_door(&graph);
    }
});
