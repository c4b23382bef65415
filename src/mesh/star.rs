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

    /// Whether neighbour `b` follows neighbour `a`: the star has the triangle of the centre,
    /// `a` and `b`.
    pub(crate) fn has_edge(&self, a: u32, b: u32) -> bool {
        let n = &self.neighbours;
        let Some(i) = n.iter().position(|&w| w == a) else {
            return false;
        };
        match n.get(i + 1) {
            Some(&next) => next == b,
            None => self.closed && n[0] == b,
        }
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

#[cfg(test)]
mod tests {
    use glam::DVec2;

    use super::*;
    use crate::mesh::fixtures::mesh_of;

    /// A square cut into four triangles at its centre (4), and the centre's star.
    fn centre_star() -> (Mesh, Star) {
        let vertices = vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
            DVec2::new(0.5, 0.5),
        ];
        let triangles = vec![[4, 0, 1], [4, 1, 2], [4, 2, 3], [4, 3, 0]];
        let mesh = mesh_of(vertices, &[], triangles);
        let star = Star::around(&mesh, 4, 2).expect("a star");
        (mesh, star)
    }

    #[test]
    fn a_closed_star_has_its_edges_counter_clockwise_and_the_wrapping_one() {
        let (_, star) = centre_star();
        assert!(star.closed);
        for (a, b) in [(0, 1), (1, 2), (2, 3), (3, 0)] {
            assert!(star.has_edge(a, b), "{a} {b}");
            assert!(!star.has_edge(b, a), "{b} {a}");
        }
        assert!(!star.has_edge(0, 2));
        assert!(!star.has_edge(4, 0));
    }

    #[test]
    fn an_open_star_has_no_edge_from_its_last_neighbour_to_its_first() {
        let (mesh, _) = centre_star();
        // Corner 1 of the square: triangles 0 and 1, neighbours 0, 4, 2 counter-clockwise.
        let star = Star::around(&mesh, 1, 0).expect("a star");
        assert!(!star.closed);
        assert_eq!(star.neighbours, vec![2, 4, 0]);
        assert!(star.has_edge(2, 4) && star.has_edge(4, 0));
        assert!(!star.has_edge(0, 2));
    }
}
