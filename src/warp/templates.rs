//! The triangulations of one leaf (BEG's templates, `beg-quadtree-meshing.md` §2.4–2.5), as
//! tables over the leaf's boundary ring, so that neighbours across leaves are table lookups.
//!
//! A leaf's boundary ring lists, counter-clockwise from the lower-left corner, its corners and
//! the midpoints of its split sides: labels 0 LL, 1 S-mid, 2 LR, 3 E-mid, 4 UR, 5 N-mid, 6 UL,
//! 7 W-mid; label 8 is the centre.

use std::sync::OnceLock;

/// Label of the centre vertex.
pub const CENTRE: u8 = 8;

/// The sides of a leaf in ring order (counter-clockwise from the bottom).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RingSide {
    /// y = y0, walked left to right.
    South = 0,
    /// x = x1, walked bottom to top.
    East = 1,
    /// y = y1, walked right to left.
    North = 2,
    /// x = x0, walked top to bottom.
    West = 3,
}

impl RingSide {
    /// All four, in ring order.
    pub const ALL: [RingSide; 4] = [
        RingSide::South,
        RingSide::East,
        RingSide::North,
        RingSide::West,
    ];

    /// The side facing this one.
    pub fn opposite(self) -> RingSide {
        RingSide::ALL[(self as usize + 2) % 4]
    }
}

/// Which part of a side a boundary segment is: the whole side, or the half with the smaller
/// (`Low`) or larger (`High`) coordinate along it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// The whole side.
    Full = 0,
    /// The half nearer the side's lower (or left) end.
    Low = 1,
    /// The other half.
    High = 2,
}

/// A template: which triangulation a leaf uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// No midpoints; the diagonal LL–UR.
    DiagonalUp,
    /// No midpoints; the diagonal LR–UL.
    DiagonalDown,
    /// One midpoint, on this side: joined to the two far corners.
    OneMidpoint(RingSide),
    /// Two or more midpoints (bit `s` for ring side `s`): a star from the centre.
    Star(u8),
    /// A leaf of the compact warp whose corner `2 * turn` moved: candidate `choice` of
    /// [`WARPED_CANDIDATES`] for the midpoints `far` on the two sides away from that corner
    /// (bit 0 the side after the next, bit 1 the one after that), turned by `turn` quarters.
    Warped { turn: u8, far: u8, choice: u8 },
}

/// The compact warp's candidate triangulations of a leaf whose lower-left corner moved, for
/// each set of midpoints on its east (bit 0) and north (bit 1) sides, by ring label (8 is a
/// centre placed by [`warped_centre`]), in the order ties go. The exhaustive sweep of
/// `beg-quadtree-meshing.md` §2.5 (the test `the_sweep_bounds_every_warped_leaf`) proves that
/// choosing among them as [`super::choose_warped`] does keeps every angle in
/// [26.5°, 118.1°].
pub const WARPED_CANDIDATES: [&[&[[u8; 3]]]; 4] = [
    &[
        &[[0, 2, 6], [2, 4, 6]],
        &[[0, 2, 4], [0, 4, 6]],
        &[[8, 0, 2], [8, 2, 4], [8, 4, 6], [8, 6, 0]],
    ],
    &[
        &[[0, 2, 3], [0, 3, 6], [3, 4, 6]],
        &[[0, 2, 3], [0, 3, 4], [0, 4, 6]],
        &[[8, 0, 2], [8, 2, 3], [8, 3, 4], [8, 4, 6], [8, 6, 0]],
        &[[0, 2, 3], [8, 0, 3], [8, 3, 4], [8, 4, 6], [8, 6, 0]],
    ],
    &[
        &[[0, 2, 5], [2, 4, 5], [0, 5, 6]],
        &[[0, 2, 4], [0, 4, 5], [0, 5, 6]],
        &[[8, 0, 2], [8, 2, 4], [8, 4, 5], [8, 5, 6], [8, 6, 0]],
        &[[0, 5, 6], [8, 0, 2], [8, 2, 4], [8, 4, 5], [8, 5, 0]],
    ],
    &[
        &[[0, 2, 3], [0, 3, 5], [3, 4, 5], [0, 5, 6]],
        &[
            [8, 0, 2],
            [8, 2, 3],
            [8, 3, 4],
            [8, 4, 5],
            [8, 5, 6],
            [8, 6, 0],
        ],
        &[
            [0, 5, 6],
            [8, 0, 2],
            [8, 2, 3],
            [8, 3, 4],
            [8, 4, 5],
            [8, 5, 0],
        ],
        &[
            [0, 2, 3],
            [8, 0, 3],
            [8, 3, 4],
            [8, 4, 5],
            [8, 5, 6],
            [8, 6, 0],
        ],
    ],
];

