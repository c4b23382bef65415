//! The passes of the coarsening before its rounds: collapses inside chunks of the vertices,
//! one chunk a task.
//!
//! A chunk is a run of a fixed number of vertices in an order of them that keeps it a patch of
//! the plane: their own numbering where that is one (the warp numbers them in Morton order), a
//! Morton order of their places where not (the nonobtuse split numbers the points' vertices
//! after the grid's, far from their neighbours). A chunk owns the triangles whose corners
//! are all its own; only its own collapses change those, and a triangle at one of its vertices
//! is either its own or one no collapse of a pass changes. A vertex whose triangles the chunk
//! owns, collapsing onto a neighbour with the triangles beyond owned too, so changes nothing
//! another chunk reads. Each chunk copies what it owns and collapses greedily in the copy —
//! the vertices to plan in order, then each vertex whose star a collapse changed — and its
//! result is written back. The vertices at a chunk's edge, and those whose collapse reaches past
//! it, are left to the next pass. The chunks are fixed, so the result does not depend on the
//! thread count.

use std::collections::VecDeque;
use std::ops::Range;

use glam::DVec2;
use rayon::prelude::*;

use super::{Limits, Plan, Rails, Scratch, corners_of};
use crate::mesh::{Mesh, NONE};
use crate::morton::SortPairs;
use crate::morton::interleave::box_key;

/// Marks, in a chunk's copy, a link to a triangle the chunk does not own.
const FOREIGN: u32 = NONE - 1;

/// What the chunks did: how many vertices they collapsed, and the vertices still to plan
/// (sorted): those at a chunk's edge that were to be planned or whose star changed, and those
/// whose collapse reached past their chunk.
pub(super) struct ChunkPass {
    pub(super) collapses: usize,
    pub(super) left: Vec<u32>,
}

/// Collapses inside the chunks of `chunking` (see the module's description), planning first the
/// vertices `pending` marks; `corner` follows, a collapsed vertex's [`NONE`].
pub(super) fn collapse_in_chunks(
    mesh: &mut Mesh,
    chunking: &Chunking,
    (fixed, rails): (&[bool], &Rails),
    corner: &mut [u32],
    limits: Limits,
    pending: &[bool],
) -> ChunkPass {
    let owner: Vec<u32> = (mesh.triangles.par_iter())
        .map(|&t| chunking.owner_of(t))
        .collect();
    let edge = chunk_edge(mesh, &owner);
    let (members, local) = members_of(&owner, chunking.count(mesh.vertices.len()));
    let chunks: Vec<Chunk> = members
        .par_iter()
        .enumerate()
        .map_init(Scratch::default, |scratch, (c, members)| {
            let mut chunk = Chunk::copy(mesh, chunking, c as u32, members, &owner, &local);
            chunk.collapse(chunking, (fixed, rails), &edge, pending, limits, scratch);
            chunk
        })
        .collect();
    write_back(mesh, chunking, corner, &chunks, &owner, &local);
    let mut left: Vec<u32> = (chunks.iter())
        .flat_map(|c| c.unsettled.iter().map(|&l| chunking.vertex(c.first + l)))
        .filter(|&v| corner[v as usize] != NONE)
        .collect();
    left.par_sort_unstable();
    left.dedup();
    ChunkPass {
        collapses: chunks.iter().map(|c| c.collapses).sum(),
        left,
    }
}

/// Which vertices go together: runs of `size` in an order of them, that of their indices or
/// `order` (with `rank`, its inverse).
pub(super) struct Chunking {
    size: u32,
    order: Option<(Vec<u32>, Vec<u32>)>,
}

impl Chunking {
    /// Runs of `size` vertices in the order of their indices.
    pub(super) fn by_index(size: usize) -> Chunking {
        Chunking {
            size: size as u32,
            order: None,
        }
    }

    /// Whether at least `share` of the triangles fall inside a chunk.
    pub(super) fn holds(&self, triangles: &[[u32; 3]], share: f64) -> bool {
        let inside = (triangles.par_iter())
            .filter(|&&t| self.owner_of(t) != NONE)
            .count();
        inside as f64 >= share * triangles.len() as f64
    }

