//! The region a mesh covers: an axis-parallel rectangle, its sides and the mirror images the
//! mesher may work in; and the crate's one "no index" sentinel. A leaf: it imports nothing
//! from the rest of the crate.

use glam::{DVec2, Vec2Swizzles};

/// "No index" in the crate's 32-bit index arrays: no triangle, no input point, no such node,
/// leaf or point. Indices stay below it.
pub const NONE: u32 = u32::MAX;

/// An axis-parallel rectangle `[lo, hi]`, the region a mesh covers.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Domain {
    /// Lower-left corner.
    pub lo: DVec2,
    /// Upper-right corner.
    pub hi: DVec2,
}

impl Domain {
    /// Area of the rectangle.
    pub fn area(&self) -> f64 {
        let d = self.hi - self.lo;
        d.x * d.y
    }

    /// Whether the rectangle is a square: its sides equal in f64.
    pub fn is_square(&self) -> bool {
        let d = self.hi - self.lo;
        d.x == d.y
    }

    /// Whether `p` lies in the closed rectangle.
    pub fn contains(&self, p: DVec2) -> bool {
        self.lo.x <= p.x && p.x <= self.hi.x && self.lo.y <= p.y && p.y <= self.hi.y
    }

    /// The rectangle's mirror image.
    pub fn reflected(&self, r: Reflection) -> Domain {
        let (a, b) = (r.point(self.lo), r.point(self.hi));
        Domain {
            lo: a.min(b),
            hi: a.max(b),
        }
    }
}

/// A mirror image the mesher may work in and map back from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reflection {
    /// Across the diagonal `x = y`: coordinates swapped.
    Diagonal,
    /// Across the x axis: `y` negated.
    Horizontal,
}

impl Reflection {
    /// The image of a point (exact: a swap or a sign change).
    pub fn point(self, p: DVec2) -> DVec2 {
        match self {
            Reflection::Diagonal => p.yx(),
            Reflection::Horizontal => DVec2::new(p.x, -p.y),
        }
    }

    /// The image of a domain side.
    pub fn side(self, side: BoundarySide) -> BoundarySide {
        use BoundarySide::{Bottom, Left, Right, Top};
        match (self, side) {
            (Reflection::Diagonal, Bottom) => Left,
            (Reflection::Diagonal, Left) => Bottom,
            (Reflection::Diagonal, Right) => Top,
            (Reflection::Diagonal, Top) => Right,
            (Reflection::Horizontal, Bottom) => Top,
            (Reflection::Horizontal, Top) => Bottom,
            (Reflection::Horizontal, other) => other,
        }
    }
}

/// Which side of the domain a boundary edge lies on; the value is the edge's marker in the
/// output files (Triangle's convention: 0 is interior, nonzero is boundary).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum BoundarySide {
    /// `y = lo.y`.
    Bottom = 1,
    /// `x = hi.x`.
    Right = 2,
    /// `y = hi.y`.
    Top = 3,
    /// `x = lo.x`.
    Left = 4,
}

impl std::fmt::Display for BoundarySide {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            BoundarySide::Bottom => "bottom",
            BoundarySide::Right => "right",
            BoundarySide::Top => "top",
            BoundarySide::Left => "left",
        })
    }
}

/// A triangle edge on the domain boundary, oriented counter-clockwise around the domain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BoundaryEdge {
    /// Its two vertices, the domain's interior on their left.
    pub vertices: [u32; 2],
    /// Its marker (Triangle's convention: nonzero on the boundary): on a rectangle, the side it
    /// lies on (see [`BoundarySide::marker`]); on the points' convex hull, 1.
    pub marker: i32,
}

impl BoundaryEdge {
    /// The rectangle's side it lies on, for a mesh of a rectangle (one without an outline).
    pub fn side(&self) -> Option<BoundarySide> {
        BoundarySide::of_marker(self.marker)
    }
}

impl BoundarySide {
    /// The marker of the boundary edges on this side: 1 to 4 from the bottom, counter-clockwise.
    pub fn marker(self) -> i32 {
        self as i32
    }

    /// The side whose edges carry `marker`.
    pub fn of_marker(marker: i32) -> Option<BoundarySide> {
        use BoundarySide::{Bottom, Left, Right, Top};
        [Bottom, Right, Top, Left]
            .into_iter()
            .find(|s| s.marker() == marker)
    }
}

/// A mesh edge on an input segment: the segment's pieces after its splits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SubSegment {
    /// Its two vertices, in the direction of the input segment.
    pub vertices: [u32; 2],
    /// The input segment it lies on, an index into the cleaned input's segments.
    pub segment: u32,
    /// That segment's marker.
    pub marker: i32,
}
