//! What [`crate::mesh`] takes: the input geometry and the options, built by value.

use glam::DVec2;

use crate::error::Error;
use crate::mesh::{AngleBounds, Domain};
use crate::morton::SortAlgorithm;
use crate::refine::{GUARANTEED_MIN_ANGLE_DEG, MAX_MIN_ANGLE_DEG};
use crate::warp::{
    ANGLE_BOUNDS, COARSE_ANGLE_BOUNDS, COMPACT_ANGLE_BOUNDS, GRAPH_ANGLE_BOUNDS, NONOBTUSE_MAX_DEG,
};

/// The geometry to mesh: a point set, or a planar straight-line graph (points, segments, holes
/// and regions, as in Triangle's `.poly` files).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Input {
    /// The points; each distinct one becomes a vertex with its exact coordinates.
    pub points: Vec<DVec2>,
    /// Segments between points (indices into `points`) with a marker each.
    pub segments: Vec<Segment>,
    /// Seeds of holes: the region around each, up to segments, is left empty.
    pub holes: Vec<DVec2>,
    /// Regions: a seed, an attribute for its triangles and an optional area bound.
    pub regions: Vec<RegionSeed>,
}

/// A segment between two input points and its boundary marker.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Segment {
    /// Indices of its ends in [`Input::points`].
    pub ends: [u32; 2],
    /// Its marker, carried to the mesh edges on it.
    pub marker: i32,
}

/// A region of a planar straight-line graph, named by a point inside it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegionSeed {
    /// A point inside the region.
    pub seed: DVec2,
    /// The attribute its triangles get.
    pub attribute: f64,
    /// The largest area of its triangles, if bounded.
    pub max_area: Option<f64>,
}

impl Input {
    /// A bare point set.
    pub fn points(points: impl Into<Vec<DVec2>>) -> Self {
        Input {
            points: points.into(),
            ..Input::default()
        }
    }

    /// Whether the input is a planar straight-line graph: it has segments, holes or regions.
    pub fn is_graph(&self) -> bool {
        !(self.segments.is_empty() && self.holes.is_empty() && self.regions.is_empty())
    }

    /// Refuses what the warp mode cannot mesh yet: segments, holes and regions.
    ///
    /// # Errors
    /// [`Error::Unsupported`] naming the first such part.
    pub fn check_supported(&self) -> Result<(), Error> {
        let unsupported = [
            (!self.segments.is_empty(), "segments"),
            (!self.holes.is_empty(), "holes"),
            (!self.regions.is_empty(), "regions"),
        ];
        match unsupported.into_iter().find(|(used, _)| *used) {
            Some((_, what)) => Err(Error::Unsupported { what }),
            None => Ok(()),
        }
    }
}

/// The meshing mode.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mode {
    /// Off-center Delaunay refinement: a Delaunay mesh with every angle at least the bound
    /// (default [`DEFAULT_MIN_ANGLE_DEG`]) and every area at most the area bound, if given.
    #[default]
    Delaunay,
    /// The warped quadtree mesh, coarsened: the compact warp ([`Mode::CompactWarp`]) with
    /// every vertex that is no input point collapsed where the triangles it leaves keep every
    /// angle in [20°, 120°] ([`crate::warp::coarsen`]), about 6–7 triangles per point, on any
    /// rectangle as the compact warp.
    /// A planar straight-line graph is meshed over what its segments enclose from a quadtree
    /// bent onto it (see [`crate::warp::triangulate_graph`]), its poor triangles' Steiner
    /// corners then moved (see [`crate::warp::smooth_steiner_vertices`]) and the mesh
    /// coarsened as a point set's (a vertex inside a segment goes only along it, and where
    /// segments end or meet vertices stay), then the triangles left below 20° refined by
    /// off-centers: every angle in [`crate::warp::GRAPH_ANGLE_BOUNDS`], [20°, 140°], outside
    /// input corners narrower than 20° ([`Options::angle_bounds_of`]).
    Warp,
    /// The compact warp, not coarsened: every angle in [26°, 120°], about 36 triangles per
    /// point (points separated by the blocks around their leaves' nearest corners), on any
    /// rectangle: a given one ([`Region::Rectangle`], [`Region::BoundingBox`]) is cut into
    /// cells within [`crate::morton::CELL_ANISOTROPY`] of square. The mesh the dynamic mesh
    /// keeps by default. For a planar straight-line graph, the warp without coarsening, refined
    /// as in [`Mode::Warp`].
    CompactWarp,
    /// The block warp: every angle in [22.5°, 112.5°], about 104 triangles per point (each
    /// point's leaf centred in a 5×5 block of empty leaves); the tree the dynamic mesh keeps.
    BlockWarp,
    /// The nonobtuse split ([`Mode::NonobtuseSplit`]) coarsened: every vertex that is no input
    /// point collapsed where the triangles it leaves have no angle over 90° nor under 20°
    /// ([`crate::warp::NONOBTUSE_COARSE_BOUNDS`]), about half the split's triangles. Every
    /// angle at most 90°; the split's thin triangles at points near its grid lines stay, so
    /// none is bounded below.
    Nonobtuse,
    /// The block warp's quadtree split into right triangles at the points: every angle at
    /// most 90°, none bounded below, about 114 triangles per point; the mesh the dynamic mesh
    /// keeps for [`Mode::Nonobtuse`].
    NonobtuseSplit,
}

