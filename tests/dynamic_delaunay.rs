//! Dynamic quality Delaunay meshes (`DynamicDelaunay`): after every edit the mesh equals, byte
//! for byte, refinement in order of the live points in id order, passes `validate` with the
//! angle bound and the exact Delaunay check; most edits replay a window, not the domain; the
//! bytes do not depend on the thread count; bad edits leave the mesh unchanged.

mod common;

use common::{FAMILIES, on_threads};
use quadmesh::dynamic::{DynamicDelaunay, Edit, RefinedEdit};
use quadmesh::generate::{self, Distribution2d};
use quadmesh::mesh::{AngleBounds, Domain};
use quadmesh::refine::{RefineDomain, RefineOptions, refine_points_in_order};
use quadmesh::{DVec2, Error, Mesh};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

fn options(angle: f64, domain: Domain) -> RefineOptions {
    RefineOptions {
        min_angle_deg: angle,
        domain: RefineDomain::Rectangle(domain),
        ..RefineOptions::default()
    }
}

/// The points' bounding box grown by a twentieth on each side.
fn domain_around(points: &[DVec2]) -> Domain {
    let (lo, hi) = points.iter().fold(
        (DVec2::splat(f64::MAX), DVec2::splat(f64::MIN)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let margin = (hi - lo) * 0.05;
    Domain {
        lo: lo - margin,
        hi: hi + margin,
    }
}

/// Checks the dynamic mesh against a rebuild of its live points, and the mesh's validity.
fn matches_rebuild(dynamic: &DynamicDelaunay, options: &RefineOptions) -> Mesh {
    let points = dynamic.live_points();
    assert_eq!(dynamic.len(), points.len());
    let mesh = dynamic.mesh().expect("the dynamic mesh");
    let (rebuilt, _) = refine_points_in_order(&points, options).expect("a rebuild");
    assert_eq!(
        mesh.vertices, rebuilt.vertices,
        "vertices differ from a rebuild"
    );
    assert_eq!(mesh.vertex_input, rebuilt.vertex_input);
    assert_eq!(
        mesh.triangles, rebuilt.triangles,
        "triangles differ from a rebuild"
    );
    assert_eq!(mesh.neighbours, rebuilt.neighbours);
    let a = options.min_angle_deg;
    let bounds = AngleBounds {
        min_deg: a,
        max_deg: 180.0 - 2.0 * a,
    };
    mesh.validate(&points, bounds).expect("a valid mesh");
    mesh.check_delaunay().expect("a Delaunay mesh");
    mesh
}

/// The live ids of a dynamic mesh.
fn live_ids(dynamic: &DynamicDelaunay, issued: u32) -> Vec<u32> {
    (0..issued)
        .filter(|&id| dynamic.point(id).is_some())
        .collect()
}

/// The middle of `domain`, `share` of its side across.
fn middle(domain: Domain, share: f64) -> Domain {
    let margin = (domain.hi - domain.lo) * (1.0 - share) / 2.0;
    Domain {
        lo: domain.lo + margin,
        hi: domain.hi - margin,
    }
}

/// Applies `edits` random edits in `domain` (insertions near existing points and, where
/// `anywhere`, at random places, deletions, small moves), checking the mesh against a rebuild
/// after each; returns the edits' reports.
fn random_edits(
    dynamic: &mut DynamicDelaunay,
    options: &RefineOptions,
    (domain, anywhere): (Domain, bool),
    edits: usize,
    seed: u64,
) -> Vec<RefinedEdit> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut issued = dynamic.live_points().len() as u32;
    let size = domain.hi - domain.lo;
    let mut reports = Vec::new();
    for step in 0..edits {
        let live: Vec<u32> = live_ids(dynamic, issued)
            .into_iter()
            .filter(|&id| domain.contains(dynamic.point(id).unwrap()))
            .collect();
        let near = |rng: &mut Xoshiro256PlusPlus, p: DVec2| {
            let jitter = DVec2::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
            (p + jitter * size * 0.002).clamp(domain.lo, domain.hi)
        };
        let report = match step % 4 {
            0 if anywhere => {
                let p = domain.lo + DVec2::new(rng.random(), rng.random()) * size;
                issued += 1;
                dynamic.insert(p).expect("an insertion")
            }
            0 | 1 => {
                let at = dynamic
                    .point(live[rng.random_range(0..live.len())])
                    .unwrap();
                let p = near(&mut rng, at);
                issued += 1;
                dynamic.insert(p).expect("an insertion near a point")
            }
            2 => dynamic
                .delete(live[rng.random_range(0..live.len())])
                .expect("a deletion"),
            _ => {
                let id = live[rng.random_range(0..live.len())];
                let to = near(&mut rng, dynamic.point(id).unwrap());
                dynamic.move_to(id, to).expect("a move")[1]
            }
        };
        matches_rebuild(dynamic, options);
        reports.push(report);
    }
    reports
}

#[test]
fn random_edits_give_a_rebuilds_bytes_after_every_step() {
    for (k, dist) in FAMILIES.into_iter().enumerate() {
        let points = generate::points(dist, 1200, 3 + k as u64);
        let domain = domain_around(&points);
        for angle in [20.0, 30.0] {
            let options = options(angle, domain);
            let mut dynamic = DynamicDelaunay::new(&points, &options).expect("a dynamic mesh");
            matches_rebuild(&dynamic, &options);
            random_edits(&mut dynamic, &options, (domain, true), 24, 9 + k as u64);
        }
    }
}

#[test]
fn edits_anywhere_stay_local() {
    // Edits where the points are, all over the domain, near its sides too (whose pieces
    // refinement in order cut first). Between clusters, and in the sparse far reaches of
    // Kuzmin's points, the first triangulation's triangles span the gaps, and an edit there
    // may replay much of the domain (see the module's limits).
    let families = [
        Distribution2d::Uniform,
        Distribution2d::Kuzmin,
        Distribution2d::Grid,
    ];
    for (k, dist) in families.into_iter().enumerate() {
        let points = generate::points(dist, 3000, 13 + k as u64);
        let domain = domain_around(&points);
        let options = options(30.0, domain);
        let mut dynamic = DynamicDelaunay::new(&points, &options).expect("a dynamic mesh");
        let reports = random_edits(&mut dynamic, &options, (domain, false), 16, k as u64);
        let local = reports.iter().filter(|r| !r.rebuilt).count();
        assert!(
            local * 16 >= reports.len() * 15,
            "{dist:?}: only {local} of {} edits stayed local",
            reports.len()
        );
    }
}

#[test]
fn an_edit_replays_a_window_and_changes_few_steiner_points() {
    let points = generate::points(Distribution2d::Uniform, 6000, 21);
    let domain = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::ONE,
    };
    let options = options(30.0, domain);
    let mut dynamic = DynamicDelaunay::new(&points, &options).expect("a dynamic mesh");
    let steiner = dynamic.steiner_count();
    let reports = random_edits(&mut dynamic, &options, (middle(domain, 0.8), true), 16, 5);
    let mut windows: Vec<f64> = reports.iter().map(|r| r.window).collect();
    windows.sort_by(f64::total_cmp);
    let median = windows[windows.len() / 2];
    assert!(median < 0.5, "median window side {median}");
    for r in reports.iter().filter(|r| !r.rebuilt) {
        assert!(
            r.steiner_removed < steiner / 10 && r.steiner_added < steiner / 10,
            "{r:?} against {steiner} Steiner points"
        );
    }
}

