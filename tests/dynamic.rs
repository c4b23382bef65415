//! Dynamic warped meshes: after any sequence of edits, the same mesh as a build from scratch of
//! the live points in id order, warped (coarsened too, on the corner tree) or nonobtuse; bad
//! edits change nothing.

use glam::DVec2;
use quadmesh::balance::Separation;
use quadmesh::dynamic::{DynamicMesh, Edit};
use quadmesh::mesh::Domain;
use quadmesh::{Error, Input, Mesh, Mode, Options, Region};
use rand::{Rng as _, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus as Rng;

fn unit() -> Domain {
    Domain {
        lo: DVec2::ZERO,
        hi: DVec2::ONE,
    }
}

/// What a build from scratch gives for the live points in id order, in the mode `mode`.
fn rebuilt_in(dynamic: &DynamicMesh, mode: Mode) -> Mesh {
    let (_, points) = dynamic.live_points();
    let options = Options::default()
        .with_mode(mode)
        .region(Region::Rectangle(dynamic.domain()));
    quadmesh::mesh(&Input::points(points), &options)
        .expect("the live points mesh from scratch")
        .0
}

/// Both trees a dynamic mesh keeps: the compact warp's (the default) and the block warp's.
const SEPARATIONS: [Separation; 2] = [Separation::Corner, Separation::Block];

/// The warp mode of a dynamic mesh's tree.
fn warp_mode(dynamic: &DynamicMesh) -> Mode {
    match dynamic.separation() {
        Separation::Corner => Mode::CompactWarp,
        Separation::Block => Mode::BlockWarp,
    }
}

/// The warped rebuild in the mode of the dynamic mesh's tree.
fn rebuilt(dynamic: &DynamicMesh) -> Mesh {
    rebuilt_in(dynamic, warp_mode(dynamic))
}

/// The dynamic mesh equals the rebuild, warped and coarsened (on the corner tree) or nonobtuse,
/// split and coarsened (on the block tree), and passes the crate's check with the bounds of its
/// mode; a corner tree refuses the nonobtuse split, a block tree the coarsened warp.
fn check(dynamic: &DynamicMesh, what: &str) {
    let mesh = dynamic.mesh().expect("the dynamic mesh warps");
    let expected = rebuilt(dynamic);
    assert!(
        mesh == expected,
        "{what}: the dynamic mesh differs from a rebuild"
    );
    let (_, points) = dynamic.live_points();
    let options = Options::default()
        .with_mode(warp_mode(dynamic))
        .region(Region::Rectangle(dynamic.domain()));
    mesh.validate(&points, options.angle_bounds())
        .unwrap_or_else(|e| panic!("{what}: {e}"));
    if dynamic.separation() == Separation::Corner {
        assert!(
            matches!(dynamic.mesh_nonobtuse(), Err(Error::InvalidOption { .. })),
            "{what}: a corner tree split nonobtuse"
        );
        assert!(
            matches!(
                dynamic.coarsened_nonobtuse_mesh(),
                Err(Error::InvalidOption { .. })
            ),
            "{what}: a corner tree split nonobtuse and coarsened"
        );
        let coarse = dynamic.coarsened_mesh().expect("the dynamic mesh coarsens");
        assert!(
            coarse == rebuilt_in(dynamic, Mode::Warp),
            "{what}: the dynamic coarsened mesh differs from a rebuild"
        );
        let warp = Options::default().warp();
        coarse
            .validate(&points, warp.angle_bounds())
            .unwrap_or_else(|e| panic!("{what}: coarsened: {e}"));
        return;
    }
    assert!(
        matches!(dynamic.coarsened_mesh(), Err(Error::InvalidOption { .. })),
        "{what}: a block tree coarsened"
    );
    let split = dynamic.mesh_nonobtuse().expect("the dynamic mesh splits");
    assert!(
        split == rebuilt_in(dynamic, Mode::NonobtuseSplit),
        "{what}: the dynamic nonobtuse split differs from a rebuild"
    );
    split
        .validate_nonobtuse(&points)
        .unwrap_or_else(|e| panic!("{what}: {e}"));
    let coarse = (dynamic.coarsened_nonobtuse_mesh()).expect("the dynamic mesh coarsens");
    assert!(
        coarse == rebuilt_in(dynamic, Mode::Nonobtuse),
        "{what}: the dynamic coarsened nonobtuse mesh differs from a rebuild"
    );
    coarse
        .validate_nonobtuse(&points)
        .unwrap_or_else(|e| panic!("{what}: coarsened: {e}"));
}

/// A point of the unit square from one of the families: uniform, a tight cluster, a
/// Kuzmin-like spread around a centre, on a side or a corner, or on a grid line.
fn point(rng: &mut Rng) -> DVec2 {
    match rng.random_range(0..10) {
        0 | 1 => DVec2::new(
            0.3 + rng.random::<f64>() * 1e-3,
            0.6 + rng.random::<f64>() * 1e-3,
        ),
        2 => {
            let r = 0.4 * rng.random::<f64>().powi(3);
            let a = rng.random::<f64>() * std::f64::consts::TAU;
            DVec2::new(0.5 + r * a.cos(), 0.5 + r * a.sin())
        }
        3 => DVec2::new(rng.random::<f64>(), 0.0),
        4 => DVec2::new(1.0, rng.random::<f64>()),
        5 => [DVec2::ZERO, DVec2::ONE, DVec2::new(0.0, 1.0)][rng.random_range(0..3)],
        6 => DVec2::new(0.5, rng.random::<f64>()),
        _ => DVec2::new(rng.random::<f64>(), rng.random::<f64>()),
    }
}

/// The point of `domain` at `p` of the unit square: the unit square's sides on the domain's,
/// exactly.
fn onto(domain: Domain, p: DVec2) -> DVec2 {
    let axis = |t: f64, lo: f64, hi: f64| match t {
        1.0 => hi,
        t => (lo + t * (hi - lo)).min(hi),
    };
    DVec2::new(
        axis(p.x, domain.lo.x, domain.hi.x),
        axis(p.y, domain.lo.y, domain.hi.y),
    )
}

/// Rectangles that are not squares: wide, tall, with no small fraction near their ratio, and
/// long strips.
fn rectangles() -> [Domain; 4] {
    let d = |lo: (f64, f64), hi: (f64, f64)| Domain {
        lo: lo.into(),
        hi: hi.into(),
    };
    [
        d((0.0, 0.0), (2.0, 1.0)),
        d((-0.1, -0.2), (1.05, 3.3)),
        d((0.0, 0.0), (std::f64::consts::SQRT_2, 1.0)),
        d((1.0, 2.0), (1.0 + 1e-3, 2.05)),
    ]
}

#[test]
fn on_rectangles_random_edits_give_the_rebuilt_mesh_after_every_step() {
    for domain in rectangles() {
        random_edits_on(domain, Separation::Corner, 1..=2, 80);
    }
}

#[test]
fn on_rectangles_tracked_changes_turn_the_old_mesh_into_the_new() {
    for domain in rectangles() {
        let mut rng = Rng::seed_from_u64(5);
        let mut initial: Vec<DVec2> = (0..60).map(|_| onto(domain, point(&mut rng))).collect();
        initial.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
        initial.dedup();
        let mut dynamic = DynamicMesh::new(&initial, domain).unwrap();
        dynamic.track_changes(true);
        let mut mesh = dynamic.mesh().unwrap();
        for step in 0..60 {
            let edit = match step % 3 {
                0 => Edit::Insert(onto(domain, point(&mut rng))),
                1 => Edit::Delete(some_id(&dynamic, &mut rng)),
                _ => Edit::Move(some_id(&dynamic, &mut rng), onto(domain, point(&mut rng))),
            };
            if let Err((_, e)) = dynamic.apply(&[edit]) {
                assert!(matches!(e, Error::DuplicatePoint { .. }), "{e}");
            }
            let what = format!("{domain:?} step {step}: {edit:?}");
            mesh = check_changes(&mut dynamic, &mesh, &what).0;
            assert!(mesh == rebuilt(&dynamic), "{what}: differs from a rebuild");
        }
    }
}

/// A random live id.
fn some_id(dynamic: &DynamicMesh, rng: &mut Rng) -> u32 {
    let (ids, _) = dynamic.live_points();
    ids[rng.random_range(0..ids.len())]
}

/// Edit `step` of a cycle: an insertion at a random place, the deletion of a random live
/// point, a move of one to a random place.
fn cycled_edit(step: usize, dynamic: &DynamicMesh, rng: &mut Rng) -> Edit {
    match step % 3 {
        0 => Edit::Insert(DVec2::new(rng.random::<f64>(), rng.random::<f64>())),
        1 => Edit::Delete(some_id(dynamic, rng)),
        _ => Edit::Move(
            some_id(dynamic, rng),
            DVec2::new(rng.random::<f64>(), rng.random::<f64>()),
        ),
    }
}

#[test]
fn random_edits_give_the_rebuilt_mesh_after_every_step() {
    for separation in SEPARATIONS {
        random_edits_give_the_rebuilt_mesh_after_every_step_with(separation);
    }
}

fn random_edits_give_the_rebuilt_mesh_after_every_step_with(separation: Separation) {
    random_edits_on(unit(), separation, 1..=4, 120);
}

/// Random edits of points of `domain`'s families (see [`point`]), seed by seed, each checked
/// against a rebuild after every step.
fn random_edits_on(
    domain: Domain,
    separation: Separation,
    seeds: std::ops::RangeInclusive<u64>,
    steps: usize,
) {
    let place = |rng: &mut Rng| onto(domain, point(rng));
    for seed in seeds {
        let mut rng = Rng::seed_from_u64(seed * 0x2545_F491_4F6C_DD1D);
        let initial: Vec<DVec2> = (0..30).map(|_| place(&mut rng)).collect();
        let mut initial = initial;
        initial.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
        initial.dedup();
        let mut dynamic = DynamicMesh::with_separation(&initial, domain, separation).unwrap();
        check(&dynamic, "the initial build");
        for step in 0..steps {
            let edit = match rng.random_range(0..if dynamic.len() > 1 { 3 } else { 1 }) {
                0 => Edit::Insert(place(&mut rng)),
                1 => Edit::Delete(some_id(&dynamic, &mut rng)),
                _ => Edit::Move(some_id(&dynamic, &mut rng), place(&mut rng)),
            };
            match dynamic.apply(&[edit]) {
                Ok(_) => check(&dynamic, &format!("seed {seed} step {step}: {edit:?}")),
                // A random place can repeat a live point's; nothing else may fail here.
                Err((_, e)) => assert!(matches!(e, Error::DuplicatePoint { .. }), "{e}"),
            }
        }
    }
}

#[test]
fn deleting_down_to_one_point_and_back() {
    for separation in SEPARATIONS {
        deleting_down_to_one_point_and_back_with(separation);
    }
}

fn deleting_down_to_one_point_and_back_with(separation: Separation) {
    let mut rng = Rng::seed_from_u64(99);
    let points: Vec<DVec2> = (0..25)
        .map(|_| DVec2::new(rng.random::<f64>(), rng.random::<f64>()))
        .collect();
    let mut dynamic = DynamicMesh::with_separation(&points, unit(), separation).unwrap();
    for id in 0..24 {
        dynamic.delete(id).unwrap();
        check(&dynamic, &format!("after deleting {id}"));
    }
    assert_eq!(dynamic.len(), 1);
    for k in 0..10 {
        let id = dynamic
            .insert(DVec2::new(rng.random::<f64>(), rng.random::<f64>()))
            .unwrap()
            .id;
        assert_eq!(id, 25 + k, "new points take the next ids");
        check(&dynamic, &format!("after inserting {id}"));
    }
}

#[test]
fn points_closer_than_the_narrow_grid_move_the_tree_to_the_wide_one_and_back() {
    for separation in SEPARATIONS {
        points_closer_than_the_narrow_grid_move_the_tree_to_the_wide_one_and_back_with(separation);
    }
}

fn points_closer_than_the_narrow_grid_move_the_tree_to_the_wide_one_and_back_with(
    separation: Separation,
) {
    let points = [DVec2::new(0.25, 0.25), DVec2::new(0.75, 0.6)];
    let mut dynamic = DynamicMesh::with_separation(&points, unit(), separation).unwrap();
    dynamic.track_changes(true);
    let first = dynamic.mesh().unwrap();
    assert!(!dynamic.is_wide());
    let close = dynamic
        .insert(DVec2::new(0.25 + 1e-11, 0.25))
        .expect("a close point goes on the wide grid");
    assert!(close.rebuilt && dynamic.is_wide());
    check(&dynamic, "with a point 1e-11 from another");
    let (wide, _) = check_changes(&mut dynamic, &first, "onto the wide grid");
    // On the wide grid, an edit's changes are found locally again.
    let far = dynamic.insert(DVec2::new(0.8, 0.2)).unwrap();
    let (wide, _) = check_changes(&mut dynamic, &wide, "an insertion on the wide grid");
    dynamic.delete(far.id).unwrap();
    let (wide, _) = check_changes(&mut dynamic, &wide, "a deletion on the wide grid");
    let back = dynamic.delete(close.id).unwrap();
    assert!(back.rebuilt && !dynamic.is_wide());
    check(&dynamic, "after deleting it");
    check_changes(&mut dynamic, &wide, "back onto the narrow grid");
}

#[test]
fn bad_edits_are_refused_and_change_nothing() {
    for separation in SEPARATIONS {
        bad_edits_are_refused_and_change_nothing_with(separation);
    }
}

fn bad_edits_are_refused_and_change_nothing_with(separation: Separation) {
    let points = [
        DVec2::new(0.2, 0.3),
        DVec2::new(0.7, 0.8),
        DVec2::new(0.5, 0.1),
    ];
    let mut dynamic = DynamicMesh::with_separation(&points, unit(), separation).unwrap();
    let before = dynamic.mesh().unwrap();
    let refused = [
        (Edit::Insert(DVec2::new(f64::NAN, 0.5)), "NonFinite"),
        (Edit::Insert(DVec2::new(1.5, 0.5)), "OutsideDomain"),
        (Edit::Insert(DVec2::new(0.7, 0.8)), "DuplicatePoint"),
        (Edit::Delete(7), "UnknownPoint"),
        (Edit::Move(1, DVec2::new(0.2, 0.3)), "DuplicatePoint"),
        (Edit::Move(2, DVec2::new(0.5, -0.1)), "OutsideDomain"),
    ];
    for (edit, kind) in refused {
        let Err((at, e)) = dynamic.apply(&[edit]) else {
            panic!("{edit:?} was accepted");
        };
        assert_eq!(at, 0);
        assert!(format!("{e:?}").starts_with(kind), "{edit:?}: {e:?}");
        assert_eq!(dynamic.mesh().unwrap(), before, "{edit:?} changed the mesh");
        assert_eq!(dynamic.len(), 3);
    }
    // A deleted id is unknown from then on, and the next insertion still takes id 3.
    dynamic.delete(0).unwrap();
    assert!(matches!(
        dynamic.delete(0),
        Err(Error::UnknownPoint { id: 0 })
    ));
    assert_eq!(dynamic.insert(DVec2::new(0.4, 0.4)).unwrap().id, 3);
    check(&dynamic, "after the refused edits");
}

/// A batch whose edits pass the checks but put a point where no grid separates it from
/// another fails where it is placed: everything the batch did before goes back, the ids too,
/// and the tracked changes say nothing changed.
#[test]
fn a_batch_failing_past_its_checks_takes_back_what_it_did() {
    for separation in SEPARATIONS {
        a_batch_failing_past_its_checks_takes_back_what_it_did_with(separation);
    }
}

fn a_batch_failing_past_its_checks_takes_back_what_it_did_with(separation: Separation) {
    // Near the origin a step of f64 is a few cells of the wide grid: too few to separate.
    let points = [DVec2::new(0.01, 0.01), DVec2::new(0.75, 0.6)];
    let crowded = DVec2::new(0.01f64.next_up(), 0.01);
    let edits = [
        Edit::Insert(DVec2::new(0.6, 0.3)),
        Edit::Move(1, DVec2::new(0.7, 0.65)),
        Edit::Insert(crowded),
        Edit::Delete(1),
    ];
    let mut one_by_one = DynamicMesh::with_separation(&points, unit(), separation).unwrap();
    one_by_one.track_changes(true);
    let before = one_by_one.mesh().unwrap();
    let mut batched = one_by_one.clone();
    let Err((at, e)) = one_by_one.apply(&edits) else {
        panic!("a point one step of f64 from another was placed");
    };
    assert_eq!(at, 2, "{e}");
    assert!(matches!(e, Error::Unresolvable { .. }), "{e}");
    let Err((_, e)) = batched.apply_batch(&edits) else {
        panic!("a point one step of f64 from another was placed in a batch");
    };
    assert!(matches!(e, Error::Unresolvable { .. }), "{e}");
    // A batch is placed as a whole: the point next to one the batch deletes is no crowd.
    let mut whole = edits;
    whole[3] = Edit::Delete(0);
    assert!(one_by_one.clone().apply(&whole).is_err());
    assert!(one_by_one.clone().apply_batch(&whole).is_ok());
    for dynamic in [&mut one_by_one, &mut batched] {
        assert_eq!(dynamic.mesh().unwrap(), before);
        assert_eq!(dynamic.live_points().1, points.to_vec());
        let changes = dynamic.take_changes().expect("changes are tracked");
        assert!(changes.removed.is_empty() && changes.added.is_empty());
        assert_eq!(dynamic.insert(DVec2::new(0.4, 0.4)).unwrap().id, 2);
        check(dynamic, "after the refused batch");
    }
}

#[test]
fn a_batch_equals_its_edits_one_by_one_and_a_bad_batch_changes_nothing() {
    for separation in SEPARATIONS {
        a_batch_equals_its_edits_one_by_one_and_a_bad_batch_changes_nothing_with(separation);
    }
}

fn a_batch_equals_its_edits_one_by_one_and_a_bad_batch_changes_nothing_with(
    separation: Separation,
) {
    let mut rng = Rng::seed_from_u64(5);
    let points: Vec<DVec2> = (0..40)
        .map(|_| DVec2::new(rng.random::<f64>(), rng.random::<f64>()))
        .collect();
    let mut batched = DynamicMesh::with_separation(&points, unit(), separation).unwrap();
    let mut single = batched.clone();
    let edits: Vec<Edit> = (0..30)
        .map(|k| match k % 3 {
            0 => Edit::Insert(DVec2::new(rng.random::<f64>(), rng.random::<f64>())),
            1 => Edit::Delete(k as u32),
            _ => Edit::Move(
                k as u32,
                DVec2::new(rng.random::<f64>(), rng.random::<f64>()),
            ),
        })
        .collect();
    let mut sequential = batched.clone();
    let report = batched.apply_batch(&edits).unwrap();
    sequential.apply(&edits).unwrap();
    for &edit in &edits {
        single.apply(&[edit]).unwrap();
    }
    assert_eq!(batched.mesh().unwrap(), single.mesh().unwrap());
    assert_eq!(sequential.mesh().unwrap(), single.mesh().unwrap());
    assert_eq!(batched.live_points(), single.live_points());
    assert_eq!(report.ids.len(), edits.len());
    check(&batched, "after the batch");
    let before = batched.mesh().unwrap();
    let bad = [Edit::Insert(DVec2::new(0.123, 0.456)), Edit::Delete(1)];
    assert_eq!(batched.apply(&bad).unwrap_err().0, 1);
    assert_eq!(batched.apply_batch(&bad).unwrap_err().0, 1);
    assert_eq!(batched.mesh().unwrap(), before);
    // 40 points and 10 insertions: the refused batches took no id.
    assert_eq!(batched.insert(DVec2::new(0.31, 0.62)).unwrap().id, 50);
}

#[test]
fn random_batches_equal_their_edits_one_by_one() {
    for separation in SEPARATIONS {
        random_batches_equal_their_edits_one_by_one_with(separation);
    }
}

fn random_batches_equal_their_edits_one_by_one_with(separation: Separation) {
    for seed in 1..=6u64 {
        let mut rng = Rng::seed_from_u64(seed * 0x1234_5678_9ABC_DEF1);
        let initial: Vec<DVec2> = {
            let mut v: Vec<DVec2> = (0..60).map(|_| point(&mut rng)).collect();
            v.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
            v.dedup();
            v
        };
        let mut batched = DynamicMesh::with_separation(&initial, unit(), separation).unwrap();
        let mut single = batched.clone();
        for round in 0..8 {
            // Edits that may name points inserted or moved earlier in the same batch.
            let mut edits = Vec::new();
            let mut next_id = batched.live_points().0.iter().max().map_or(0, |m| m + 1);
            let (mut ids, _) = batched.live_points();
            for _ in 0..1 + rng.random_range(0..25) {
                let edit = match rng.random_range(0..if ids.len() > 1 { 4 } else { 1 }) {
                    0 => {
                        ids.push(next_id.max(batched.len() as u32));
                        next_id += 1;
                        Edit::Insert(point(&mut rng))
                    }
                    1 => Edit::Delete(ids.swap_remove(rng.random_range(0..ids.len()))),
                    2 => Edit::Move(ids[rng.random_range(0..ids.len())], point(&mut rng)),
                    _ => {
                        let id = ids[rng.random_range(0..ids.len())];
                        let p = batched.point(id).unwrap_or(DVec2::splat(0.5));
                        Edit::Move(id, (p + DVec2::splat(1e-6)).min(DVec2::ONE))
                    }
                };
                edits.push(edit);
            }
            let together = batched.apply_batch(&edits);
            let one_by_one = single.apply(&edits);
            match (together, one_by_one) {
                (Ok(_), Ok(_)) => {
                    assert_eq!(batched.live_points(), single.live_points());
                    assert!(batched.mesh().unwrap() == single.mesh().unwrap());
                    check(&batched, &format!("seed {seed} round {round}"));
                }
                (Err((a, _)), Err((b, _))) => assert_eq!(a, b, "seed {seed} round {round}"),
                (a, b) => panic!("seed {seed} round {round}: batch {a:?}, one by one {b:?}"),
            }
        }
    }
}

#[test]
fn a_time_step_of_moving_points_equals_a_rebuild() {
    for separation in SEPARATIONS {
        a_time_step_of_moving_points_equals_a_rebuild_with(separation);
    }
}

fn a_time_step_of_moving_points_equals_a_rebuild_with(separation: Separation) {
    let mut rng = Rng::seed_from_u64(11);
    let points: Vec<DVec2> = (0..200)
        .map(|_| {
            DVec2::new(
                0.1 + 0.8 * rng.random::<f64>(),
                0.1 + 0.8 * rng.random::<f64>(),
            )
        })
        .collect();
    let mut dynamic = DynamicMesh::with_separation(&points, unit(), separation).unwrap();
    for step in 0..3 {
        let (ids, _) = dynamic.live_points();
        let shifts: Vec<DVec2> = ids
            .iter()
            .map(|_| DVec2::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5) * 1e-3)
            .collect();
        dynamic.move_all(&ids, &shifts).unwrap();
        check(&dynamic, &format!("time step {step}"));
    }
}

