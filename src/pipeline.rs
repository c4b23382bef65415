//! The stages chained: points → Morton order → framework → unbalanced quadtree, with timings.
//! The CLI, the benches and the tests all call these.

use glam::DVec2;

use crate::balance::{
    BalancedTree, Band, BandError, Conflict, DomainSides, GraphFeatures, Separation, TooCrowded,
    balance, balance_closure, coarsest_band_level, crowded_squares, linked_tree, separate,
    separate_in, separate_with,
};
use crate::error::Error;
use crate::framework::{Framework, build_framework};
pub use crate::mesh::StageTimes;
use crate::mesh::{AngleQuality, BoundarySide, Domain, Mesh, MeshReport, NONE, report_of};
use crate::morton::{
    DomainCells, DomainLayout, Duplicates, Grid, Morton, MortonKey, MortonOrder, SortAlgorithm,
    bounding_box, morton_order, morton_order_on, morton_order_wide, validate_points,
};
use crate::options::{Input, Mode, Options, Region};
use crate::pslg::{CornerCut, carve_warped};
use crate::quadtree::{Quadtree, expand};
use crate::refine::{
    PslgOptions, RefineDomain, RefineOptions, refine_graph_mesh, refine_points, refine_pslg,
    within_budget,
};
pub use crate::warp::placement::domain_reflections;
use crate::warp::placement::{GradedColumns, graded_columns, mirrored};
use crate::warp::{
    COARSE_ANGLE_BOUNDS, EdgePieces, GRAPH_ANGLE_BOUNDS, GraphLeaves, NONOBTUSE_COARSE_BOUNDS,
    coarsen, edge_pieces, finest_resolved_level, leaves_in_domain, point_finer_than_grid,
    smooth_steiner_vertices, split, triangulate_graph, unresolvable, warp,
};

/// The trees of one input on one grid width.
#[derive(Clone, Debug)]
pub struct TreeBuild<K: Copy> {
    /// Distinct points in Morton order, the grid and the merged duplicates.
    pub morton: MortonOrder<K>,
    /// The compressed quadtree.
    pub framework: Framework<K>,
    /// The unbalanced quadtree.
    pub quadtree: Quadtree<K>,
    /// The balanced (or well-separated) tree, when asked for.
    pub balanced: Option<BalancedTree<K>>,
    /// The band of uniform leaves along a given domain's top side, when that lies inside the
    /// root.
    pub band: Option<Band>,
}

impl<K: MortonKey> TreeBuild<K> {
    /// The most refined tree built: the balanced one if there is one.
    pub fn final_tree(&self) -> &Quadtree<K> {
        self.balanced.as_ref().map_or(&self.quadtree, |b| &b.tree)
    }
}

/// How far to refine the quadtree.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Refinement {
    /// Every point alone in its leaf.
    #[default]
    Unbalanced,
    /// Also 2:1 balanced, with cross links and point location.
    Balanced,
    /// Balanced, and every point's leaf centred in a 5×5 block of same-size empty leaves.
    Separated,
    /// Balanced, and separated by the blocks around the points' nearest corners
    /// ([`Separation::Corner`], the warp's tree).
    CornerSeparated,
}

/// What [`build_tree`] builds and how.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TreeOptions {
    /// The sort used for Morton order.
    pub sort: SortAlgorithm,
    /// How far to refine.
    pub refinement: Refinement,
}

impl TreeOptions {
    /// These options with another refinement.
    pub fn refinement(self, refinement: Refinement) -> Self {
        TreeOptions { refinement, ..self }
    }

    /// These options with another sort.
    pub fn sort(self, sort: SortAlgorithm) -> Self {
        TreeOptions { sort, ..self }
    }
}

/// The trees on whichever grid the input needed.
#[derive(Clone, Debug)]
pub enum Tree {
    /// 32 bits per axis.
    Narrow(TreeBuild<u64>),
    /// 64 bits per axis.
    Wide(TreeBuild<u128>),
}

impl Tree {
    /// The grid of the build.
    pub fn grid(&self) -> &Grid {
        match self {
            Tree::Narrow(b) => &b.morton.grid,
            Tree::Wide(b) => &b.morton.grid,
        }
    }

    /// The duplicates merged.
    pub fn duplicates(&self) -> &Duplicates {
        match self {
            Tree::Narrow(b) => &b.morton.duplicates,
            Tree::Wide(b) => &b.morton.duplicates,
        }
    }
}

