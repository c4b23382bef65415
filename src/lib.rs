//! quadmesh: quadtrees built the PRAM way (Morton order, a framework by all-nearest-larger-values,
//! level-parallel balancing) and quality triangle meshes from them, in parallel with rayon.
//!
//! The stages are functions from flat, Morton-sorted arrays to flat arrays:
//! [`morton`] → [`framework`] → [`quadtree`] → [`balance`] → [`warp`] → [`mesh`](mod@mesh).
//! See `ARCHITECTURE.md` for the module graph.
//!
//! One call meshes in either mode: by default a quality Delaunay mesh of the points' convex
//! hull with every angle at least 20°, one option away the warped quadtree mesh.
//!
//! ```
//! use quadmesh::{DVec2, Input, NONE, Options, mesh};
//!
//! let points = vec![
//!     DVec2::new(0.0, 0.0),
//!     DVec2::new(1.0, 0.0),
//!     DVec2::new(0.5, 1.0),
//!     DVec2::new(0.4, 0.3),
//! ];
//! let options = Options::default().min_angle(25.0).max_area(0.01);
//! let (m, report) = mesh(&Input::points(points.clone()), &options)?;
//! m.validate(&points, options.angle_bounds()).expect("a valid mesh");
//! m.check_delaunay().expect("a Delaunay mesh");
//! assert!(report.min_angle >= 25.0);
//! // Every edge once, with its triangles (the second is NONE on the boundary) and its marker.
//! let edges = m.edges();
//! assert!(edges.iter().all(|e| (e.triangles[1] == NONE) == (e.marker != 0)));
//! assert_eq!(m.vertex_markers().len(), m.vertices.len());
//!
//! let warped = Options::default().warp();
//! let (w, report) = mesh(&Input::points(points.clone()), &warped)?;
//! w.validate(&points, warped.angle_bounds()).expect("a valid mesh");
//! assert!(report.min_angle >= 20.0 - 1e-9 && report.max_angle <= 120.0 + 1e-9);
//! # Ok::<(), quadmesh::Error>(())
//! ```
//!
//! A given rectangle, here the points' bounding box: the points on its sides become boundary
//! vertices, with the same angle bounds.
//!
//! ```
//! use quadmesh::mesh::{AngleBounds, Domain};
//! use quadmesh::{DVec2, MeshOptions, mesh_points};
//!
//! let points = vec![DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.5), DVec2::new(0.25, 0.75)];
//! let domain = Domain { lo: DVec2::new(0.0, 0.0), hi: DVec2::new(1.0, 0.75) };
//! let options = MeshOptions { domain: Some(domain), ..MeshOptions::default() };
//! let (mesh, _) = mesh_points(&points, &options)?;
//! mesh.validate(&points, AngleBounds { min_deg: 22.5, max_deg: 112.5 }).expect("a valid mesh");
//! assert_eq!(mesh.domain, domain);
//! # Ok::<(), quadmesh::Error>(())
//! ```
//!
//! The trees alone:
//!
//! ```
//! use quadmesh::{DVec2, Refinement, Tree, TreeOptions, build_tree};
//!
//! let points = vec![DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.5), DVec2::new(0.25, 0.75)];
//! let options = TreeOptions::default().refinement(Refinement::Balanced);
//! let (tree, _times) = build_tree(&points, &options)?;
//! let Tree::Narrow(build) = &tree else { unreachable!("three points fit the narrow grid") };
//! let balanced = build.balanced.as_ref().expect("asked for");
//! balanced.check(&build.morton.keys).expect("a valid balanced tree");
//! assert_eq!(balanced.point_leaf.len(), 3);
//! # Ok::<(), quadmesh::Error>(())
//! ```
#![deny(unsafe_code)]
#![deny(missing_docs)]

pub mod balance;
pub mod domain;
pub mod dynamic;
mod error;
pub mod framework;
pub mod generate;
pub mod io;
pub mod mesh;
pub mod morton;
mod options;
pub(crate) mod par;
pub mod pipeline;
mod predicates;
pub mod pslg;
pub mod quadtree;
pub mod refine;
mod spatial;
pub mod warp;

/// The README's Rust examples, compiled and run as doctests.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

pub use error::{Error, Incomplete, Unmet};
pub use glam::DVec2;
pub use mesh::{
    AngleBounds, BoundaryEdge, BoundarySide, Domain, Edge, InvalidMesh, Mesh, MeshCheck,
    MeshReport, NONE, SubSegment, validate_pslg,
};
pub use morton::SortAlgorithm;
pub use options::{DEFAULT_MIN_ANGLE_DEG, Input, Mode, Options, Region, RegionSeed, Segment};
pub use pipeline::{
    MeshOptions, Refinement, Tree, TreeBuild, TreeOptions, build_tree, mesh, mesh_points,
};
pub use refine::{
    GUARANTEED_MIN_ANGLE_DEG, PslgOptions, RefineDomain, RefineOptions, refine_points, refine_pslg,
};