#[test]
fn one_and_several_threads_give_the_same_mesh() {
    for separation in SEPARATIONS {
        one_and_several_threads_give_the_same_mesh_with(separation);
    }
}

fn one_and_several_threads_give_the_same_mesh_with(separation: Separation) {
    let mut rng = Rng::seed_from_u64(21);
    let points: Vec<DVec2> = (0..300).map(|_| point(&mut rng)).collect();
    let mut points = points;
    points.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    points.dedup();
    let edits: Vec<Edit> = (0..60)
        .map(|k| match k % 2 {
            0 => Edit::Insert(DVec2::new(rng.random::<f64>(), rng.random::<f64>())),
            _ => Edit::Delete(k as u32),
        })
        .collect();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut dynamic = DynamicMesh::with_separation(&points, unit(), separation).unwrap();
            dynamic.apply(&edits).unwrap();
            dynamic.mesh().unwrap()
        })
    };
    assert_eq!(run(1), run(3));
}

#[test]
fn a_block_tree_on_a_domain_that_is_not_square_is_refused() {
    let domain = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::new(2.0, 1.0),
    };
    assert!(matches!(
        DynamicMesh::with_separation(&[DVec2::new(0.5, 0.5)], domain, Separation::Block),
        Err(Error::InvalidOption { .. })
    ));
    assert!(DynamicMesh::new(&[DVec2::new(0.5, 0.5)], domain).is_ok());
    let needle = Domain {
        lo: DVec2::ZERO,
        hi: DVec2::new(1e7, 1.0),
    };
    assert!(matches!(
        DynamicMesh::new(&[DVec2::new(0.5, 0.5)], needle),
        Err(Error::ThinDomain { .. })
    ));
    assert!(matches!(
        DynamicMesh::new(&[DVec2::new(0.5, 0.5), DVec2::new(0.5, 0.5)], unit()),
        Err(Error::DuplicatePoint { .. })
    ));
}