/// Builds the Morton order, the framework, the unbalanced quadtree and, if asked, the balanced
/// tree of `points` on the current rayon pool, timing each stage.
///
/// # Errors
/// Whatever [`morton_order`] refuses: empty input, non-finite coordinates, inseparable points.
pub fn build_tree(points: &[DVec2], options: &TreeOptions) -> Result<(Tree, StageTimes), Error> {
    let mut times = StageTimes::default();
    let morton = times.time("morton", || morton_order(points, options.sort))?;
    let tree = match morton {
        Morton::Narrow(m) => Tree::Narrow(trees_of(m, options, &mut times)),
        Morton::Wide(m) => Tree::Wide(trees_of(m, options, &mut times)),
    };
    Ok((tree, times))
}

fn trees_of<K: MortonKey>(
    morton: MortonOrder<K>,
    options: &TreeOptions,
    times: &mut StageTimes,
) -> TreeBuild<K> {
    let keys = &morton.keys;
    let framework = times.time("framework", || build_framework(keys));
    let quadtree = times.time("quadtree", || expand(&framework, keys));
    let balanced = match options.refinement {
        Refinement::Unbalanced => None,
        Refinement::Balanced => Some(times.time("balance", || balance(&quadtree, keys))),
        Refinement::Separated => Some(times.time("separate", || separate(&quadtree, keys))),
        Refinement::CornerSeparated => Some(times.time("separate", || {
            separate_with(&quadtree, keys, Separation::Corner)
        })),
    };
    TreeBuild {
        morton,
        framework,
        quadtree,
        balanced,
        band: None,
    }
}

/// What [`mesh_points`] builds and how.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeshOptions {
    /// The sort used for Morton order.
    pub sort: SortAlgorithm,
    /// The rectangle to mesh, holding every point (on its sides too); by default the points'
    /// bounding box centred in a square twice its larger side.
    pub domain: Option<Domain>,
    /// Split the leaves by the lines through the points into right triangles (every angle at
    /// most 90°, see [`crate::warp::split`]) instead of warping their corners.
    pub nonobtuse: bool,
    /// The separation rule of the tree the warp moves: [`Separation::Corner`] for the compact
    /// warp (every angle in [`crate::warp::COMPACT_ANGLE_BOUNDS`]), [`Separation::Block`] for
    /// the block warp ([`crate::warp::ANGLE_BOUNDS`]). The nonobtuse split uses the block rule
    /// whatever this says.
    pub separation: Separation,
    /// Coarsen the mesh (see [`crate::warp::coarsen`]): the warp's to every new angle in
    /// [`crate::warp::COARSE_ANGLE_BOUNDS`], the nonobtuse split's to every new angle in
    /// [`crate::warp::NONOBTUSE_COARSE_BOUNDS`].
    pub coarsen: bool,
}

impl MeshOptions {
    /// The rule the tree is built by: the one asked for where it applies.
    fn effective_separation(&self) -> Separation {
        if self.nonobtuse {
            Separation::Block
        } else {
            self.separation
        }
    }
}

/// The well-separated tree the warp needs, on the narrow grid if it resolves the points finely
/// enough for their leaves, on the wide grid otherwise; on the options' domain if they give one,
/// which must then be at least as wide as it is tall (see [`Grid::on_domain`]) and hold the
/// points.
///
/// # Errors
/// Whatever [`morton_order`] refuses, [`Error::Unresolvable`] for points too close together
/// relative to the extent for even the wide grid, [`Error::NearDomainSide`] when a domain's
/// top side needs too fine a band of leaves, and [`Error::ThinDomain`] for a domain too
/// elongated for one.
pub fn separated_tree(
    points: &[DVec2],
    options: &MeshOptions,
) -> Result<(Tree, StageTimes), Error> {
    // A failed graded attempt's stages stay in the times: they were spent.
    let mut times = StageTimes::default();
    if let Some(domain) = options.domain
        && options.effective_separation() == Separation::Corner
    {
        let cells = domain_cells(points.len(), domain)?;
        let tree = separated_tree_on(
            points,
            options,
            (DomainLayout::Cells(cells), None),
            &mut times,
        )?;
        return Ok((tree.expect("a cells grid needs no band"), times));
    }
    let graded = options.domain.and_then(|d| graded_columns(points, d));
    if let Some(columns) = graded
        && let Some(tree) = separated_tree_on(
            points,
            options,
            (
                DomainLayout::Columns(columns.level, columns.columns),
                Some(columns),
            ),
            &mut times,
        )?
    {
        return Ok((tree, times));
    }
    let tree = separated_tree_on(points, options, (DomainLayout::Root, None), &mut times)?;
    Ok((tree.expect("a uniform band needs no grading"), times))
}