#[test]
fn points_on_the_sides_and_corners_come_and_go() {
    let domain = Domain {
        lo: DVec2::new(-1.0, 2.0),
        hi: DVec2::new(3.0, 4.0),
    };
    let options = options(25.0, domain);
    let points = generate::points(Distribution2d::Uniform, 400, 8)
        .into_iter()
        .map(|p| domain.lo + p * (domain.hi - domain.lo))
        .collect::<Vec<_>>();
    let mut dynamic = DynamicDelaunay::new(&points, &options).expect("a dynamic mesh");
    let on_boundary = [
        DVec2::new(-1.0, 3.1),
        DVec2::new(3.0, 2.0),
        DVec2::new(0.7, 4.0),
        DVec2::new(-1.0, 2.0),
        DVec2::new(1.3, 2.0),
    ];
    let mut ids = Vec::new();
    for p in on_boundary {
        ids.push(dynamic.insert(p).expect("a point on the boundary").id);
        matches_rebuild(&dynamic, &options);
    }
    dynamic.move_to(ids[0], DVec2::new(-1.0, 3.7)).unwrap();
    matches_rebuild(&dynamic, &options);
    for id in ids {
        dynamic.delete(id).unwrap();
        matches_rebuild(&dynamic, &options);
    }
}

#[test]
fn few_points_down_to_one_and_back() {
    let domain = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::new(2.0, 1.0),
    };
    let options = options(30.0, domain);
    let points = [
        DVec2::new(0.3, 0.2),
        DVec2::new(1.7, 0.9),
        DVec2::new(1.0, 0.5),
    ];
    let mut dynamic = DynamicDelaunay::new(&points, &options).expect("a dynamic mesh");
    dynamic.delete(0).unwrap();
    matches_rebuild(&dynamic, &options);
    dynamic.delete(2).unwrap();
    matches_rebuild(&dynamic, &options);
    dynamic.insert(DVec2::new(0.1, 0.9)).unwrap();
    matches_rebuild(&dynamic, &options);
    dynamic.move_to(1, DVec2::new(1.99, 0.01)).unwrap();
    matches_rebuild(&dynamic, &options);
}