#[test]
fn the_change_between_meshes_is_local_and_turns_the_old_mesh_into_the_new() {
    for separation in SEPARATIONS {
        the_change_between_meshes_is_local_and_turns_the_old_mesh_into_the_new_with(separation);
    }
}

fn the_change_between_meshes_is_local_and_turns_the_old_mesh_into_the_new_with(
    separation: Separation,
) {
    let mut rng = Rng::seed_from_u64(41);
    let points: Vec<DVec2> = (0..2000)
        .map(|_| DVec2::new(rng.random::<f64>(), rng.random::<f64>()))
        .collect();
    let mut dynamic = DynamicMesh::with_separation(&points, unit(), separation).unwrap();
    let corners = |m: &Mesh, t: u32| m.triangles[t as usize].map(|v| m.vertices[v as usize]);
    for step in 0..12 {
        let before = dynamic.mesh().unwrap();
        let edit = cycled_edit(step, &dynamic, &mut rng);
        dynamic.apply(&[edit]).unwrap();
        let after = dynamic.mesh().unwrap();
        let change = after.changes_from(&before);
        // Kept triangles are the same triangles, and with the new ones they make the mesh.
        for &[old, new] in &change.kept {
            let (a, b) = (corners(&before, old), corners(&after, new));
            assert!(
                (0..3).any(|r| (0..3).all(|k| a[k] == b[(k + r) % 3])),
                "{edit:?}"
            );
        }
        assert_eq!(
            change.kept.len() + change.added.len(),
            after.triangles.len()
        );
        assert_eq!(
            change.kept.len() + change.removed.len(),
            before.triangles.len()
        );
        // An edit among 2000 points changes a small part of the mesh.
        let changed = change.removed.len() + change.added.len();
        assert!(
            changed * 20 < after.triangles.len(),
            "{edit:?}: {changed} of {} triangles changed",
            after.triangles.len()
        );
    }
}