/// The cells the compact warp cuts a given domain into: [`Error::ThinDomain`] when they would be
/// more along a side than [`band_level_limit`] allows leaves along a band.
fn domain_cells(points: usize, domain: Domain) -> Result<DomainCells, Error> {
    DomainCells::for_domain(domain.hi - domain.lo, 1 << band_level_limit::<u64>(points))
}

/// [`separated_tree`] on the grid `layout` lays on the options' domain (if any); `None` when the
/// band along a graded domain's top side turns out finer than its columns allow.
fn separated_tree_on(
    points: &[DVec2],
    options: &MeshOptions,
    (layout, columns): (DomainLayout, Option<GradedColumns>),
    times: &mut StageTimes,
) -> Result<Option<Tree>, Error> {
    let domain = options.domain.map(|d| (d.lo, d.hi, layout));
    let morton = times.time("morton", || morton_order_on(points, domain, options.sort))?;
    let m = match morton {
        Morton::Narrow(m) => {
            let Some(build) =
                separated_build(m, points, (columns, options.effective_separation()), times)?
            else {
                return Ok(None);
            };
            if deepest_point_leaf(&build, options.effective_separation()).is_none() {
                return Ok(Some(Tree::Narrow(build)));
            }
            // Points so close that their leaves are finer than the narrow grid resolves the
            // points: the wide grid places them exactly enough.
            times.time("morton wide", || {
                morton_order_wide(points, domain, options.sort)
            })?
        }
        Morton::Wide(m) => m,
    };
    let Some(build) = separated_build(m, points, (columns, options.effective_separation()), times)?
    else {
        return Ok(None);
    };
    if let Some(p) = deepest_point_leaf(&build, options.effective_separation()) {
        let index = build.morton.order[p];
        return Err(unresolvable(points[index as usize], index));
    }
    Ok(Some(Tree::Wide(build)))
}

/// The framework, the unbalanced tree and the well-separated tree on `morton`'s grid, with the
/// band along the domain's top side if it has one inside the root (the grid then moves the
/// band's top row onto that side); graded as `columns` says if given, `None` if leaves finer
/// than that allows meet the side.
fn separated_build<K: MortonKey>(
    mut morton: MortonOrder<K>,
    points: &[DVec2],
    (columns, separation): (Option<GradedColumns>, Separation),
    times: &mut StageTimes,
) -> Result<Option<TreeBuild<K>>, Error> {
    let mut sides = DomainSides::of(points, &morton.order, &morton.grid);
    // `graded_columns` rounded the top side as this grid does, so the choice holds here.
    if let (Some(sides), Some(c)) = (sides.as_mut(), columns) {
        sides.graded_top = Some((c.level as u8, c.finest.min(K::AXIS_BITS) as u8));
    }
    let keys = &morton.keys;
    let limit = band_level_limit::<K>(keys.len());
    if let Some(top) = morton.grid.inner_top()
        && coarsest_band_level(top, K::AXIS_BITS) > limit
    {
        let (lo, hi) = morton.grid.domain();
        return Err(Error::ThinDomain {
            width: hi.x - lo.x,
            height: hi.y - lo.y,
        });
    }
    let framework = times.time("framework", || build_framework(keys));
    let quadtree = times.time("quadtree", || expand(&framework, keys));
    let separated = times.time("separate", || {
        separate_in(&quadtree, keys, sides.as_ref(), limit, separation)
    });
    let (balanced, band) = match separated {
        Ok(tree) => tree,
        Err(BandError::NotGraded) => return Ok(None),
        Err(BandError::TooFine { level, point }) => {
            let index = morton.order[point];
            let p = points[index as usize];
            return Err(Error::NearDomainSide {
                index: index as usize,
                x: p.x,
                y: p.y,
                side: BoundarySide::Top,
                cells: 1u128 << level,
            });
        }
    };
    if let Some(band) = band {
        morton.grid.set_top_row(band.top_row);
    }
    Ok(Some(TreeBuild {
        morton,
        framework,
        quadtree,
        balanced: Some(balanced),
        band,
    }))
}

/// The finest band along a domain's top side allowed for `points` points: at most 64 cells per
/// point or 2^20 cells, whichever is more, and within the grid.
fn band_level_limit<K: MortonKey>(points: usize) -> u8 {
    let cells = (points as u128 * 64).max(1 << 20);
    cells.ilog2().min(K::AXIS_BITS - 1) as u8
}

