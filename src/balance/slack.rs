//! A vector with free room before its items as well as after them, for the sorted per-point
//! arrays a dynamic edit inserts into and removes from: each edit moves the shorter side of the
//! array, half the memory traffic of a `Vec`'s shift on average.

use std::ops::{Deref, DerefMut};

/// Items `buf[start..]`, with `buf[..start]` free.
#[derive(Clone, Debug, Default)]
pub struct SlackVec<T> {
    buf: Vec<T>,
    start: usize,
}

/// Equal items, whatever room either keeps.
impl<T: PartialEq> PartialEq for SlackVec<T> {
    fn eq(&self, other: &Self) -> bool {
        self[..] == other[..]
    }
}

impl<T: Eq> Eq for SlackVec<T> {}

impl<T> From<Vec<T>> for SlackVec<T> {
    fn from(buf: Vec<T>) -> Self {
        SlackVec { buf, start: 0 }
    }
}

impl<T> Deref for SlackVec<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        &self.buf[self.start..]
    }
}

impl<T> DerefMut for SlackVec<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        &mut self.buf[self.start..]
    }
}

impl<T: Copy + Default> SlackVec<T> {
    /// Inserts `values[j]` so that it ends at position `at[j]` (sorted, distinct, positions in
    /// the longer array).
    pub fn insert_sorted(&mut self, at: &[usize], values: &[T]) {
        assert_eq!(at.len(), values.len(), "a position per value");
        let (Some(&first), Some(&last)) = (at.first(), at.last()) else {
            return;
        };
        let added = at.len();
        let before_last = last + 1 - added;
        debug_assert!(
            before_last <= self.len(),
            "positions within the longer array"
        );
        if before_last < self.len() - first {
            self.insert_moving_front(at, values);
        } else {
            self.insert_moving_back(at, values);
        }
    }

    /// Removes the items at `positions` (sorted, distinct).
    pub fn remove_sorted(&mut self, positions: &[usize]) {
        let (Some(&first), Some(&last)) = (positions.first(), positions.last()) else {
            return;
        };
        assert!(last < self.len(), "positions within the array");
        if last < self.len() - first {
            self.remove_moving_front(positions);
        } else {
            self.remove_moving_back(positions);
        }
    }

    /// Inserts `value` at position `i`.
    pub fn insert(&mut self, i: usize, value: T) {
        self.insert_sorted(&[i], &[value]);
    }

    /// Removes the item at position `i`.
    pub fn remove(&mut self, i: usize) {
        self.remove_sorted(&[i]);
    }

    /// The items before each new one move left by the number of new ones after them.
    fn insert_moving_front(&mut self, at: &[usize], values: &[T]) {
        let added = at.len();
        if self.start < added {
            self.make_room_in_front(added);
        }
        let (start, new_start) = (self.start, self.start - added);
        // Old items `moved..` have not moved yet.
        let mut moved = 0;
        for (j, (&position, &value)) in at.iter().zip(values).enumerate() {
            let old_before = position - j;
            self.buf
                .copy_within(start + moved..start + old_before, new_start + moved + j);
            self.buf[new_start + position] = value;
            moved = old_before;
        }
        self.start = new_start;
    }

    /// The items after each new one move right by the number of new ones before them.
    fn insert_moving_back(&mut self, at: &[usize], values: &[T]) {
        if self.start > self.len() / 2 {
            self.recentre();
        }
        let (start, old_len) = (self.start, self.len());
        self.buf.resize(self.buf.len() + at.len(), T::default());
        // Old items `..end` have not moved yet.
        let mut end = old_len;
        for (j, (&position, &value)) in at.iter().zip(values).enumerate().rev() {
            let old_before = position - j;
            self.buf
                .copy_within(start + old_before..start + end, start + old_before + j + 1);
            self.buf[start + position] = value;
            end = old_before;
        }
    }

    /// The items before each removed one move right by the number removed after them.
    fn remove_moving_front(&mut self, positions: &[usize]) {
        let (start, removed) = (self.start, positions.len());
        for (j, &gone) in positions.iter().enumerate().rev() {
            let begin = if j == 0 { 0 } else { positions[j - 1] + 1 };
            self.buf
                .copy_within(start + begin..start + gone, start + begin + removed - j);
        }
        self.start += removed;
    }

    /// The items after each removed one move left by the number removed before them.
    fn remove_moving_back(&mut self, positions: &[usize]) {
        let (start, len) = (self.start, self.len());
        let mut write = start + positions[0];
        for (k, &gone) in positions.iter().enumerate() {
            let end = positions.get(k + 1).copied().unwrap_or(len);
            self.buf.copy_within(start + gone + 1..start + end, write);
            write += end - gone - 1;
        }
        self.buf.truncate(write);
    }

    /// Room for at least `added` items in front, and a sixteenth of the items more, so that
    /// the copy is paid for by many insertions.
    fn make_room_in_front(&mut self, added: usize) {
        let room = added + self.len() / 16;
        let mut buf = Vec::with_capacity(room + self.len() + added);
        buf.resize(room, T::default());
        buf.extend_from_slice(self);
        (self.buf, self.start) = (buf, room);
    }

    /// Gives the room in front back (all but a sixteenth of the items) once it exceeds half
    /// the items, so that removals in front and insertions at the back do not grow the buffer
    /// without end.
    fn recentre(&mut self) {
        let room = self.len() / 16;
        let len = self.len();
        self.buf.copy_within(self.start.., room);
        self.buf.truncate(room + len);
        self.start = room;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng as _, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus as Rng;

    /// Random batches of insertions and removals at random places give what a `Vec` gives.
    #[test]
    fn edits_match_a_plain_vector() {
        let mut rng = Rng::seed_from_u64(7);
        let mut slack = SlackVec::from((0..100u32).collect::<Vec<_>>());
        let mut plain: Vec<u32> = (0..100).collect();
        let mut next = 1000;
        for _ in 0..3000 {
            let count = rng.random_range(1..5usize);
            if rng.random_bool(0.5) && plain.len() >= count {
                let mut positions: Vec<usize> = (0..count)
                    .map(|_| rng.random_range(0..plain.len()))
                    .collect();
                positions.sort_unstable();
                positions.dedup();
                for &i in positions.iter().rev() {
                    plain.remove(i);
                }
                slack.remove_sorted(&positions);
            } else {
                let longer = plain.len() + count;
                let mut at = rand::seq::index::sample(&mut rng, longer, count).into_vec();
                at.sort_unstable();
                let values: Vec<u32> = (0..at.len() as u32).map(|v| next + v).collect();
                next += at.len() as u32;
                for (&i, &v) in at.iter().zip(&values) {
                    plain.insert(i, v);
                }
                slack.insert_sorted(&at, &values);
            }
            assert_eq!(&slack[..], &plain[..]);
            assert_eq!(
                slack,
                SlackVec::from(plain.clone()),
                "equal whatever the room"
            );
            assert!(
                slack.buf.len() <= 2 * plain.len() + 200,
                "the room stays bounded"
            );
        }
    }
}