/// A mesh's triangles by their corners' bits, each from its least corner on.
fn triangle_set(mesh: &Mesh) -> Vec<[[u64; 2]; 3]> {
    let mut all: Vec<[[u64; 2]; 3]> = mesh
        .triangles
        .iter()
        .map(|t| bits(t.map(|v| mesh.vertices[v as usize])))
        .collect();
    all.sort_unstable();
    all
}

fn bits(corners: [DVec2; 3]) -> [[u64; 2]; 3] {
    let mut b = corners.map(|p| [p.x.to_bits(), p.y.to_bits()]);
    let least = (0..3).min_by_key(|&i| b[i]).unwrap();
    b.rotate_left(least);
    b
}

/// The tracked changes since the last take turn `before` into the dynamic mesh as it is:
/// every removed triangle was in `before`, every added one is new, and what is left with them
/// is the mesh. Returns the mesh and the leaves the changes took. Nonobtuse: the changes of
/// the nonobtuse mesh, taken from a copy (the warped mesh's are taken from `dynamic`).
fn check_changes_in(
    dynamic: &mut DynamicMesh,
    before: &Mesh,
    what: &str,
    nonobtuse: bool,
) -> (Mesh, usize) {
    let (changes, after) = if nonobtuse {
        let mut copy = dynamic.clone();
        let changes = copy.take_nonobtuse_changes().expect("changes are tracked");
        (
            changes,
            dynamic.mesh_nonobtuse().expect("the dynamic mesh splits"),
        )
    } else {
        let changes = dynamic.take_changes().expect("changes are tracked");
        (changes, dynamic.mesh().expect("the dynamic mesh warps"))
    };
    let mut expected = triangle_set(before);
    let mut removed: Vec<_> = changes.removed.iter().map(|&t| bits(t)).collect();
    removed.sort_unstable();
    // Take out each removed triangle once: all of them must be there.
    let mut kept = Vec::with_capacity(expected.len());
    let mut r = 0;
    for t in expected.drain(..) {
        if r < removed.len() && removed[r] == t {
            r += 1;
        } else {
            kept.push(t);
        }
    }
    assert_eq!(
        r,
        removed.len(),
        "{what}: a removed triangle was not in the mesh"
    );
    kept.extend(changes.added.iter().map(|&t| bits(t)));
    kept.sort_unstable();
    assert!(
        kept == triangle_set(&after),
        "{what}: the mesh less {} removed and with {} added triangles is not the new mesh",
        changes.removed.len(),
        changes.added.len()
    );
    (after, changes.leaves)
}

