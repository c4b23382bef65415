//! Dynamic quality Delaunay meshes (`DynamicDelaunay`): after every edit, the mesh equals byte
//! for byte refinement in order of the live points in id order, passes `validate` with the
//! angle bound and the exact Delaunay check; bad edits leave it unchanged.

use quadmesh::dynamic::DynamicDelaunay;
use quadmesh::generate::{self, Distribution2d};
use quadmesh::mesh::{AngleBounds, Domain};
use quadmesh::refine::{RefineDomain, RefineOptions, refine_points_in_order};
use quadmesh::{DVec2, Mesh};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

fn options(angle: f64, domain: Domain) -> RefineOptions {
    RefineOptions {
        min_angle_deg: angle,
        domain: RefineDomain::Rectangle(domain),
        ..RefineOptions::default()
    }
}

/// Checks the dynamic mesh against a rebuild of its live points, and the rebuild's validity.
fn matches_rebuild(dynamic: &DynamicDelaunay, options: &RefineOptions) -> Mesh {
    let points = dynamic.live_points();
    let mesh = dynamic.mesh().expect("the dynamic mesh");
    let (rebuilt, _) = refine_points_in_order(&points, options).expect("a rebuild");
    assert_eq!(mesh.vertices, rebuilt.vertices, "vertices differ from a rebuild");
    assert_eq!(mesh.triangles, rebuilt.triangles, "triangles differ from a rebuild");
    let a = options.min_angle_deg;
    let bounds = AngleBounds {
        min_deg: a,
        max_deg: 180.0 - 2.0 * a,
    };
    mesh.validate(&points, bounds).expect("a valid mesh");
    mesh.check_delaunay().expect("a Delaunay mesh");
    mesh
}

#[test]
fn random_edits_give_a_rebuilds_bytes_after_every_step() {
    let domain = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::ONE,
    };
    let options = options(30.0, domain);
    let points = generate::points(Distribution2d::Uniform, 1500, 3);
    let mut dynamic = DynamicDelaunay::new(&points, &options).expect("a dynamic mesh");
    matches_rebuild(&dynamic, &options);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(9);
    let mut rebuilt = 0;
    for step in 0..40 {
        let live: Vec<u32> = (0..dynamic.live_points().len() as u32 + 100)
            .filter(|&id| dynamic.point(id).is_some())
            .collect();
        let report = match step % 3 {
            0 => dynamic.insert(DVec2::new(rng.random(), rng.random())).unwrap(),
            1 => dynamic.delete(live[rng.random_range(0..live.len())]).unwrap(),
            _ => {
                let id = live[rng.random_range(0..live.len())];
                let p = dynamic.point(id).unwrap();
                let to = (p + DVec2::new(rng.random(), rng.random()) * 0.01 - 0.005).clamp(DVec2::ZERO, DVec2::ONE);
                dynamic.move_to(id, to).unwrap()[1]
            }
        };
        rebuilt += usize::from(report.rebuilt);
        eprintln!("{step}: {report:?}");
        matches_rebuild(&dynamic, &options);
    }
    assert!(rebuilt < 10, "{rebuilt} of 40 edits refined everything again");
}