#[test]
fn one_and_two_threads_give_the_same_bytes() {
    let run = || {
        let points = generate::points(Distribution2d::Cluster, 2000, 4);
        let domain = domain_around(&points);
        let options = options(30.0, domain);
        let mut dynamic = DynamicDelaunay::new(&points, &options).expect("a dynamic mesh");
        random_edits(&mut dynamic, &options, (domain, true), 8, 2);
        dynamic.mesh().expect("a mesh")
    };
    let (one, two) = (on_threads(1, run), on_threads(2, run));
    assert_eq!(one.vertices, two.vertices);
    assert_eq!(one.triangles, two.triangles);
}

#[test]
fn bad_edits_leave_the_mesh_unchanged() {
    let domain = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::ONE,
    };
    let options = options(30.0, domain);
    let points = generate::points(Distribution2d::Uniform, 500, 6);
    let mut dynamic = DynamicDelaunay::new(&points, &options).expect("a dynamic mesh");
    dynamic.delete(7).unwrap();
    let before = dynamic.mesh().unwrap();
    let unchanged = |dynamic: &DynamicDelaunay| {
        let after = dynamic.mesh().unwrap();
        assert_eq!(after.vertices, before.vertices);
        assert_eq!(after.triangles, before.triangles);
    };
    let p = points[3];
    let refusals = [
        (dynamic.insert(DVec2::new(f64::NAN, 0.5)).err(), "NaN"),
        (dynamic.insert(DVec2::new(1.5, 0.5)).err(), "outside"),
        (dynamic.insert(p).err(), "a duplicate"),
        (
            dynamic.insert(p + DVec2::new(0.0, 1e-72)).err(),
            "too close",
        ),
        (dynamic.delete(7).err(), "a deleted id"),
        (dynamic.delete(10_000).err(), "an unknown id"),
        (dynamic.move_to(4, p).err(), "a move onto a point"),
        (
            dynamic.move_to(7, DVec2::splat(0.5)).err(),
            "a move of a deleted id",
        ),
        (
            dynamic.move_to(4, DVec2::new(0.5, f64::INFINITY)).err(),
            "a move to infinity",
        ),
    ];
    for (refusal, what) in refusals {
        let error = refusal.unwrap_or_else(|| panic!("{what} was accepted"));
        assert!(
            matches!(
                error,
                Error::NonFinite { .. }
                    | Error::OutsideDomain { .. }
                    | Error::DuplicatePoint { .. }
                    | Error::TooClose { .. }
                    | Error::UnknownPoint { .. }
            ),
            "{what}: {error}"
        );
        unchanged(&dynamic);
    }
    assert_eq!(dynamic.live_points().len(), 499);
}

#[test]
fn a_dynamic_mesh_needs_a_fixed_rectangle_and_distinct_points() {
    let points = [DVec2::ZERO, DVec2::ONE, DVec2::ZERO];
    let square = RefineOptions {
        domain: RefineDomain::Square,
        ..RefineOptions::default()
    };
    assert!(matches!(
        DynamicDelaunay::new(&points[..2], &square),
        Err(Error::InvalidOption { .. })
    ));
    let domain = Domain {
        lo: DVec2::splat(-1.0),
        hi: DVec2::splat(2.0),
    };
    assert!(matches!(
        DynamicDelaunay::new(&points, &options(30.0, domain)),
        Err(Error::DuplicatePoint { .. })
    ));
}