fn check_changes(dynamic: &mut DynamicMesh, before: &Mesh, what: &str) -> (Mesh, usize) {
    check_changes_in(dynamic, before, what, false)
}

/// A dynamic mesh of `n` uniform points of the unit square that tracks changes, and its mesh.
fn tracked_uniform(rng: &mut Rng, separation: Separation, n: usize) -> (DynamicMesh, Mesh) {
    let points: Vec<DVec2> = (0..n)
        .map(|_| DVec2::new(rng.random::<f64>(), rng.random::<f64>()))
        .collect();
    let mut dynamic = DynamicMesh::with_separation(&points, unit(), separation).unwrap();
    dynamic.track_changes(true);
    let mesh = dynamic.mesh().unwrap();
    (dynamic, mesh)
}

#[test]
fn tracked_changes_turn_the_old_mesh_into_the_new_after_every_edit() {
    for separation in SEPARATIONS {
        tracked_changes_turn_the_old_mesh_into_the_new_after_every_edit_with(separation);
    }
}

fn tracked_changes_turn_the_old_mesh_into_the_new_after_every_edit_with(separation: Separation) {
    for seed in 1..=3u64 {
        let mut rng = Rng::seed_from_u64(seed * 0x9E37_79B9_7F4A_7C15);
        let mut initial: Vec<DVec2> = (0..60).map(|_| point(&mut rng)).collect();
        initial.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
        initial.dedup();
        let mut dynamic = DynamicMesh::with_separation(&initial, unit(), separation).unwrap();
        dynamic.track_changes(true);
        let mut mesh = dynamic.mesh().unwrap();
        let block = separation == Separation::Block;
        let mut split = if block {
            dynamic.mesh_nonobtuse().unwrap()
        } else {
            Mesh::default()
        };
        for step in 0..150 {
            let edit = match rng.random_range(0..if dynamic.len() > 1 { 3 } else { 1 }) {
                0 => Edit::Insert(point(&mut rng)),
                1 => Edit::Delete(some_id(&dynamic, &mut rng)),
                _ => Edit::Move(some_id(&dynamic, &mut rng), point(&mut rng)),
            };
            match dynamic.apply(&[edit]) {
                Ok(_) => {}
                Err((_, e)) => assert!(matches!(e, Error::DuplicatePoint { .. }), "{e}"),
            }
            let what = format!("seed {seed} step {step}: {edit:?}");
            if block {
                split = check_changes_in(&mut dynamic, &split, &what, true).0;
            }
            mesh = check_changes(&mut dynamic, &mesh, &what).0;
        }
    }
}

