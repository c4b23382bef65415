//! Any bytes as the recipe of a graph large enough for its points to go in strips (more than
//! 65 536 of them): a lattice of small star-shaped polygons (holes or regions, some left out,
//! their corners on a fine grid so that many points are cocircular and share coordinates with
//! others), the block with holes, or nested rings; scaled by a power of two and turned as the
//! bytes say. Each is meshed at a bound the bytes choose on one thread and on two: the answers
//! must be the same bytes (or the same error), and a mesh must pass the PSLG check and the
//! Delaunay check. This reaches the strips' seam probes, their glue and its flip budget, and
//! the fall-back to one sequence.
#![no_main]

use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use quadmesh::mesh::validate_pslg;
use quadmesh::{DVec2, Error, Input, Options, RegionSeed, Segment};
use rayon::{ThreadPool, ThreadPoolBuilder};

/// Polygons along each side of the lattice: with eight corners each, about 100 000 points
/// when none is left out.
const LATTICE: usize = 112;

/// Byte `i` of the pattern, read cyclically (0 when there is none).
fn pattern(bytes: &[u8], i: usize) -> u8 {
    if bytes.is_empty() {
        0
    } else {
        bytes[i % bytes.len()]
    }
}

/// Adds the closed loop `outline` with `marker` to `input`.
fn push_loop(input: &mut Input, outline: &[DVec2], marker: i32) {
    let first = input.points.len() as u32;
    let n = outline.len() as u32;
    input.points.extend_from_slice(outline);
    for k in 0..n {
        input.segments.push(Segment {
            ends: [first + k, first + (k + 1) % n],
            marker,
        });
    }
}

/// The lattice: a square of side `LATTICE` holding in each unit cell an octagon star-shaped
/// about the cell's centre (corners on the axes and diagonals at radii the pattern picks on a
/// 1/32 grid), a hole or a region of its own, or nothing where the pattern leaves it out.
fn lattice(bytes: &[u8]) -> Input {
    let mut input = Input::default();
    let side = LATTICE as f64;
    push_loop(
        &mut input,
        &[
            DVec2::ZERO,
            DVec2::new(side, 0.0),
            DVec2::new(side, side),
            DVec2::new(0.0, side),
        ],
        1,
    );
    let directions = [
        (1.0, 0.0),
        (1.0, 1.0),
        (0.0, 1.0),
        (-1.0, 1.0),
        (-1.0, 0.0),
        (-1.0, -1.0),
        (0.0, -1.0),
        (1.0, -1.0),
    ];
    for cell in 0..LATTICE * LATTICE {
        let code = pattern(bytes, cell);
        // A quarter of the cells, where the pattern says so, stay empty.
        if code % 4 == 3 {
            continue;
        }
        let centre = DVec2::new((cell % LATTICE) as f64 + 0.5, (cell / LATTICE) as f64 + 0.5);
        let outline: Vec<DVec2> = directions
            .iter()
            .enumerate()
            .map(|(k, &(dx, dy))| {
                let step = pattern(bytes, cell * 8 + k + 1) % 4;
                let radius = f64::from(8 + step) / 32.0;
                // Diagonal corners as far along each axis as the others along theirs: squares
                // and diamonds, every corner on the 1/32 grid.
                centre + DVec2::new(dx, dy) * radius
            })
            .collect();
        push_loop(&mut input, &outline, 2 + (cell % 5) as i32);
        if code % 4 == 0 {
            input.holes.push(centre);
        } else {
            input.regions.push(RegionSeed {
                seed: centre,
                attribute: f64::from(code % 7),
                max_area: None,
            });
        }
    }
    input
}

/// `input` scaled by 2^`exponent` (exact) and, when `turn`, mirrored across the diagonal.
fn transformed(mut input: Input, exponent: i32, turn: bool) -> Input {
    let scale = 2f64.powi(exponent);
    let map = |p: DVec2| {
        let p = p * scale;
        if turn { DVec2::new(p.y, p.x) } else { p }
    };
    for p in input.points.iter_mut().chain(&mut input.holes) {
        *p = map(*p);
    }
    for r in &mut input.regions {
        r.seed = map(r.seed);
    }
    input
}

fn pool(threads: usize) -> &'static ThreadPool {
    static POOLS: [OnceLock<ThreadPool>; 2] = [OnceLock::new(), OnceLock::new()];
    POOLS[threads - 1].get_or_init(|| {
        ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("a thread pool")
    })
}

fuzz_target!(|data: &[u8]| {
    let [angle, family, exponent, seed, pattern_bytes @ ..] = data else {
        return;
    };
    let seed = u64::from(*seed);
    let input = match family % 4 {
        0 | 1 => lattice(pattern_bytes),
        2 => quadmesh::generate::block_with_holes(16_384 + usize::from(*family) * 64, seed),
        _ => quadmesh::generate::nested_curves(65_536 + usize::from(*family) * 256, seed),
    };
    let exponent = i32::from(*exponent % 64) - 32;
    let input = transformed(input, exponent, family & 0x80 != 0);
    let options = Options::default()
        .min_angle(f64::from(angle % 34))
        .max_vertices(1_000_000);
    let one = pool(1).install(|| quadmesh::mesh(&input, &options));
    let two = pool(2).install(|| quadmesh::mesh(&input, &options));
    match (one, two) {
        (Ok((a, _)), Ok((b, _))) => {
            assert!(a == b, "one thread and two give different meshes");
            validate_pslg(&a, &input, options.angle_bounds())
                .unwrap_or_else(|e| panic!("invalid mesh: {e}"));
            a.check_delaunay()
                .unwrap_or_else(|e| panic!("not Delaunay: {e}"));
        }
        (Err(Error::VertexBudget(a)), Err(Error::VertexBudget(b))) => {
            assert!(
                a.mesh == b.mesh,
                "partial meshes differ between thread counts"
            );
            a.mesh
                .check_delaunay()
                .unwrap_or_else(|e| panic!("partial: {e}"));
        }
        (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
        (a, b) => panic!(
            "one thread and two disagree: {:?} / {:?}",
            a.map(|_| ()),
            b.map(|_| ())
        ),
    }
});