impl Mode {
    /// Whether the mode meshes the well-separated quadtree (warp or nonobtuse), which takes
    /// rectangles and no area bound or vertex budget.
    pub fn is_quadtree(self) -> bool {
        matches!(
            self,
            Mode::Warp
                | Mode::CompactWarp
                | Mode::BlockWarp
                | Mode::Nonobtuse
                | Mode::NonobtuseSplit
        )
    }
}

/// The region a mesh covers.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Region {
    /// The points' convex hull in the Delaunay mode (Triangle's choice for a bare point set),
    /// or, for a planar straight-line graph, what its segments enclose (Triangle's `-p`);
    /// [`Region::Square`] in the warp mode, which meshes rectangles only.
    #[default]
    Auto,
    /// The points' convex hull (Delaunay mode only), minus the holes of a planar
    /// straight-line graph (Triangle's `-c`).
    ConvexHull,
    /// The points' bounding box.
    BoundingBox,
    /// The points' bounding box centred in a square twice its larger side.
    Square,
    /// A given rectangle, which must hold every point (on its sides too).
    Rectangle(Domain),
}

/// The smallest angle the Delaunay mode asks for by default, degrees: below arcsin(1/(2√2)) ≈
/// 20.7°, up to which off-center refinement is proven to terminate, and Triangle's `-q` default.
pub const DEFAULT_MIN_ANGLE_DEG: f64 = 20.0;

/// How to mesh: built by value from [`Options::default`].
///
/// ```
/// use quadmesh::{Mode, Options};
/// let options = Options::default().min_angle(30.0).max_area(0.1);
/// assert_eq!(options.mode(), Mode::Delaunay);
/// assert_eq!(options.min_angle_deg(), 30.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    mode: Mode,
    min_angle_deg: f64,
    max_area: Option<f64>,
    max_vertices: Option<usize>,
    region: Region,
    sort: SortAlgorithm,
    boundary_steiner: bool,
    split_crossings: bool,
    spare_vertices_removed: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            mode: Mode::Delaunay,
            min_angle_deg: DEFAULT_MIN_ANGLE_DEG,
            max_area: None,
            max_vertices: None,
            region: Region::Auto,
            sort: SortAlgorithm::default(),
            boundary_steiner: true,
            split_crossings: false,
            spare_vertices_removed: false,
        }
    }
}

impl Options {
    /// The mode.
    pub fn mode(self) -> Mode {
        self.mode
    }

    /// These options with mode `mode`.
    pub fn with_mode(self, mode: Mode) -> Self {
        Options { mode, ..self }
    }

    /// The warp mode.
    pub fn warp(self) -> Self {
        self.with_mode(Mode::Warp)
    }

    /// The compact warp mode (the warp not coarsened).
    pub fn compact_warp(self) -> Self {
        self.with_mode(Mode::CompactWarp)
    }

    /// The block warp mode.
    pub fn block_warp(self) -> Self {
        self.with_mode(Mode::BlockWarp)
    }

    /// The nonobtuse mode.
    pub fn nonobtuse(self) -> Self {
        self.with_mode(Mode::Nonobtuse)
    }

    /// The nonobtuse split mode (the nonobtuse mesh not coarsened).
    pub fn nonobtuse_split(self) -> Self {
        self.with_mode(Mode::NonobtuseSplit)
    }

    /// Every angle at least `degrees` (Delaunay mode), in [0, 45]; 0 asks for no angle bound.
    pub fn min_angle(self, degrees: f64) -> Self {
        Options {
            min_angle_deg: degrees,
            ..self
        }
    }

    /// Every triangle's area at most `area` (Delaunay mode).
    pub fn max_area(self, area: f64) -> Self {
        Options {
            max_area: Some(area),
            ..self
        }
    }

    /// Refinement stops past `count` vertices, returning the mesh reached in
    /// [`Error::VertexBudget`]; by default 100 per point plus 10 000.
    pub fn max_vertices(self, count: usize) -> Self {
        Options {
            max_vertices: Some(count),
            ..self
        }
    }

    /// The region to mesh.
    pub fn region(self, region: Region) -> Self {
        Options { region, ..self }
    }

    /// The sort that orders the quadtree's points (warp mode).
    pub fn sort(self, sort: SortAlgorithm) -> Self {
        Options { sort, ..self }
    }

    /// Never split a boundary edge of a planar straight-line graph (Triangle's `-Y`): its
    /// boundary segments stay whole, and angles beside them may stay below the bound.
    pub fn no_boundary_steiner(self) -> Self {
        Options {
            boundary_steiner: false,
            ..self
        }
    }