#[test]
fn tracked_changes_of_batches_and_rebuilds_turn_the_old_mesh_into_the_new() {
    for separation in SEPARATIONS {
        tracked_changes_of_batches_and_rebuilds_turn_the_old_mesh_into_the_new_with(separation);
    }
}

fn tracked_changes_of_batches_and_rebuilds_turn_the_old_mesh_into_the_new_with(
    separation: Separation,
) {
    let mut rng = Rng::seed_from_u64(77);
    let (mut dynamic, mut mesh) = tracked_uniform(&mut rng, separation, 400);
    for step in 0..8 {
        // Small batches stay local; every third moves all points, which builds anew.
        let count = if step % 3 == 2 { dynamic.len() } else { 5 };
        let (ids, _) = dynamic.live_points();
        let mut edits: Vec<Edit> = Vec::new();
        for &id in ids.iter().take(count) {
            let p = dynamic.point(id).unwrap();
            let d = DVec2::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5) * 1e-3;
            edits.push(Edit::Move(id, (p + d).clamp(DVec2::ZERO, DVec2::ONE)));
        }
        edits.push(Edit::Insert(DVec2::new(rng.random(), rng.random())));
        dynamic.apply_batch(&edits).unwrap();
        mesh = check_changes(&mut dynamic, &mesh, &format!("batch {step}")).0;
    }
}

