//! Triangles waiting for refinement, smallest size class first (Har-Peled and Üngör process
//! cells from the smallest up: a Steiner point then never lands where a smaller one would).

/// A bad triangle as it was when queued: refinement replaces triangles and reuses their slots,
/// so an entry is live only while its slot still holds the same triangle. Every triangle an
/// insertion makes has the new vertex, numbered above all others, as a corner, so a slot's
/// largest corner grows with each reuse and tells the triangles in it apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Queued {
    pub triangle: u32,
    /// The largest vertex number of the triangle.
    pub newest: u32,
    /// Its order within its size class, smallest first: by its smallest angle, then its
    /// position's Morton key (see `refiner::rank`).
    pub rank: u64,
}

/// One stack per binary exponent of the squared shortest edge.
#[derive(Clone, Debug)]
pub(crate) struct SizeQueue {
    classes: Vec<Vec<Queued>>,
    lowest: usize,
    /// Per class, how many of its first entries are already in runs of descending rank; later
    /// entries were queued since and are not.
    sorted: Vec<usize>,
    /// Entries in all classes.
    len: usize,
}

impl SizeQueue {
    /// Size classes: every value [`Self::class_of`] gives is below this.
    pub const CLASSES: usize = 1 << 13;

    pub fn new() -> Self {
        SizeQueue {
            classes: vec![Vec::new(); Self::CLASSES],
            lowest: Self::CLASSES,
            sorted: vec![0; Self::CLASSES],
            len: 0,
        }
    }

    /// The class of a triangle whose shortest edge has squared length `shortest2`: its binary
    /// exponent and two leading mantissa bits, so each class spans at most a factor of 1.12 in
    /// edge length. Finer classes than whole octaves leave fewer Steiner points.
    #[inline]
    pub fn class_of(shortest2: f64) -> usize {
        ((shortest2.to_bits() >> 50) as usize) & (Self::CLASSES - 1)
    }

    #[inline]
    pub fn push(&mut self, class: usize, entry: Queued) {
        self.classes[class].push(entry);
        self.lowest = self.lowest.min(class);
        self.len += 1;
    }

    /// The next entry: from the smallest non-empty class, lowest rank first. Entries queued since
    /// the class was last taken from are put in order first and come first, so every entry is
    /// sorted once, and new bad triangles next to the last insertion are fixed while their
    /// memory is still in cache.
    pub fn pop(&mut self) -> Option<(usize, Queued)> {
        if self.len == 0 {
            self.lowest = self.classes.len();
            return None;
        }
        self.len -= 1;
        loop {
            let (class, sorted) = (
                &mut self.classes[self.lowest],
                &mut self.sorted[self.lowest],
            );
            if class.is_empty() {
                self.lowest += 1;
                continue;
            }
            if class.len() > *sorted {
                class[*sorted..].sort_unstable_by_key(|e| std::cmp::Reverse(e.rank));
            }
            let entry = class.pop();
            *sorted = class.len();
            return entry.map(|e| (self.lowest, e));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(t: u32) -> Queued {
        Queued {
            triangle: t,
            newest: t,
            rank: u64::from(t),
        }
    }

    #[test]
    fn smallest_class_first_in_rank_order_within_a_class() {
        let mut q = SizeQueue::new();
        q.push(SizeQueue::class_of(4.0), entry(1));
        q.push(SizeQueue::class_of(0.3), entry(3));
        q.push(SizeQueue::class_of(0.25), entry(2));
        q.push(SizeQueue::class_of(100.0), entry(4));
        let order: Vec<u32> = std::iter::from_fn(|| q.pop())
            .map(|(_, e)| e.triangle)
            .collect();
        assert_eq!(order, vec![2, 3, 1, 4]);
        assert_eq!(q.pop(), None);
    }

    #[test]
    fn entries_queued_meanwhile_come_first_in_their_own_order() {
        let mut q = SizeQueue::new();
        for t in [3, 1, 2] {
            q.push(SizeQueue::class_of(1.0), entry(t));
        }
        assert_eq!(q.pop().map(|(_, e)| e.triangle), Some(1));
        q.push(SizeQueue::class_of(1.0), entry(9));
        q.push(SizeQueue::class_of(1.0), entry(8));
        let order: Vec<u32> = std::iter::from_fn(|| q.pop())
            .map(|(_, e)| e.triangle)
            .collect();
        assert_eq!(order, vec![8, 9, 2, 3]);
    }

    #[test]
    fn classes_follow_the_binary_exponent() {
        assert_eq!(SizeQueue::class_of(1.0), 4 * 1023);
        assert_eq!(SizeQueue::class_of(1.2), 4 * 1023);
        assert_eq!(SizeQueue::class_of(1.3), 4 * 1023 + 1);
        assert_eq!(SizeQueue::class_of(1.99), 4 * 1023 + 3);
        assert_eq!(SizeQueue::class_of(2.0), 4 * 1024);
        assert!(SizeQueue::class_of(f64::MIN_POSITIVE) < SizeQueue::class_of(1e-300));
    }
}