/// Where a compact-warp leaf whose corner `moved` (ring label) went to `x` puts its centre:
/// `(x + LR + 2·UR + UL) / 5` in the frame turned so the moved corner is the lower left, the
/// position that keeps the sweep's smallest angle at 26.5° (the leaf's centre or the corners'
/// mean leave 18.4° where the point sits beyond the leaf's side).
pub fn warped_centre(ring: &[glam::DVec2; 8], moved: u8, x: glam::DVec2) -> glam::DVec2 {
    let at = |k: u8| ring[((moved + k) % 8) as usize];
    (x + at(2) + 2.0 * at(4) + at(6)) / 5.0
}

/// What lies across the edge opposite a corner of a template triangle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Across {
    /// Another triangle of the same leaf, and its corner opposite the shared edge.
    Inside { triangle: u8, corner: u8 },
    /// A segment of the leaf's boundary.
    Boundary { side: RingSide, part: Part },
}

/// One template: its triangles as ring labels, counter-clockwise, and what lies across each
/// edge; and, per side and part, the triangle and corner facing that boundary segment.
#[derive(Clone, Debug)]
pub struct Template {
    /// Triangles as labels.
    pub triangles: Vec<[u8; 3]>,
    /// `across[t][i]`: what lies across the edge opposite corner `i` of triangle `t`.
    pub across: Vec<[Across; 3]>,
    /// `facing[side][part]`: `(triangle, corner)` whose opposite edge is that segment.
    pub facing: [[(u8, u8); 3]; 4],
}

/// Number of distinct unwarped templates: 2 diagonals, 4 single midpoints, 11 stars.
pub const KINDS: usize = 17;
const KINDS_U8: u8 = KINDS as u8;
/// Number of codes, the compact warp's 4 turns × 4 midpoint sets × 4 candidates included.
pub const CODES: usize = KINDS + 64;

impl Kind {
    /// A dense code for table lookups.
    pub fn code(self) -> u8 {
        match self {
            Kind::DiagonalUp => 0,
            Kind::DiagonalDown => 1,
            Kind::OneMidpoint(side) => 2 + side as u8,
            Kind::Star(mask) => 6 + STAR_MASKS.iter().position(|&m| m == mask).expect("star") as u8,
            Kind::Warped { turn, far, choice } => KINDS as u8 + 16 * turn + 4 * far + choice,
        }
    }

    /// The unwarped template of a leaf whose split sides are `mask` (bit per ring side).
    pub fn for_midpoints(mask: u8) -> Kind {
        match mask.count_ones() {
            0 => Kind::DiagonalUp,
            1 => Kind::OneMidpoint(RingSide::ALL[mask.trailing_zeros() as usize]),
            _ => Kind::Star(mask),
        }
    }

    fn of_code(code: u8) -> Kind {
        match code {
            0 => Kind::DiagonalUp,
            1 => Kind::DiagonalDown,
            2..=5 => Kind::OneMidpoint(RingSide::ALL[code as usize - 2]),
            6..KINDS_U8 => Kind::Star(STAR_MASKS[code as usize - 6]),
            _ => {
                let c = code - KINDS as u8;
                Kind::Warped {
                    turn: c / 16,
                    far: c / 4 % 4,
                    choice: c % 4,
                }
            }
        }
    }