#[test]
fn the_changes_of_one_edit_among_many_points_take_few_leaves() {
    for separation in SEPARATIONS {
        the_changes_of_one_edit_among_many_points_take_few_leaves_with(separation);
    }
}

fn the_changes_of_one_edit_among_many_points_take_few_leaves_with(separation: Separation) {
    let mut rng = Rng::seed_from_u64(5);
    let (mut dynamic, mut mesh) = tracked_uniform(&mut rng, separation, 20_000);
    let total = mesh.triangles.len();
    let mut leaves = Vec::new();
    for step in 0..9 {
        let edit = cycled_edit(step, &dynamic, &mut rng);
        dynamic.apply(&[edit]).unwrap();
        let (after, taken) = check_changes(&mut dynamic, &mesh, &format!("{edit:?}"));
        leaves.push(taken);
        mesh = after;
    }
    leaves.sort_unstable();
    // The median edit warps a small part of the tree (about 45 leaves a point in all).
    assert!(
        leaves[leaves.len() / 2] * 50 < total,
        "leaves per edit {leaves:?} against {total} triangles"
    );
}

#[test]
fn edits_beside_a_crowd_warp_few_leaves() {
    for separation in SEPARATIONS {
        edits_beside_a_crowd_warp_few_leaves_with(separation);
    }
}

