//! How a mesh differs from an earlier one: the triangles that went, those that came, and where
//! each kept triangle is now, for moving per-triangle data across an edit.

use std::collections::HashMap;

use glam::DVec2;

use super::Mesh;

/// The difference between a mesh and an earlier one. Triangles are matched by the exact
/// coordinates of their corners, whatever their numbering: a kept triangle has the same three
/// corners, bit for bit, in the same turning order.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MeshChange {
    /// Triangles of the earlier mesh that are gone, by their index there, increasing.
    pub removed: Vec<u32>,
    /// Triangles of this mesh that are new, by their index here, increasing.
    pub added: Vec<u32>,
    /// For every other triangle, its index in the earlier mesh and here, by the earlier index.
    pub kept: Vec<[u32; 2]>,
}

/// A triangle's corners as bits, starting from the least, so that its three rotations agree.
pub(crate) type Corners = [u64; 6];

fn corners(mesh: &Mesh, t: usize) -> Corners {
    corner_bits(mesh.triangles[t].map(|v| mesh.vertices[v as usize]))
}

/// The corners `c` as [`Corners`].
pub(crate) fn corner_bits(c: [DVec2; 3]) -> Corners {
    // +0 and -0 are the same place.
    let bits = |p: DVec2| [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits()];
    let [a, b, d] = c.map(bits);
    let rotations = [[a, b, d], [b, d, a], [d, a, b]];
    let least = rotations.iter().min().expect("three rotations");
    [
        least[0][0],
        least[0][1],
        least[1][0],
        least[1][1],
        least[2][0],
        least[2][1],
    ]
}

impl Mesh {
    /// How this mesh differs from `earlier`: in O(n) expected time for n triangles.
    pub fn changes_from(&self, earlier: &Mesh) -> MeshChange {
        let mut before: HashMap<Corners, u32> = HashMap::with_capacity(earlier.triangles.len());
        for t in 0..earlier.triangles.len() {
            before.insert(corners(earlier, t), t as u32);
        }
        let mut change = MeshChange::default();
        for t in 0..self.triangles.len() {
            match before.remove(&corners(self, t)) {
                Some(old) => change.kept.push([old, t as u32]),
                None => change.added.push(t as u32),
            }
        }
        change.removed = before.into_values().collect();
        change.removed.sort_unstable();
        change.kept.sort_unstable();
        change
    }
}