    /// Runs of `size` vertices in the order of their Morton keys on a square around them whose
    /// low corner lies `shift` of its side below and left of theirs: with a shift of a third,
    /// these runs' edges cross those of the runs with none, which follow the quadrants' edges
    /// wherever their two sides are far apart in Morton order.
    pub(super) fn morton(size: usize, vertices: &[DVec2], shift: f64) -> Chunking {
        let (lo, hi) = crate::morton::bounding_box(vertices);
        let side = (hi - lo).max_element();
        let (lo, side) = (
            lo - DVec2::splat(side * shift),
            DVec2::splat(side * (1.0 + shift)),
        );
        // A box key has 32 bits: with the vertex below it, one radix sort orders by key, then
        // by index.
        let mut keyed: Vec<u64> = (vertices.par_iter().enumerate())
            .map(|(v, &p)| box_key(p, lo, side) << 32 | v as u64)
            .collect();
        u64::sort_keys(&mut keyed);
        let order: Vec<u32> = keyed.into_par_iter().map(|k| k as u32).collect();
        let mut rank = vec![0; vertices.len()];
        for (r, &v) in order.iter().enumerate() {
            rank[v as usize] = r as u32;
        }
        Chunking {
            size: size as u32,
            order: Some((order, rank)),
        }
    }

    /// How many chunks `vertices` vertices make.
    fn count(&self, vertices: usize) -> usize {
        vertices.div_ceil(self.size as usize)
    }

    fn rank(&self, v: u32) -> u32 {
        match &self.order {
            None => v,
            Some((_, rank)) => rank[v as usize],
        }
    }

    fn vertex(&self, rank: u32) -> u32 {
        match &self.order {
            None => rank,
            Some((order, _)) => order[rank as usize],
        }
    }

    fn of(&self, v: u32) -> u32 {
        self.rank(v) / self.size
    }

    /// The ranks of chunk `c`'s vertices.
    fn ranks(&self, c: u32, vertices: usize) -> Range<u32> {
        let start = |c: u32| (c as usize * self.size as usize).min(vertices) as u32;
        start(c)..start(c + 1)
    }

    /// The chunk owning a triangle with these corners: theirs when they share one, else
    /// [`NONE`].
    fn owner_of(&self, corners: [u32; 3]) -> u32 {
        if corners[0] == NONE {
            return NONE;
        }
        let chunk = self.of(corners[0]);
        match corners[1..].iter().all(|&v| self.of(v) == chunk) {
            true => chunk,
            false => NONE,
        }
    }
}

/// Per vertex, whether it is a corner of a triangle no chunk owns.
fn chunk_edge(mesh: &Mesh, owner: &[u32]) -> Vec<bool> {
    let mut edge = vec![false; mesh.vertices.len()];
    let shared: Vec<[u32; 3]> = (mesh.triangles.par_iter().zip(owner))
        .filter(|&(t, &o)| o == NONE && t[0] != NONE)
        .map(|(&t, _)| t)
        .collect();
    for v in shared.into_iter().flatten() {
        edge[v as usize] = true;
    }
    edge
}

/// Per chunk, the triangles it owns in order, and per triangle its place in its chunk's list.
fn members_of(owner: &[u32], chunks: usize) -> (Vec<Vec<u32>>, Vec<u32>) {
    let mut members = vec![Vec::new(); chunks];
    let mut local = vec![NONE; owner.len()];
    for (t, &o) in owner.iter().enumerate() {
        if o != NONE {
            let list = &mut members[o as usize];
            local[t] = list.len() as u32;
            list.push(t as u32);
        }
    }
    (members, local)
}

/// A chunk's copy of its vertices (numbered by rank from its first) and of the triangles it
/// owns (links to the triangles of its list, [`NONE`] on the boundary, [`FOREIGN`] elsewhere),
/// and what its collapses did.
struct Chunk<'a> {
    first: u32,
    members: &'a [u32],
    mesh: Mesh,
    corner: Vec<u32>,
    collapsed: Vec<bool>,
    unsettled: Vec<u32>,
    collapses: usize,
}

impl<'a> Chunk<'a> {
    /// Chunk `c`'s copy: its vertices and the triangles `members`.
    fn copy(
        mesh: &Mesh,
        chunking: &Chunking,
        c: u32,
        members: &'a [u32],
        owner: &[u32],
        local: &[u32],
    ) -> Self {
        let ranks = chunking.ranks(c, mesh.vertices.len());
        let first = ranks.start;
        let link = |n: u32| match n {
            NONE => NONE,
            _ if owner[n as usize] == c => local[n as usize],
            _ => FOREIGN,
        };
        let copy = Mesh {
            vertices: (ranks.clone())
                .map(|r| mesh.vertices[chunking.vertex(r) as usize])
                .collect(),
            triangles: (members.iter())
                .map(|&t| mesh.triangles[t as usize].map(|v| chunking.rank(v) - first))
                .collect(),
            neighbours: (members.iter())
                .map(|&t| mesh.neighbours[t as usize].map(link))
                .collect(),
            ..Mesh::default()
        };
        let corner = corners_of(&copy);
        Chunk {
            first,
            members,
            mesh: copy,
            collapsed: vec![false; corner.len()],
            corner,
            unsettled: Vec::new(),
            collapses: 0,
        }
    }