/// The quality mesh of `points` by warping on the current rayon pool, with its report: the
/// block warp (angles in [22.5°, 112.5°]), or with [`Separation::Corner`] on the root square
/// or a given rectangle the compact warp (angles in [26°, 120°]), or the nonobtuse split, as the
/// options say. The domain is the options' rectangle, or else the quadtree's root square: the
/// points' bounding box centred in a square of twice its larger side.
///
/// # Errors
/// Whatever [`morton_order`] refuses, [`Error::Unresolvable`] for points too close together
/// relative to the extent for either grid or for f64, [`Error::TooLarge`] past 32-bit indices;
/// with a domain, [`Error::InvalidOption`] unless it is a finite rectangle,
/// [`Error::OutsideDomain`] for a point outside it, [`Error::NearDomainSide`] for a point
/// so close to a side (or points so close together on it) that the cells along it would be too
/// many, and [`Error::ThinDomain`] for a domain too elongated for its cells.
pub fn mesh_points(points: &[DVec2], options: &MeshOptions) -> Result<(Mesh, MeshReport), Error> {
    let Some(domain) = options.domain else {
        return mesh_on(points, options);
    };
    domain.check()?;
    validate_points(points)?;
    domain.check_holds(points)?;
    // The block rule lines one side with equal cells (the top of a domain at least as wide as
    // tall): it works in the mirror image that makes that side the better one. The corner
    // rule cuts the domain into cells whose sides are all grid lines.
    if options.effective_separation() == Separation::Corner {
        return mesh_on(points, options);
    }
    let reflections = domain_reflections(points, domain);
    if reflections.is_empty() {
        return mesh_on(points, options);
    }
    let (image, image_domain) = mirrored(points, domain, &reflections);
    let options = MeshOptions {
        domain: Some(image_domain),
        ..*options
    };
    let back = reflections.iter().rev();
    match mesh_on(&image, &options) {
        Ok((mesh, report)) => Ok((back.fold(mesh, |m, &r| m.reflected(r)), report)),
        Err(e) => Err(back.fold(e, |e, &r| e.reflected(r))),
    }
}

/// [`mesh_points`] once the domain, if any, is at least as wide as it is tall.
fn mesh_on(points: &[DVec2], options: &MeshOptions) -> Result<(Mesh, MeshReport), Error> {
    let (tree, mut times) = separated_tree(points, options)?;
    let separation = (!options.nonobtuse).then(|| options.effective_separation());
    let (mut mesh, mut quality, duplicates) = match tree {
        Tree::Narrow(build) => warp_build(build, points, separation, &mut times)?,
        Tree::Wide(build) => warp_build(build, points, separation, &mut times)?,
    };
    if options.coarsen {
        let bounds = match options.nonobtuse {
            true => NONOBTUSE_COARSE_BOUNDS,
            false => COARSE_ANGLE_BOUNDS,
        };
        times.time("coarsen", || coarsen(&mut mesh, bounds));
        quality = times.time("angles", || {
            crate::refine::angle_quality(&mesh.vertices, &mesh.triangles)
        });
    }
    let report = report_of(
        &mesh,
        points.len() - duplicates,
        duplicates,
        &quality,
        times,
    );
    Ok((mesh, report))
}

type Warped = (Mesh, AngleQuality, usize);

/// The mesh of a separated tree: the nonobtuse split (`separation` `None`), or the warp of the
/// tree `separation` built.
fn warp_build<K: MortonKey>(
    build: TreeBuild<K>,
    points: &[DVec2],
    separation: Option<Separation>,
    times: &mut StageTimes,
) -> Result<Warped, Error> {
    // The framework and the unbalanced tree go here; the warp reads the separated tree's leaves,
    // links and point location only, so its internal squares go too, before the mesh's arrays
    // are made.
    let TreeBuild {
        morton, balanced, ..
    } = build;
    let mut tree = balanced.expect("a separated tree");
    tree.tree.internal = Vec::new();
    // The leaves beyond a domain's sides inside the root go: above a band's row, or beyond a
    // cells grid's lines.
    let cut = morton.grid.inner_lines().iter().any(Option::is_some);
    let tree = match cut {
        true => times.time("warp band", || {
            leaves_in_domain(tree, &morton.grid, (&morton.order, points))
        })?,
        false => tree,
    };
    let (mesh, quality) = if let Some(separation) = separation {
        let keys = (separation == Separation::Corner).then_some(&morton.keys[..]);
        warp(&tree, (&morton.order, keys), &morton.grid, points, times)?
    } else {
        split(&tree, &morton.order, &morton.grid, points, times)?
    };
    Ok((mesh, quality, morton.duplicates.count))
}

