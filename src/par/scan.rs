//! Exclusive prefix sums, in two parallel passes over chunks of [`GRAIN`] items.

use super::write::{collect_indexed, collect_segments};
use super::{GRAIN, chunk_offsets};

/// Exclusive prefix sum of `count(0), ..., count(n - 1)`, with the total appended (`n + 1`
/// entries); `count` is called twice per item instead of storing the counts.
///
/// # Complexity
/// O(n) work in two parallel passes over chunks and one sequential pass over chunk sums.
pub fn exclusive_scan_by<F>(n: usize, count: F) -> Vec<usize>
where
    F: Fn(usize) -> usize + Sync,
{
    let (starts, total) = chunk_starts(n, &count);
    scan_from_chunk_starts(n, &count, &starts, total, |at| at)
}

/// As [`exclusive_scan_by`], in 32 bits: half the memory on arrays as long as the items, for
/// offsets that are 32-bit indices themselves.
///
/// # Errors
/// The total, when it reaches `u32::MAX` (the indices' "none").
pub fn exclusive_scan_u32_by<F>(n: usize, count: F) -> Result<Vec<u32>, usize>
where
    F: Fn(usize) -> usize + Sync,
{
    let (starts, total) = chunk_starts(n, &count);
    if total >= u32::MAX as usize {
        return Err(total);
    }
    Ok(scan_from_chunk_starts(n, &count, &starts, total, |at| {
        at as u32
    }))
}

/// Where each chunk of [`GRAIN`] items starts in the sum of the counts, and the total.
fn chunk_starts<F>(n: usize, count: &F) -> (Vec<usize>, usize)
where
    F: Fn(usize) -> usize + Sync,
{
    let chunks = chunk_offsets(n, GRAIN);
    let sums: Vec<usize> = collect_indexed(chunks.len() - 1, |c| {
        (chunks[c]..chunks[c + 1]).map(count).sum()
    });
    let mut starts = Vec::with_capacity(sums.len());
    let mut total = 0usize;
    for s in &sums {
        starts.push(total);
        total += s;
    }
    (starts, total)
}

/// The prefix sums from the chunks' starts, each stored as `store(sum)`.
fn scan_from_chunk_starts<T, F, S>(
    n: usize,
    count: &F,
    starts: &[usize],
    total: usize,
    store: S,
) -> Vec<T>
where
    T: Send,
    F: Fn(usize) -> usize + Sync,
    S: Fn(usize) -> T + Sync,
{
    // Output position `i` of chunk `c` is `starts[c]` plus the counts before `i` in the chunk;
    // the extra last position holds the total.
    let chunks = chunk_offsets(n + 1, GRAIN);
    collect_segments(&chunks, |c| {
        let mut acc = starts.get(c).copied().unwrap_or(total);
        let store = &store;
        (chunks[c]..chunks[c + 1]).map(move |i| {
            let here = store(acc);
            if i < n {
                acc += count(i);
            }
            here
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scan_matches_sequential() {
        for n in [0usize, 1, 5, GRAIN, 3 * GRAIN + 7] {
            let counts: Vec<u32> = (0..n).map(|i| (i * 7 % 5) as u32).collect();
            let got = exclusive_scan_by(n, |i| counts[i] as usize);
            let mut acc = 0usize;
            for (i, &c) in counts.iter().enumerate() {
                assert_eq!(got[i], acc);
                acc += c as usize;
            }
            assert_eq!(got[n], acc);
        }
    }

    /// Streaming writes land as plain ones do, at 16-byte aligned slots (streamed) and at

    #[test]
    fn the_32_bit_scan_matches_the_wide_one_and_refuses_overflow() {
        let count = |i: usize| i % 5;
        let n = 3 * GRAIN + 7;
        let wide = exclusive_scan_by(n, count);
        let narrow = exclusive_scan_u32_by(n, count).expect("fits");
        assert_eq!(narrow.len(), n + 1);
        assert!(narrow.iter().zip(&wide).all(|(&a, &b)| a as usize == b));
        let half = u32::MAX as usize / 2 + 1;
        assert_eq!(exclusive_scan_u32_by(2, |_| half), Err(2 * half));
    }
}