    /// Collapses greedily: the `pending` vertices in order, then each whose star a collapse
    /// changed. Those at the chunk's `edge` it would have planned, and those whose collapse
    /// reaches past the chunk, it leaves unsettled.
    fn collapse(
        &mut self,
        chunking: &Chunking,
        (fixed, rails): (&[bool], &Rails),
        edge: &[bool],
        pending: &[bool],
        limits: Limits,
        scratch: &mut Scratch,
    ) {
        let first = self.first;
        let global = |l: u32| chunking.vertex(first + l);
        let along = |a: u32, b: u32| rails.admits(global(a), global(b));
        let mut queue = Queue {
            vertex: |l: u32| global(l) as usize,
            fixed,
            edge,
            queued: vec![false; self.corner.len()],
            order: VecDeque::new(),
            unsettled: Vec::new(),
        };
        for l in 0..self.corner.len() as u32 {
            if pending[(queue.vertex)(l)] {
                queue.want(l, &self.corner);
            }
        }
        while let Some(v) = queue.next() {
            let start = self.corner[v as usize];
            let Some(plan) = Plan::of(&self.mesh, v, start, (limits, &along), scratch) else {
                continue;
            };
            if plan.claims.contains(&FOREIGN) {
                queue.unsettled.push(v);
                continue;
            }
            plan.collapse(&mut self.mesh, &mut self.corner);
            self.collapsed[v as usize] = true;
            self.collapses += 1;
            for &t in &plan.claims {
                for w in self.mesh.triangles[t as usize] {
                    if w != NONE {
                        queue.want(w, &self.corner);
                    }
                }
            }
        }
        self.unsettled = queue.unsettled;
    }
}

/// The vertices a chunk is to plan, in order, and those it leaves to the rounds.
struct Queue<'a, V: Fn(u32) -> usize> {
    vertex: V,
    fixed: &'a [bool],
    edge: &'a [bool],
    queued: Vec<bool>,
    order: VecDeque<u32>,
    unsettled: Vec<u32>,
}

impl<V: Fn(u32) -> usize> Queue<'_, V> {
    /// Queues the chunk's vertex `l` if it may go and is not queued; at the chunk's edge, it
    /// leaves `l` unsettled.
    fn want(&mut self, l: u32, corner: &[u32]) {
        if self.queued[l as usize] || corner[l as usize] == NONE {
            return;
        }
        let v = (self.vertex)(l);
        if self.fixed[v] {
            return;
        }
        if self.edge[v] {
            self.unsettled.push(l);
            return;
        }
        self.queued[l as usize] = true;
        self.order.push_back(l);
    }

    fn next(&mut self) -> Option<u32> {
        let l = self.order.pop_front()?;
        self.queued[l as usize] = false;
        Some(l)
    }
}

/// Writes the chunks' triangles, links and corners back into the mesh's.
fn write_back(
    mesh: &mut Mesh,
    chunking: &Chunking,
    corner: &mut [u32],
    chunks: &[Chunk],
    owner: &[u32],
    local: &[u32],
) {
    (mesh.triangles.par_iter_mut().zip(&mut mesh.neighbours))
        .enumerate()
        .filter(|&(t, _)| owner[t] != NONE)
        .for_each(|(t, (corners, links))| {
            let chunk = &chunks[owner[t] as usize];
            let l = local[t] as usize;
            *corners = chunk.mesh.triangles[l].map(|v| match v {
                NONE => NONE,
                _ => chunking.vertex(v + chunk.first),
            });
            for (link, &copied) in links.iter_mut().zip(&chunk.mesh.neighbours[l]) {
                match copied {
                    FOREIGN => {}
                    NONE => *link = NONE,
                    _ => *link = chunk.members[copied as usize],
                }
            }
        });
    corner.par_iter_mut().enumerate().for_each(|(v, corner)| {
        let rank = chunking.rank(v as u32);
        let chunk = &chunks[(rank / chunking.size) as usize];
        let l = (rank - chunk.first) as usize;
        match (chunk.collapsed[l], chunk.corner[l]) {
            (true, _) => *corner = NONE,
            (false, NONE) => {}
            (false, t) => *corner = chunk.members[t as usize],
        }
    });
}
