mod common;
use quadmesh::{DVec2, Input, Mesh, Options};

fn outside_narrow_caps_min(input: &Input, mesh: &Mesh, narrow_deg: f64) -> (f64, f64, usize) {
    let cut = quadmesh::pslg::cut_acute_corners(input).unwrap();
    let caps: Vec<[DVec2; 3]> = cut
        .caps
        .iter()
        .map(|c| [c.apex, c.ends[0], c.ends[1]].map(|v| cut.points[v as usize]))
        .filter(|[a, b, c]| {
            let (u, w) = (*b - *a, *c - *a);
            u.angle_to(w).abs().to_degrees() < narrow_deg
        })
        .collect();
    let inside = |p: DVec2| {
        caps.iter().any(|[a, b, c]| {
            let s = |p0: DVec2, p1: DVec2| (p1 - p0).perp_dot(p - p0) >= -1e-12;
            s(*a, *b) && s(*b, *c) && s(*c, *a)
        })
    };
    let (mut min, mut max, mut below) = (180.0f64, 0.0f64, 0);
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| mesh.vertices[v as usize]);
        if inside((a + b + c) / 3.0) {
            continue;
        }
        let angles = quadmesh::mesh::angles_deg(a, b, c);
        if angles.iter().any(|&x| x < 14.0) {
            eprintln!(
                "   {:.2}: {}",
                angles.iter().fold(180.0f64, |m, &x| m.min(x)),
                t.iter()
                    .map(|&v| format!(
                        "({:.5},{:.5}){}",
                        mesh.vertices[v as usize].x,
                        mesh.vertices[v as usize].y,
                        if mesh.vertex_input[v as usize] != u32::MAX {
                            "*"
                        } else {
                            ""
                        }
                    ))
                    .collect::<Vec<_>>()
                    .join(" ")
            );
        }
        for x in angles {
            min = min.min(x);
            max = max.max(x);
            if x < 18.0 {
                below += 1;
            }
        }
    }
    (min, max, below)
}

#[test]
fn scratch() {
    let Some(dir) = common::triangle_examples() else {
        return;
    };
    for name in [
        "A",
        "face",
        "la",
        "double_hex",
        "double_hex2",
        "square_circle_hole",
    ] {
        let input = quadmesh::io::read_input(&dir.join(format!("{name}.poly"))).unwrap();
        let (clean, _) = quadmesh::pslg::clean(&input, Default::default()).unwrap();
        let (mesh, report) = quadmesh::mesh(&clean, &Options::default().warp()).unwrap();
        let (min, max, below) = outside_narrow_caps_min(&clean, &mesh, 18.0);
        eprintln!(
            "{name:20} tri {:7} all [{:.2},{:.2}] outside narrow caps [{min:.2},{max:.2}] below18 {below}",
            mesh.triangles.len(),
            report.min_angle,
            report.max_angle
        );
    }
}