    /// Split crossing segments at their intersection (a new point) instead of refusing them.
    pub fn split_crossings(self) -> Self {
        Options {
            split_crossings: true,
            ..self
        }
    }

    /// After refining a planar straight-line graph (Delaunay mode), take out the Steiner
    /// vertices on no segment wherever the mesh left, with free vertices beside them moved,
    /// still meets every bound: a smaller mesh, still constrained Delaunay, for more time.
    pub fn remove_spare_vertices(self) -> Self {
        Options {
            spare_vertices_removed: true,
            ..self
        }
    }

    /// Whether spare Steiner vertices are taken out after refinement.
    pub fn spare_vertices_removed(&self) -> bool {
        self.spare_vertices_removed
    }

    /// Whether boundary edges may be split.
    pub fn boundary_steiner_allowed(&self) -> bool {
        self.boundary_steiner
    }

    /// Whether crossing segments are split.
    pub fn crossings_split(&self) -> bool {
        self.split_crossings
    }

    /// The angle bound asked for, degrees.
    pub fn min_angle_deg(&self) -> f64 {
        self.min_angle_deg
    }

    /// The area bound asked for.
    pub fn max_area_bound(&self) -> Option<f64> {
        self.max_area
    }

    /// The vertex budget asked for.
    pub fn vertex_budget(&self) -> Option<usize> {
        self.max_vertices
    }

    /// The region asked for.
    pub fn region_choice(&self) -> Region {
        self.region
    }

    /// The sort asked for.
    pub fn sort_algorithm(&self) -> SortAlgorithm {
        self.sort
    }

    /// [`Self::angle_bounds`] for meshes of `input`: in the warp modes, a graph's
    /// [`GRAPH_ANGLE_BOUNDS`] (outside input corners narrower than the smallest).
    pub fn angle_bounds_of(&self, input: &Input) -> AngleBounds {
        if matches!(self.mode, Mode::Warp | Mode::CompactWarp) && input.is_graph() {
            AngleBounds {
                min_deg: GRAPH_ANGLE_BOUNDS.0,
                max_deg: GRAPH_ANGLE_BOUNDS.1,
            }
        } else {
            self.angle_bounds()
        }
    }

    /// The angles every mesh of these options has, outside input angles smaller than the bound
    /// (the corners of a convex hull): at least the bound and at most 180° minus twice it in the
    /// Delaunay mode, [20°, 120°] in the warp mode, [26°, 120°] in the compact warp mode,
    /// [22.5°, 112.5°] in the block warp mode, at
    /// most 90° in the nonobtuse modes.
    pub fn angle_bounds(&self) -> AngleBounds {
        match self.mode {
            Mode::Warp => AngleBounds {
                min_deg: COARSE_ANGLE_BOUNDS.0,
                max_deg: COARSE_ANGLE_BOUNDS.1,
            },
            Mode::CompactWarp => AngleBounds {
                min_deg: COMPACT_ANGLE_BOUNDS.0,
                max_deg: COMPACT_ANGLE_BOUNDS.1,
            },
            Mode::BlockWarp => AngleBounds {
                min_deg: ANGLE_BOUNDS.0,
                max_deg: ANGLE_BOUNDS.1,
            },
            Mode::Nonobtuse | Mode::NonobtuseSplit => AngleBounds {
                min_deg: 0.0,
                max_deg: NONOBTUSE_MAX_DEG,
            },
            Mode::Delaunay => AngleBounds {
                min_deg: self.min_angle_deg,
                max_deg: 180.0 - 2.0 * self.min_angle_deg,
            },
        }
    }

    /// Whether termination is proven for these options: always in the quadtree modes, and up
    /// to [`GUARANTEED_MIN_ANGLE_DEG`] in the Delaunay mode.
    pub fn termination_proven(&self) -> bool {
        self.mode.is_quadtree() || self.min_angle_deg <= GUARANTEED_MIN_ANGLE_DEG
    }

    /// Refuses values out of range, and Delaunay-mode options in the warp mode.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] naming the option.
    pub fn check(&self) -> Result<(), Error> {
        let invalid = |option, message: String| Err(Error::InvalidOption { option, message });
        let a = self.min_angle_deg;
        if !(0.0..=MAX_MIN_ANGLE_DEG).contains(&a) {
            return invalid(
                "min_angle",
                format!("{a} is not an angle in [0, {MAX_MIN_ANGLE_DEG}] degrees"),
            );
        }
        if let Some(area) = self.max_area
            && !(area > 0.0 && area.is_finite())
        {
            return invalid("max_area", format!("{area} is not a positive finite area"));
        }
        if let Region::Rectangle(d) = self.region {
            d.check()?;
        }
        if self.mode.is_quadtree() {
            if self.max_area.is_some() || self.max_vertices.is_some() {
                return invalid(
                    "mode",
                    "the warp and nonobtuse modes take no area bound or vertex budget".into(),
                );
            }
            if self.region == Region::ConvexHull {
                return invalid(
                    "region",
                    "the warp and nonobtuse modes mesh rectangles, not convex hulls".into(),
                );
            }
        }
        Ok(())
    }
}