    /// Ring sides carrying a midpoint.
    pub fn midpoint_mask(self) -> u8 {
        match self {
            Kind::DiagonalUp | Kind::DiagonalDown => 0,
            Kind::OneMidpoint(side) => 1 << side as u8,
            Kind::Star(mask) => mask,
            // The east side (1) and the north side (2) of the turned frame.
            Kind::Warped { turn, far, .. } => (0..2)
                .filter(|bit| far & (1 << bit) != 0)
                .map(|bit| 1 << ((1 + bit + turn) % 4))
                .sum(),
        }
    }
}

/// Whether template `code` uses the centre vertex.
pub fn uses_centre(code: u8) -> bool {
    template(code)
        .triangles
        .iter()
        .flatten()
        .any(|&label| label == CENTRE)
}

/// The sides carrying a midpoint in template `code`, one bit per ring side.
pub fn midpoint_mask_of(code: u8) -> u8 {
    Kind::of_code(code).midpoint_mask()
}

/// Masks with two or more of the four sides.
const STAR_MASKS: [u8; 11] = [3, 5, 6, 7, 9, 10, 11, 12, 13, 14, 15];

/// The template of `code`, built once.
pub fn template(code: u8) -> &'static Template {
    static TABLE: OnceLock<Vec<Template>> = OnceLock::new();
    &TABLE.get_or_init(|| (0..CODES as u8).map(|c| build(Kind::of_code(c))).collect())
        [code as usize]
}

/// The ring labels present for a midpoint mask, in counter-clockwise order.
fn ring(mask: u8) -> Vec<u8> {
    (0..8u8)
        .filter(|&label| label.is_multiple_of(2) || mask & (1 << (label / 2)) != 0)
        .collect()
}

fn triangles_of(kind: Kind) -> Vec<[u8; 3]> {
    match kind {
        Kind::DiagonalUp => vec![[0, 2, 4], [0, 4, 6]],
        Kind::DiagonalDown => vec![[0, 2, 6], [2, 4, 6]],
        Kind::OneMidpoint(side) => {
            // Corners A, B of the split side, C, D of the far side; M the midpoint.
            let at = |k: u8| (2 * side as u8 + k) % 8;
            let (a, m, b, c, d) = (at(0), at(1), at(2), at(4), at(6));
            vec![[a, m, d], [m, b, c], [m, c, d]]
        }
        Kind::Star(mask) => {
            let ring = ring(mask);
            (0..ring.len())
                .map(|i| [CENTRE, ring[i], ring[(i + 1) % ring.len()]])
                .collect()
        }
        Kind::Warped { turn, far, choice } => {
            let turned = |label: u8| {
                if label == CENTRE {
                    CENTRE
                } else {
                    (label + 2 * turn) % 8
                }
            };
            // The fourth choice with no midpoints repeats the third: codes stay dense.
            let list = WARPED_CANDIDATES[far as usize];
            list[(choice as usize).min(list.len() - 1)]
                .iter()
                .map(|t| t.map(turned))
                .collect()
        }
    }
}

/// The boundary segment from ring label `from` to the next ring label `to`, if that edge is one.
fn segment(mask: u8, from: u8, to: u8) -> Option<(RingSide, Part)> {
    if from == CENTRE || to == CENTRE {
        return None;
    }
    let labels = ring(mask);
    let i = labels.iter().position(|&l| l == from)?;
    if labels[(i + 1) % labels.len()] != to {
        return None;
    }
    let side = RingSide::ALL[(from / 2) as usize];
    if mask & (1 << side as u8) == 0 {
        return Some((side, Part::Full));
    }
    // The first half walked is the low half on the south and east sides (walked in increasing
    // coordinate), the high half on the north and west sides.
    let first = from.is_multiple_of(2);
    let increasing = matches!(side, RingSide::South | RingSide::East);
    let part = if first == increasing {
        Part::Low
    } else {
        Part::High
    };
    Some((side, part))
}

