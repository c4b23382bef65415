//! quadmesh: quadtrees built the PRAM way (Morton order, a framework by all-nearest-larger-values,
//! level-parallel balancing) and quality triangle meshes from them, in parallel with rayon.
//!
//! The stages are functions from flat, Morton-sorted arrays to flat arrays:
//! [`morton`] → [`framework`] → [`quadtree`] → `balance` → `warp` / `pslg` → mesh.
//! See `ARCHITECTURE.md` for the module graph.
#![deny(unsafe_code)]
#![deny(missing_docs)]

pub mod balance;
pub mod dynamic;
mod error;
pub mod framework;
pub mod generate;
pub mod io;
pub mod morton;
pub mod par;
pub mod pipeline;
pub mod pslg;
pub mod quadtree;
pub mod warp;

pub use error::Error;
pub use glam::DVec2;
pub use pipeline::{Refinement, Tree, TreeBuild, TreeOptions, build_tree};
