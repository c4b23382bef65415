//! The triangles around a vertex, walked through the neighbour links.

use super::{Mesh, NONE};

/// A vertex, its neighbours counter-clockwise around it, and its triangles: it and each two
/// consecutive neighbours, and the last and the first when the ring is closed (an interior
/// vertex). On the boundary the first and last neighbours are the ends of its boundary edges.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Star {
    pub(crate) centre: u32,
    pub(crate) neighbours: Vec<u32>,
    pub(crate) triangles: Vec<u32>,
    pub(crate) closed: bool,
}

impl Star {
    /// The star of `v`, one of whose triangles is `start`; `None` if the links do not go round
    /// `v` as a valid mesh's do.
    pub(crate) fn around(mesh: &Mesh, v: u32, start: u32) -> Option<Star> {
        let mut star = Star::default();
        star.refill(mesh, v, start)?;
        Some(star)
    }

    /// Makes this the star of `v` as [`Star::around`] does, keeping the buffers.
    pub(crate) fn refill(&mut self, mesh: &Mesh, v: u32, start: u32) -> Option<()> {
        let corner = |t: u32| {
            let corners = mesh.triangles.get(t as usize)?;
            let i = corners.iter().position(|&c| c == v)?;
            Some((*corners, i))
        };
        self.centre = v;
        self.closed = false;
        let triangles = &mut self.triangles;
        triangles.clear();
        // Counter-clockwise from `start`: across the edge from `v` to its triangle's last corner.
        triangles.push(start);
        loop {
            let last = *triangles.last()?;
            let (_, i) = corner(last)?;
            let next = mesh.neighbours[last as usize][(i + 1) % 3];
            if next == start {
                self.closed = true;
                break;
            }
            if next == NONE || triangles.len() > mesh.triangles.len() {
                break;
            }
            triangles.push(next);
        }
        if !self.closed {
            // Clockwise from `start`, to the boundary: pushed after, then turned to the front.
            let forward = triangles.len();
            let mut t = start;
            loop {
                let (_, i) = corner(t)?;
                t = mesh.neighbours[t as usize][(i + 2) % 3];
                if t == NONE || triangles.len() > mesh.triangles.len() {
                    break;
                }
                triangles.push(t);
            }
            let back = triangles.len() - forward;
            triangles[forward..].reverse();
            triangles.rotate_right(back);
        }
        self.neighbours.clear();
        for &t in &self.triangles {
            let (corners, i) = corner(t)?;
            self.neighbours.push(corners[(i + 1) % 3]);
        }
        if !self.closed {
            let (corners, i) = corner(*self.triangles.last()?)?;
            self.neighbours.push(corners[(i + 2) % 3]);
        }
        Some(())
    }

    /// The pairs of consecutive neighbours, one per triangle, in the triangles' order.
    pub(crate) fn edges(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        let wrap = self.closed.then(|| {
            let n = &self.neighbours;
            (n[n.len() - 1], n[0])
        });
        self.neighbours.windows(2).map(|w| (w[0], w[1])).chain(wrap)
    }
}