fn build(kind: Kind) -> Template {
    let mask = kind.midpoint_mask();
    let triangles = triangles_of(kind);
    let mut facing = [[(u8::MAX, u8::MAX); 3]; 4];
    let across = triangles
        .iter()
        .enumerate()
        .map(|(t, tri)| {
            std::array::from_fn(|i| {
                let (from, to) = (tri[(i + 1) % 3], tri[(i + 2) % 3]);
                if let Some((side, part)) = segment(mask, from, to) {
                    facing[side as usize][part as usize] = (t as u8, i as u8);
                    return Across::Boundary { side, part };
                }
                let (triangle, corner) = triangles
                    .iter()
                    .enumerate()
                    .find_map(|(u, other)| {
                        (0..3)
                            .find(|&j| other[(j + 1) % 3] == to && other[(j + 2) % 3] == from)
                            .map(|j| (u as u8, j as u8))
                    })
                    .expect("an interior template edge has a triangle on each side");
                Across::Inside { triangle, corner }
            })
        })
        .collect();
    Template {
        triangles,
        across,
        facing,
    }
}

/// Position of a label on the unit square.
pub(super) fn unit_position(label: u8) -> glam::DVec2 {
    let (x, y) = [
        (0.0, 0.0),
        (0.5, 0.0),
        (1.0, 0.0),
        (1.0, 0.5),
        (1.0, 1.0),
        (0.5, 1.0),
        (0.0, 1.0),
        (0.0, 0.5),
        (0.5, 0.5),
    ][label as usize];
    glam::DVec2::new(x, y)
}

/// The angles of template `code` on a square leaf.
pub fn unit_angles(code: u8) -> super::AngleQuality {
    let mut q = super::AngleQuality::empty();
    for tri in &template(code).triangles {
        let [a, b, c] = tri.map(unit_position);
        for angle in crate::mesh::angles_deg(a, b, c) {
            q.add(angle, 1);
        }
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;

    fn position(label: u8) -> (f64, f64) {
        let p = unit_position(label);
        (p.x, p.y)
    }

    fn area(t: [u8; 3]) -> f64 {
        let [a, b, c] = t.map(position);
        ((b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)) / 2.0
    }

    #[test]
    fn every_template_tiles_the_square_counter_clockwise() {
        for code in 0..CODES as u8 {
            let t = template(code);
            assert!(t.triangles.iter().all(|&tri| area(tri) > 0.0), "{code}");
            let total: f64 = t.triangles.iter().map(|&tri| area(tri)).sum();
            assert_eq!(total, 1.0, "template {code}");
        }
    }

    #[test]
    fn every_boundary_segment_has_one_facing_triangle() {
        for code in 0..CODES as u8 {
            let kind = Kind::of_code(code);
            assert_eq!(kind.code(), code);
            let t = template(code);
            let mask = kind.midpoint_mask();
            let mut segments = 0;
            for side in RingSide::ALL {
                let split = mask & (1 << side as u8) != 0;
                let parts: &[Part] = if split {
                    &[Part::Low, Part::High]
                } else {
                    &[Part::Full]
                };
                for &part in parts {
                    let (tri, corner) = t.facing[side as usize][part as usize];
                    assert_eq!(
                        t.across[tri as usize][corner as usize],
                        Across::Boundary { side, part }
                    );
                    segments += 1;
                }
            }
            let boundary = t
                .across
                .iter()
                .flatten()
                .filter(|a| matches!(a, Across::Boundary { .. }))
                .count();
            assert_eq!(boundary, segments, "template {code}");
        }
    }

    #[test]
    fn low_halves_have_the_smaller_coordinate() {
        let t = template(Kind::Star(15).code());
        for side in RingSide::ALL {
            let (tri, corner) = t.facing[side as usize][Part::Low as usize];
            let tri = t.triangles[tri as usize];
            let (a, b) = (
                position(tri[(corner as usize + 1) % 3]),
                position(tri[(corner as usize + 2) % 3]),
            );
            let along = |p: (f64, f64)| match side {
                RingSide::South | RingSide::North => p.0,
                RingSide::East | RingSide::West => p.1,
            };
            assert!(along(a).max(along(b)) <= 0.5, "{side:?}");
        }
    }
}
