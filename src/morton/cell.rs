//! Squares of the quadtree, named by the Morton key of their lower-left corner and a level.

use super::MortonKey;

/// A square of the tree: the Morton key of its lower-left corner and its level (0 = root).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Cell<K> {
    /// Morton key of the lower-left corner.
    pub anchor: K,
    /// Level; the side is `2^-level` of the root's.
    pub level: u8,
}

impl<K: MortonKey> Cell<K> {
    /// The root square.
    pub fn root() -> Self {
        Cell {
            anchor: K::default(),
            level: 0,
        }
    }

    /// The square at `level` holding key `k`.
    pub fn containing(k: K, level: u8) -> Self {
        Cell {
            anchor: k.cell_anchor(level),
            level,
        }
    }

    /// Whether key `k` lies in this square.
    pub fn contains(&self, k: K) -> bool {
        k.cell_anchor(self.level) == self.anchor
    }

    /// The parent square (the root for the root).
    pub fn parent(&self) -> Self {
        Cell::containing(self.anchor, self.level.saturating_sub(1))
    }

    /// log2 of the number of grid keys the square spans.
    pub fn span_bits(&self) -> u32 {
        2 * (K::AXIS_BITS - self.level as u32)
    }
}
