//! Warped meshes of planar straight-line graphs (BET §5).

mod common;

use quadmesh::mesh::{AngleBounds, validate_pslg};
use quadmesh::{DVec2, Input, Mesh, MeshReport, Options, Segment};

fn closed_loop(input: &mut Input, corners: &[DVec2], marker: i32) {
    let first = input.points.len() as u32;
    let n = corners.len() as u32;
    input.points.extend_from_slice(corners);
    input.segments.extend((0..n).map(|k| Segment {
        ends: [first + k, first + (k + 1) % n],
        marker,
    }));
}

fn square(lo: DVec2, side: f64) -> [DVec2; 4] {
    [
        lo,
        lo + DVec2::new(side, 0.0),
        lo + DVec2::splat(side),
        lo + DVec2::new(0.0, side),
    ]
}

fn warped(input: &Input) -> (Mesh, MeshReport) {
    let (mesh, report) = quadmesh::mesh(input, &Options::default().warp()).expect("a mesh");
    eprintln!(
        "{} pts -> {} tri, angles [{:.2}, {:.2}]",
        input.points.len(),
        mesh.triangles.len(),
        report.min_angle,
        report.max_angle
    );
    validate_pslg(&mesh, input, AngleBounds { min_deg: 0.0, max_deg: 180.0 })
        .unwrap_or_else(|e| panic!("invalid mesh: {e}"));
    (mesh, report)
}

#[test]
fn scratch_square_with_holes() {
    let mut input = Input::default();
    closed_loop(&mut input, &square(DVec2::ZERO, 10.0), 1);
    for i in 0..3 {
        for j in 0..3 {
            let lo = DVec2::new(i as f64 * 3.0 + 1.3, j as f64 * 3.0 + 1.25);
            closed_loop(&mut input, &square(lo, 0.5), 2);
            input.holes.push(lo + DVec2::splat(0.25));
        }
    }
    warped(&input);
}

#[test]
fn scratch_triangle_examples() {
    let Some(dir) = common::triangle_examples() else { return };
    for name in ["A", "face", "la", "double_hex", "double_hex2", "square_circle_hole"] {
        eprintln!("{name}");
        let input = quadmesh::io::read_input(&dir.join(format!("{name}.poly"))).unwrap();
        warped(&input);
    }
}

fn worst(mesh: &Mesh, k: usize) {
    let mut all: Vec<(f64, usize)> = (0..mesh.triangles.len())
        .map(|t| {
            let [a, b, c] = mesh.triangles[t].map(|v| mesh.vertices[v as usize]);
            let angles = quadmesh::mesh::angles_deg(a, b, c);
            (angles.iter().copied().fold(180.0, f64::min), t)
        })
        .collect();
    all.sort_by(|x, y| x.0.total_cmp(&y.0));
    for &(angle, t) in all.iter().take(k) {
        let pts: Vec<String> = mesh.triangles[t]
            .iter()
            .map(|&v| format!("({:.5},{:.5}){}", mesh.vertices[v as usize].x, mesh.vertices[v as usize].y, if mesh.vertex_input[v as usize] != u32::MAX { "*" } else { "" }))
            .collect();
        eprintln!("  {angle:.2} {}", pts.join(" "));
    }
}

#[test]
fn scratch_worst() {
    let mut input = Input::default();
    closed_loop(&mut input, &square(DVec2::ZERO, 10.0), 1);
    for i in 0..3 {
        for j in 0..3 {
            let lo = DVec2::new(i as f64 * 3.0 + 1.3, j as f64 * 3.0 + 1.25);
            closed_loop(&mut input, &square(lo, 0.5), 2);
            input.holes.push(lo + DVec2::splat(0.25));
        }
    }
    let (mesh, _) = warped(&input);
    worst(&mesh, 12);
}