/// A point whose leaf is finer than the build's grid resolves for the tree's warp, if any.
fn deepest_point_leaf<K: MortonKey>(build: &TreeBuild<K>, separation: Separation) -> Option<usize> {
    let corners = separation == Separation::Corner;
    build
        .balanced
        .as_ref()
        .and_then(|tree| point_finer_than_grid(tree, corners))
}

/// The mesh of `input` as `options` ask, on the current rayon pool, with its report: the one
/// entry point for both modes.
///
/// # Errors
/// Bad input ([`Error::Empty`], [`Error::NonFinite`], [`Error::TooManyPoints`]), options out
/// of range ([`Error::InvalidOption`]), parts of the input not supported yet
/// ([`Error::Unsupported`]), a point outside a given rectangle ([`Error::OutsideDomain`]),
/// and what each mode refuses: see [`mesh_points`] (warp) and
/// [`crate::refine::refine_points`] (Delaunay); a refinement stopped at its vertex budget
/// returns the mesh reached in [`Error::VertexBudget`].
pub fn mesh(input: &Input, options: &Options) -> Result<(Mesh, MeshReport), Error> {
    options.check()?;
    let (mesh, mut report) = mesh_of_mode(input, options)?;
    report.angle_bounds = Some(options.angle_bounds_of(input));
    Ok((mesh, report))
}

/// [`mesh`] in the mode the options name.
fn mesh_of_mode(input: &Input, options: &Options) -> Result<(Mesh, MeshReport), Error> {
    if input.is_graph() {
        return mesh_graph(input, options);
    }
    let points = &input.points[..];
    let rectangle = match options.region_choice() {
        Region::Rectangle(d) => Some(d),
        // Each mode checks the points itself; the box needs them finite and present first.
        Region::BoundingBox => {
            validate_points(points)?;
            let (lo, hi) = bounding_box(points);
            Some(Domain { lo, hi })
        }
        Region::Auto | Region::ConvexHull | Region::Square => None,
    };
    match options.mode() {
        Mode::Warp
        | Mode::CompactWarp
        | Mode::BlockWarp
        | Mode::Nonobtuse
        | Mode::NonobtuseSplit => {
            let warp = MeshOptions {
                sort: options.sort_algorithm(),
                domain: rectangle,
                nonobtuse: matches!(options.mode(), Mode::Nonobtuse | Mode::NonobtuseSplit),
                separation: match options.mode() {
                    Mode::Warp | Mode::CompactWarp => Separation::Corner,
                    _ => Separation::Block,
                },
                coarsen: matches!(options.mode(), Mode::Warp | Mode::Nonobtuse),
            };
            mesh_points(points, &warp)
        }
        Mode::Delaunay => {
            let domain = match (rectangle, options.region_choice()) {
                (Some(d), _) => RefineDomain::Rectangle(d),
                (None, Region::Square) => RefineDomain::Square,
                (None, _) => RefineDomain::ConvexHull,
            };
            let refine = RefineOptions {
                min_angle_deg: options.min_angle_deg(),
                max_area: options.max_area_bound(),
                max_vertices: options.vertex_budget(),
                domain,
                sort: options.sort_algorithm(),
            };
            refine_points(points, &refine)
        }
    }
}

/// The mesh of a planar straight-line graph: the Delaunay mode over what its segments enclose
/// or over its convex hull.
fn mesh_graph(input: &Input, options: &Options) -> Result<(Mesh, MeshReport), Error> {
    match options.mode() {
        Mode::Warp | Mode::CompactWarp => return mesh_graph_warp(input, options),
        Mode::BlockWarp | Mode::Nonobtuse | Mode::NonobtuseSplit => input.check_supported()?,
        Mode::Delaunay => {}
    }
    let convex_hull = match options.region_choice() {
        Region::Auto => false,
        Region::ConvexHull => true,
        _ => {
            return Err(Error::InvalidOption {
                option: "region",
                message: "a planar straight-line graph is meshed over what its segments enclose \
                          or over its convex hull, not over a rectangle"
                    .into(),
            });
        }
    };
    let refine = RefineOptions {
        min_angle_deg: options.min_angle_deg(),
        max_area: options.max_area_bound(),
        max_vertices: options.vertex_budget(),
        domain: RefineDomain::ConvexHull,
        sort: options.sort_algorithm(),
    };
    let pslg = PslgOptions {
        convex_hull,
        no_boundary_steiner: !options.boundary_steiner_allowed(),
        split_crossings: options.crossings_split(),
        remove_spare_vertices: options.spare_vertices_removed(),
    };
    refine_pslg(input, &refine, pslg)
}