/// A crowd of points 1e-3 across in the middle and a few points far out: an edit far from the
/// crowd has large leaves, whose 2×2 blocks and rings reach the crowd's square without holding
/// it. Its changes must warp the leaves around it, not the crowd's tree.
fn edits_beside_a_crowd_warp_few_leaves_with(separation: Separation) {
    let mut rng = Rng::seed_from_u64(23);
    let mut points: Vec<DVec2> = (0..3000)
        .map(|_| DVec2::splat(0.5) + (DVec2::new(rng.random(), rng.random()) - 0.5) * 1e-3)
        .collect();
    points.extend([
        DVec2::new(0.1, 0.15),
        DVec2::new(0.85, 0.2),
        DVec2::new(0.3, 0.9),
    ]);
    let mut dynamic = DynamicMesh::with_separation(&points, unit(), separation).unwrap();
    dynamic.track_changes(true);
    let mut mesh = dynamic.mesh().unwrap();
    let mut split = dynamic.mesh_nonobtuse().unwrap_or_default();
    let total = mesh.triangles.len();
    // Inserted far out, each then moved far out, and the first far points deleted.
    let mut inserted = 0;
    for step in 0..9 {
        let edit = match step % 3 {
            0 => Edit::Insert(DVec2::new(rng.random::<f64>(), rng.random::<f64>())),
            1 => Edit::Move(
                inserted,
                DVec2::new(rng.random::<f64>(), rng.random::<f64>()),
            ),
            _ => Edit::Delete(3000 + step as u32 / 3),
        };
        let what = format!("step {step}: {edit:?}");
        let id = dynamic.apply(&[edit]).unwrap()[0].id;
        if matches!(edit, Edit::Insert(_)) {
            inserted = id;
        }
        if separation == Separation::Block {
            let (after, taken) = check_changes_in(&mut dynamic, &split, &what, true);
            assert!(
                taken * 20 < total,
                "{what}: {taken} leaves, {total} triangles"
            );
            split = after;
        }
        let (after, taken) = check_changes(&mut dynamic, &mesh, &what);
        assert!(
            taken * 20 < total,
            "{what}: {taken} leaves, {total} triangles"
        );
        mesh = after;
    }
}

#[test]
fn changes_are_refused_unless_tracked() {
    let mut dynamic = DynamicMesh::new(&[DVec2::splat(0.5)], unit()).unwrap();
    assert!(matches!(
        dynamic.take_changes(),
        Err(Error::InvalidOption { .. })
    ));
    dynamic.track_changes(true);
    dynamic.insert(DVec2::splat(0.25)).unwrap();
    assert!(!dynamic.take_changes().unwrap().added.is_empty());
    dynamic.track_changes(false);
    assert!(dynamic.take_changes().is_err());
}
