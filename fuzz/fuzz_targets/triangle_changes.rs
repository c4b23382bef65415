//! Tracked changes checked against whole meshes, for the dynamic targets.

use quadmesh::DVec2;
use quadmesh::dynamic::TriangleChanges;

/// A mesh's triangles by their corners' bits, each from its least corner on, sorted.
pub fn triangle_set(mesh: &quadmesh::Mesh) -> Vec<[[u64; 2]; 3]> {
    let mut all: Vec<_> = mesh
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

/// `before` less the removed triangles and with the added ones, or `None` if a removed one is
/// not there.
pub fn changed(before: &quadmesh::Mesh, changes: &TriangleChanges) -> Option<Vec<[[u64; 2]; 3]>> {
    let mut all = triangle_set(before);
    for t in &changes.removed {
        let at = all.binary_search(&bits(*t)).ok()?;
        all.remove(at);
    }
    all.extend(changes.added.iter().map(|t| bits(*t)));
    all.sort_unstable();
    Some(all)
}