/// The most squares the separation of a graph may split in [`mesh`], whatever its size: about
/// 80 bytes each through the warp, so a few GiB at most.
pub const GRAPH_SQUARE_BUDGET: usize = 20_000_000;

/// Split squares [`mesh`] allows a graph per point and segment, past a million, up to
/// [`GRAPH_SQUARE_BUDGET`]: a hundred times and more what Triangle's examples, nested rings
/// and blocks with holes need (3 to 9 per point and segment), so that features too close for
/// their size are refused in about a second, not after 20 million squares.
pub const GRAPH_SQUARES_PER_FEATURE: usize = 1_000;

/// The squares the separation of a graph of `points` points and `segments` segments may
/// split in [`mesh`].
pub fn graph_square_budget(points: usize, segments: usize) -> usize {
    points
        .saturating_add(segments)
        .saturating_mul(GRAPH_SQUARES_PER_FEATURE)
        .saturating_add(1_000_000)
        .min(GRAPH_SQUARE_BUDGET)
}

/// The clearance, in sides, the warp of a graph separates its features by: one side. The
/// papers' three sides give four to five times the triangles and no better angles (on
/// Triangle's examples; `benches/README.md`).
pub const WARP_CLEARANCE: f64 = 1.0;

/// The warped mesh of a planar straight-line graph (BET §5): cleaned, its acute corners cut
/// off, its features separated in a balanced tree, the tree bent onto it and triangulated, the
/// domain cut out with its holes and regions, the caps put back.
fn mesh_graph_warp(input: &Input, options: &Options) -> Result<(Mesh, MeshReport), Error> {
    if options.region_choice() != Region::Auto {
        return Err(Error::InvalidOption {
            option: "region",
            message: "the warped mesh of a planar straight-line graph covers what its segments \
                      enclose"
                .into(),
        });
    }
    let mut times = StageTimes::default();
    let clean_options = crate::pslg::CleanOptions {
        split_crossings: options.crossings_split(),
    };
    let (clean, cleaning) = times.time("clean", || crate::pslg::clean(input, clean_options))?;
    // Coordinates whose squares overflow or underflow f64 are refused before the corners are
    // cut, which measures lengths, as the grid would refuse them.
    if !clean.points.is_empty() {
        let (lo, hi) = bounding_box(&clean.points);
        Grid::around(lo, hi, u64::AXIS_BITS)?;
    }
    let cut = times.time("cut", || crate::pslg::cut_acute_corners(&clean))?;
    let tree_options = GraphTreeOptions {
        max_squares: Some(graph_square_budget(cut.points.len(), cut.edges.len())),
        clearance: WARP_CLEARANCE,
    };
    let tree = graph_tree(&cut, tree_options, &mut times)?;
    let mut mesh = match &tree {
        GraphTree::Narrow(build) => warped_graph(build, (&clean, &cut), &mut times),
        GraphTree::Wide(build) => warped_graph(build, (&clean, &cut), &mut times),
    }?;
    if options.mode() == Mode::Warp {
        // Every triangle the collapses make keeps the bounds: the smallest angle reached falls
        // to 20° at worst, the largest rises to 120° at worst.
        times.time("coarsen", || coarsen(&mut mesh, COARSE_ANGLE_BOUNDS));
    }
    // The few triangles the bending and the moves leave below the bound are refined away
    // (after the coarsening, which takes many of them away and leaves a sixth of the
    // triangles to flip); the budget only guards against a runaway (the warp modes take none
    // from the user).
    let budget = 2 * mesh.vertices.len() + 10_000;
    let (_, unfinished) = times.time("finish", || {
        refine_graph_mesh(&mut mesh, &clean, GRAPH_ANGLE_BOUNDS.0, budget)
    })?;
    for piece in &mut mesh.segments {
        piece.segment = cleaning.segment_origin[piece.segment as usize];
    }
    let first_input = crate::refine::first_occurrences(&cleaning.point_map, clean.points.len());
    for v in &mut mesh.vertex_input {
        if *v != NONE {
            *v = first_input[*v as usize];
        }
    }
    let quality = times.time("angles", || {
        crate::refine::angle_quality(&mesh.vertices, &mesh.triangles)
    });
    let mut report = report_of(
        &mesh,
        clean.points.len(),
        cleaning.merged_points,
        &quality,
        times,
    );
    report.cleaning = Some(cleaning);
    within_budget(mesh, report, unfinished, budget)
}