/// `count` edits from `seed`: insertions, deletions and moves of the ids from `first` on.
fn batch(count: usize, seed: u64, first: u32) -> Vec<Edit> {
    let places = generate::points(Distribution2d::Uniform, count, seed);
    places
        .iter()
        .enumerate()
        .map(|(k, &p)| match k % 3 {
            0 => Edit::Insert(p),
            1 => Edit::Delete(first + k as u32),
            _ => Edit::Move(first + k as u32, p),
        })
        .collect()
}

#[test]
fn batches_small_and_large_give_a_rebuilds_bytes_or_change_nothing() {
    let domain = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::ONE,
    };
    let options = options(30.0, domain);
    let points = generate::points(Distribution2d::Uniform, 1000, 12);
    let mut dynamic = DynamicDelaunay::new(&points, &options).expect("a dynamic mesh");
    // Three edits (one at a time) and forty (at least 16 and a 4096th of the points: all at
    // once).
    for (count, first) in [(3, 100), (40, 200)] {
        let edits = batch(count, first as u64, first);
        let reports = dynamic.apply(&edits).expect("a batch");
        assert_eq!(reports.len(), count);
        matches_rebuild(&dynamic, &options);
        // Another batch with a refused edit last: nothing changes.
        let before = dynamic.mesh().unwrap();
        let mut refused = batch(count, first as u64 + 1, first + 300);
        refused.push(Edit::Delete(10_000));
        let (at, error) = dynamic.apply(&refused).expect_err("an unknown id");
        assert_eq!(at, count);
        assert!(matches!(error, Error::UnknownPoint { .. }));
        let after = dynamic.mesh().unwrap();
        assert_eq!(after.vertices, before.vertices);
        assert_eq!(after.triangles, before.triangles);
        matches_rebuild(&dynamic, &options);
    }
}

/// A triangle's corners as bits, from its least corner on.
fn triangle_key(c: [DVec2; 3]) -> [[u64; 2]; 3] {
    let mut bits = c.map(|p| [p.x.to_bits(), p.y.to_bits()]);
    let least = (0..3).min_by_key(|&i| bits[i]).unwrap();
    bits.rotate_left(least);
    bits
}

fn triangle_keys(mesh: &Mesh) -> std::collections::HashSet<[[u64; 2]; 3]> {
    mesh.triangles
        .iter()
        .map(|t| triangle_key(t.map(|v| mesh.vertices[v as usize])))
        .collect()
}

/// Takes the changes since the last take and checks that they turn `before` into the mesh
/// as it is, which it returns; and that they are as many as a comparison of whole meshes
/// finds.
fn check_changes(dynamic: &mut DynamicDelaunay, before: &Mesh, options: &RefineOptions) -> Mesh {
    let changes = dynamic.take_changes().expect("tracked changes");
    let after = matches_rebuild(dynamic, options);
    let mut triangles = triangle_keys(before);
    for &c in &changes.removed {
        assert!(
            triangles.remove(&triangle_key(c)),
            "removed {c:?} was not there"
        );
    }
    for &c in &changes.added {
        assert!(triangles.insert(triangle_key(c)), "added {c:?} was there");
    }
    assert!(
        triangles == triangle_keys(&after),
        "the changes miss triangles"
    );
    let whole = after.changes_from(before);
    assert_eq!(changes.removed.len(), whole.removed.len());
    assert_eq!(changes.added.len(), whole.added.len());
    after
}

