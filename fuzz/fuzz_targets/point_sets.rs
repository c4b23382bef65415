//! Any bytes as up to 64 points (raw f64 bits) and options: every mode answers with a mesh that
//! passes `validate` (`validate_nonobtuse` in the nonobtuse mode; in the Delaunay mode, the exact
//! Delaunay check too) or a typed error. On the square, the Delaunay mode is also refined by
//! `refine_points_in_order`, whose mesh must pass the same checks and have the same triangles
//! for the points in reverse order. The quadtree modes may also mesh the square whose lower
//! left corner is the points' least coordinates, as wide as their larger extent, or the points'
//! bounding box: points lie on their sides and corners.
#![no_main]

use libfuzzer_sys::fuzz_target;
use quadmesh::refine::{RefineDomain, RefineOptions, refine_points_in_order};
use quadmesh::{DVec2, Error, Input, Mode, Options, Region};

/// Refinement in order on the square: valid, Delaunay, and the same triangles for the points
/// reversed.
fn check_in_order(points: &[DVec2], options: &Options) {
    let refine = RefineOptions {
        min_angle_deg: options.min_angle_deg(),
        domain: RefineDomain::Square,
        max_vertices: Some(20_000),
        ..RefineOptions::default()
    };
    let mut reversed = points.to_vec();
    reversed.reverse();
    match (
        refine_points_in_order(points, &refine),
        refine_points_in_order(&reversed, &refine),
    ) {
        (Ok((mesh, _)), Ok((other, _))) => {
            mesh.validate(points, options.angle_bounds())
                .unwrap_or_else(|e| panic!("in order: invalid mesh: {e}"));
            mesh.check_delaunay()
                .unwrap_or_else(|e| panic!("in order: not Delaunay: {e}"));
            let change = other.changes_from(&mesh);
            assert!(
                change.added.is_empty() && change.removed.is_empty(),
                "in order: depends on the input order"
            );
        }
        (Err(Error::VertexBudget(partial)), Err(_)) => {
            partial
                .mesh
                .check_delaunay()
                .unwrap_or_else(|e| panic!("in order: partial: {e}"));
        }
        (Ok(_), Err(e)) | (Err(e), Ok(_)) => panic!("in order: one order fails with {e}"),
        _ => {}
    }
}

/// How many times longer than wide the points' bounding box is, if they are finite and spread
/// both ways.
fn box_aspect(points: &[DVec2]) -> Option<f64> {
    let lo = points.iter().copied().reduce(DVec2::min)?;
    let hi = points.iter().copied().reduce(DVec2::max)?;
    let extent = hi - lo;
    (extent.is_finite() && extent.min_element() > 0.0)
        .then(|| extent.max_element() / extent.min_element())
}

/// The square from the points' least coordinates as wide as their larger extent, if they are
/// finite and spread.
fn square_on_the_points(points: &[DVec2]) -> Option<quadmesh::Domain> {
    let finite = points.iter().all(|p| p.is_finite());
    let lo = points.iter().copied().reduce(DVec2::min)?;
    let hi = points.iter().copied().reduce(DVec2::max)?;
    let side = (hi - lo).max_element();
    let far = lo + DVec2::splat(side);
    (finite && side > 0.0 && far.is_finite()).then_some(quadmesh::Domain { lo, hi: far })
}

fuzz_target!(|data: &[u8]| {
    let Some((&choice, rest)) = data.split_first() else {
        return;
    };
    let points: Vec<DVec2> = rest
        .chunks_exact(16)
        .take(64)
        .map(|c| {
            let x = f64::from_le_bytes(c[..8].try_into().unwrap());
            let y = f64::from_le_bytes(c[8..].try_into().unwrap());
            DVec2::new(x, y)
        })
        .collect();
    let mut options = if choice & 1 == 0 {
        Options::default()
            .min_angle(f64::from((choice >> 1) % 34))
            .max_vertices(20_000)
    } else if choice & 0x80 == 0 {
        if choice & 0x20 == 0 {
            // The warp coarsened, or the compact warp alone.
            match choice & 0x02 == 0 {
                true => Options::default().warp(),
                false => Options::default().compact_warp(),
            }
        } else {
            Options::default().block_warp()
        }
    } else {
        // The nonobtuse split coarsened, or the split alone.
        match choice & 0x02 == 0 {
            true => Options::default().nonobtuse(),
            false => Options::default().nonobtuse_split(),
        }
    };
    if choice & 1 != 0 && choice & 0x10 != 0 {
        if choice & 0x08 != 0 {
            // The bounding box, in the warp: a rectangle cut into nearly square cells. Boxes
            // longer than a thousand times their width take a row of cells along the long side,
            // and the block trees a band of up to 2^20 equal cells along a side that a point
            // comes near (seconds of meshing, bounded): those stay with the unit tests.
            let warp = matches!(options.mode(), Mode::Warp | Mode::CompactWarp);
            if warp && box_aspect(&points).is_some_and(|a| a <= 1e3) {
                options = options.region(Region::BoundingBox);
            }
        } else if let Some(square) = square_on_the_points(&points) {
            options = options.region(Region::Rectangle(square));
        }
    } else if choice & 0x40 != 0 {
        options = options.region(Region::Square);
        if choice & 1 == 0 {
            check_in_order(&points, &options);
        }
    }
    match quadmesh::mesh(&Input::points(points.clone()), &options) {
        Ok((mesh, _)) => {
            let nonobtuse = matches!(options.mode(), Mode::Nonobtuse | Mode::NonobtuseSplit);
            let checked = if nonobtuse {
                mesh.validate_nonobtuse(&points)
            } else {
                mesh.validate(&points, options.angle_bounds())
            };
            checked.unwrap_or_else(|e| panic!("invalid mesh: {e}"));
            if choice & 1 == 0 {
                mesh.check_delaunay()
                    .unwrap_or_else(|e| panic!("not Delaunay: {e}"));
            }
        }
        Err(
            Error::VertexBudget(partial)
            | Error::RefinementResolution {
                reached: Some(partial),
                ..
            },
        ) => {
            partial
                .mesh
                .check_delaunay()
                .unwrap_or_else(|e| panic!("partial: {e}"));
        }
        Err(_) => {}
    }
});