/// The warp of a graph's separated tree and the domain cut out of it: the mesh of the cleaned
/// graph `clean` from the tree `build` of its cut `cut`, its poor triangles' Steiner corners
/// then moved ([`smooth_steiner_vertices`]). Stage times go to `times`: "warp", "carve",
/// "smooth".
///
/// # Errors
/// What [`triangulate_graph`] and [`carve_warped`] refuse.
pub fn warped_graph<K: MortonKey>(
    build: &GraphTreeBuild<K>,
    (clean, cut): (&Input, &CornerCut),
    times: &mut StageTimes,
) -> Result<Mesh, Error> {
    let mut mesh = carved_graph(build, (clean, cut), times)?;
    times.time("smooth", || {
        let segment_ends: Vec<[DVec2; 2]> = clean
            .segments
            .iter()
            .map(|s| s.ends.map(|p| clean.points[p as usize]))
            .collect();
        smooth_steiner_vertices(&mut mesh, &segment_ends)
    });
    Ok(mesh)
}

/// [`warped_graph`] before its Steiner vertices move: the tree bent onto the graph and
/// triangulated, the domain cut out. Stage times go to `times`: "warp", "carve".
///
/// # Errors
/// What [`triangulate_graph`] and [`carve_warped`] refuse.
pub fn carved_graph<K: MortonKey>(
    build: &GraphTreeBuild<K>,
    (clean, cut): (&Input, &CornerCut),
    times: &mut StageTimes,
) -> Result<Mesh, Error> {
    let points: Vec<DVec2> = build
        .vertices
        .iter()
        .map(|&v| cut.points[v as usize])
        .collect();
    let leaves = GraphLeaves {
        tree: &build.tree,
        grid: &build.morton.grid,
        order: &build.morton.order,
        points: &points,
        edges: &build.edges,
        pieces: &build.pieces,
    };
    let triangulated = times.time("warp", || triangulate_graph(&leaves))?;
    times.time("carve", || {
        let triangle_at = |p| triangulated.triangle_at(&build.tree, &build.morton.grid, p);
        carve_warped(clean, cut, &build.vertices, &triangulated, triangle_at)
    })
}

/// A graph's features separated in a balanced quadtree: Bern, Eppstein and Teng's T_B* (§5),
/// the tree the warp of a graph is to be built on.
#[derive(Clone, Debug)]
pub struct GraphTreeBuild<K: Copy> {
    /// The feature vertices in Morton order (`order` indexes `vertices`), and the grid.
    pub morton: MortonOrder<K>,
    /// The cut graph's points that are features: all but the vertices enclosed by caps, as
    /// indices into [`CornerCut::points`], in their order there.
    pub vertices: Vec<u32>,
    /// The cut graph's edges, as indices into `vertices`.
    pub edges: Vec<[u32; 2]>,
    /// How many squares the features crowd (before balancing).
    pub crowded: usize,
    /// The reaches' clearance, in sides.
    pub clearance: f64,
    /// The balanced tree: no leaf is crowded (see [`crate::balance::crowded_squares`]).
    pub tree: BalancedTree<K>,
    /// The edges cut at the sides of the leaves they pass through.
    pub pieces: EdgePieces,
}

/// How [`graph_tree`] separates a graph.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GraphTreeOptions {
    /// The reaches' clearance, in sides (see [`crate::balance::crowded_squares`]).
    pub clearance: f64,
    /// The most split squares the crowding may ask for; `None`: as many as the grid resolves.
    pub max_squares: Option<usize>,
}

impl Default for GraphTreeOptions {
    /// The papers' clearance ([`crate::balance::CLEARANCE`]), no budget.
    fn default() -> Self {
        GraphTreeOptions {
            clearance: crate::balance::CLEARANCE,
            max_squares: None,
        }
    }
}

/// [`GraphTreeBuild`] on the grid width the graph needs.
#[derive(Clone, Debug)]
pub enum GraphTree {
    /// 32 bits per axis.
    Narrow(GraphTreeBuild<u64>),
    /// 64 bits per axis.
    Wide(GraphTreeBuild<u128>),
}