#[test]
fn tracked_changes_turn_the_mesh_before_into_the_mesh_after() {
    for (k, dist) in FAMILIES.into_iter().enumerate() {
        let points = generate::points(dist, 1500, 30 + k as u64);
        let domain = domain_around(&points);
        let options = options(30.0, domain);
        let mut dynamic = DynamicDelaunay::new(&points, &options).expect("a dynamic mesh");
        assert!(matches!(
            dynamic.take_changes(),
            Err(Error::InvalidOption { .. })
        ));
        dynamic.track_changes(true);
        let mut mesh = dynamic.mesh().unwrap();
        let mut changed = 0;
        // One edit at a time, then three between takes.
        for (round, per_take) in [(0, 1), (1, 1), (2, 3)] {
            for step in 0..per_take {
                random_edits(
                    &mut dynamic,
                    &options,
                    (domain, true),
                    1,
                    (round * 7 + step) as u64,
                );
            }
            let next = check_changes(&mut dynamic, &mesh, &options);
            changed += next.changes_from(&mesh).added.len();
            mesh = next;
        }
        assert!(changed > 0, "{dist:?}: the edits changed nothing");
        // No edit: no change.
        let none = dynamic.take_changes().unwrap();
        assert!(none.removed.is_empty() && none.added.is_empty());
        // A large batch refines everything again; a refused one changes nothing.
        let into_domain = |edits: Vec<Edit>| -> Vec<Edit> {
            let place = |p: DVec2| domain.lo + p * (domain.hi - domain.lo);
            edits
                .into_iter()
                .map(|e| match e {
                    Edit::Insert(p) => Edit::Insert(place(p)),
                    Edit::Move(id, p) => Edit::Move(id, place(p)),
                    delete => delete,
                })
                .collect()
        };
        dynamic
            .apply(&into_domain(batch(40, 3, 0)))
            .expect("a batch");
        mesh = check_changes(&mut dynamic, &mesh, &options);
        let mut refused = into_domain(batch(40, 4, 300));
        refused.push(Edit::Delete(100_000));
        dynamic.apply(&refused).expect_err("an unknown id");
        dynamic.insert(DVec2::NAN).expect_err("not a point");
        let none = dynamic.take_changes().unwrap();
        assert!(none.removed.is_empty() && none.added.is_empty());
        // A point on a corner of the domain changes no triangle; one on a side does.
        let corner = dynamic.insert(domain.lo).unwrap().id;
        let side = dynamic
            .insert(DVec2::new(domain.hi.x, (domain.lo.y + domain.hi.y) / 2.0))
            .unwrap()
            .id;
        mesh = check_changes(&mut dynamic, &mesh, &options);
        dynamic.delete(corner).unwrap();
        dynamic.delete(side).unwrap();
        check_changes(&mut dynamic, &mesh, &options);
        dynamic.track_changes(false);
        assert!(dynamic.take_changes().is_err());
    }
}

#[test]
fn the_changes_of_an_edit_are_found_near_it() {
    let points = generate::points(Distribution2d::Uniform, 6000, 23);
    let domain = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::ONE,
    };
    let options = options(30.0, domain);
    let mut dynamic = DynamicDelaunay::new(&points, &options).expect("a dynamic mesh");
    dynamic.track_changes(true);
    let mut mesh = dynamic.mesh().unwrap();
    let mut work = Vec::new();
    for seed in 0..8 {
        let reports = random_edits(&mut dynamic, &options, (middle(domain, 0.6), true), 1, seed);
        let vertices = dynamic.live_points().len() + dynamic.steiner_count();
        let changes = dynamic.clone().take_changes().unwrap();
        if !reports[0].rebuilt {
            work.push(changes.leaves as f64 / vertices as f64);
        }
        mesh = check_changes(&mut dynamic, &mesh, &options);
    }
    work.sort_by(f64::total_cmp);
    let median = work[work.len() / 2];
    assert!(
        median < 0.25,
        "a median edit triangulated {median} of the vertices"
    );
}

#[test]
fn edits_next_to_the_sides_replay_small_windows() {
    let points = generate::points(Distribution2d::Uniform, 6000, 29);
    let domain = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::ONE,
    };
    let options = options(30.0, domain);
    let mut dynamic = DynamicDelaunay::new(&points, &options).expect("a dynamic mesh");
    let mut mesh = dynamic.mesh().unwrap();
    dynamic.track_changes(true);
    let near_sides = [
        DVec2::new(0.37, 1e-4),
        DVec2::new(1.0 - 2e-5, 0.61),
        DVec2::new(0.52, 1.0 - 3e-3),
        DVec2::new(1e-6 + 1e-4, 0.2),
        DVec2::new(3e-4, 3e-4),
    ];
    for p in near_sides {
        let inserted = dynamic.insert(p).expect("a point near a side");
        let moved = dynamic
            .move_to(inserted.id, p + DVec2::new(-1e-4, 0.0))
            .unwrap();
        let deleted = dynamic.delete(inserted.id).unwrap();
        for r in [inserted, moved[0], moved[1], deleted] {
            assert!(!r.rebuilt && r.windows <= 2, "{p:?}: {r:?}");
        }
        mesh = check_changes(&mut dynamic, &mesh, &options);
    }
}