/// The separated tree of a graph whose acute corners are cut (see
/// [`crate::pslg::cut_acute_corners`]), on the narrow grid if it resolves the features, on the
/// wide one otherwise, as `options` say, and the edges cut at its leaves' sides. Stage times go
/// to `times`: "morton", "crowded", "balance", "pieces".
///
/// # Errors
/// Whatever [`morton_order`] refuses, [`Error::Inseparable`] naming two features (by a point of
/// each, as indices into [`CornerCut::points`]) that even the wide grid cannot separate, and
/// [`Error::SquareBudget`] beyond the options' budget.
pub fn graph_tree(
    cut: &CornerCut,
    options: GraphTreeOptions,
    times: &mut StageTimes,
) -> Result<GraphTree, Error> {
    let mut enclosed = vec![false; cut.points.len()];
    for &v in &cut.enclosed {
        enclosed[v as usize] = true;
    }
    let vertices: Vec<u32> = (0..cut.points.len() as u32)
        .filter(|&v| !enclosed[v as usize])
        .collect();
    let mut index = vec![u32::MAX; cut.points.len()];
    for (i, &v) in vertices.iter().enumerate() {
        index[v as usize] = i as u32;
    }
    let points: Vec<DVec2> = vertices.iter().map(|&v| cut.points[v as usize]).collect();
    let edges: Vec<[u32; 2]> = cut
        .edges
        .iter()
        .map(|e| e.ends.map(|v| index[v as usize]))
        .collect();
    let sort = SortAlgorithm::default();
    // Morton order checks the points first: the R-trees take finite ones only.
    let morton = times.time("morton", || morton_order(&points, sort))?;
    let features = GraphFeatures::new(&points, &edges);
    let narrow = match morton {
        Morton::Narrow(m) => {
            match graph_build(m, (&vertices, &edges, &points), (&features, options), times) {
                Ok(build) => return Ok(GraphTree::Narrow(build)),
                Err(TooCrowded::Budget { limit, conflict }) => {
                    return Err(square_budget(limit, conflict, (&vertices, &cut.points)));
                }
                Err(TooCrowded::Finest { .. }) => {
                    times.time("morton wide", || morton_order_wide(&points, None, sort))?
                }
            }
        }
        Morton::Wide(m) => m,
    };
    match graph_build(
        narrow,
        (&vertices, &edges, &points),
        (&features, options),
        times,
    ) {
        Ok(build) => Ok(GraphTree::Wide(build)),
        Err(TooCrowded::Budget { limit, conflict }) => {
            Err(square_budget(limit, conflict, (&vertices, &cut.points)))
        }
        Err(TooCrowded::Finest { conflict, .. }) => {
            let ((a, pa), (b, pb)) = named_conflict(conflict, (&vertices, &cut.points));
            Err(Error::Inseparable {
                a: a as usize,
                pa,
                b: b as usize,
                pb,
            })
        }
    }
}

/// [`Error::SquareBudget`] naming the features of `conflict`.
fn square_budget(limit: usize, conflict: Conflict, names: (&[u32], &[DVec2])) -> Error {
    let ((a, pa), (b, pb)) = named_conflict(conflict, names);
    Error::SquareBudget {
        limit,
        a: a as usize,
        pa,
        b: b as usize,
        pb,
    }
}

/// A point of each of a conflict's two features, as an index into the cut graph's points
/// (`names.0` maps the tree's vertices there) with its coordinates.
fn named_conflict(
    conflict: Conflict,
    (vertices, points): (&[u32], &[DVec2]),
) -> ((u32, [f64; 2]), (u32, [f64; 2])) {
    let named = |v: u32| {
        let index = vertices[v as usize];
        (index, points[index as usize].to_array())
    };
    (named(conflict.a), named(conflict.b))
}

/// The crowded squares of `features` on `morton`'s grid, their balanced closure and the edges'
/// pieces in its leaves.
fn graph_build<K: MortonKey>(
    morton: MortonOrder<K>,
    (vertices, edges, points): (&[u32], &[[u32; 2]], &[DVec2]),
    (features, options): (&GraphFeatures, GraphTreeOptions),
    times: &mut StageTimes,
) -> Result<GraphTreeBuild<K>, TooCrowded<K>> {
    let limits = (
        finest_resolved_level::<K>(false),
        options.max_squares.unwrap_or(usize::MAX),
    );
    let clearance = options.clearance;
    let crowded = times.time("crowded", || {
        crowded_squares::<K>(&morton.grid, features, clearance, limits)
    })?;
    let tree = times.time("balance", || {
        linked_tree(&balance_closure(&crowded), &morton.keys)
    });
    let pieces = times.time("pieces", || {
        edge_pieces(&tree.tree, &morton.grid, points, edges)
    });
    Ok(GraphTreeBuild {
        morton,
        vertices: vertices.to_vec(),
        edges: edges.to_vec(),
        crowded: crowded.len(),
        clearance,
        tree,
        pieces,
    })
}
