use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

use super::*;

fn input(points: &[(f64, f64)], segments: &[[u32; 2]]) -> Input {
    Input {
        points: points.iter().map(|&(x, y)| DVec2::new(x, y)).collect(),
        segments: segments
            .iter()
            .enumerate()
            .map(|(i, &ends)| Segment {
                ends,
                marker: i as i32 + 10,
            })
            .collect(),
        ..Input::default()
    }
}

fn ends(input: &Input) -> Vec<[u32; 2]> {
    input.segments.iter().map(|s| s.ends).collect()
}

fn refuse(input: &Input) -> Error {
    clean(input, CleanOptions::default()).unwrap_err()
}

#[test]
fn a_clean_input_is_unchanged() {
    let square = input(
        &[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.5, 0.5)],
        &[[0, 1], [1, 2], [2, 3], [3, 0]],
    );
    let (cleaned, report) = clean(&square, CleanOptions::default()).unwrap();
    assert_eq!(cleaned, square);
    assert!(report.is_clean());
    assert_eq!(report.point_map, vec![0, 1, 2, 3, 4]);
    assert_eq!(report.segment_origin, vec![0, 1, 2, 3]);
}

#[test]
fn typed_errors() {
    let nan = input(&[(0.0, 0.0), (f64::NAN, 1.0)], &[]);
    assert!(matches!(refuse(&nan), Error::NonFinite { index: 1, .. }));
    let out_of_range = input(&[(0.0, 0.0), (1.0, 0.0)], &[[0, 1], [1, 2]]);
    assert_eq!(
        refuse(&out_of_range),
        Error::SegmentIndex {
            segment: 1,
            index: 2,
            points: 2
        }
    );
    let same_index = input(&[(0.0, 0.0), (1.0, 0.0)], &[[0, 1], [1, 1]]);
    assert_eq!(refuse(&same_index), Error::ZeroLengthSegment { segment: 1 });
    let same_position = input(&[(0.0, 0.0), (1.0, 0.0), (-0.0, 0.0)], &[[0, 1], [2, 0]]);
    assert_eq!(
        refuse(&same_position),
        Error::ZeroLengthSegment { segment: 1 }
    );
    let x = input(
        &[(0.0, 0.0), (2.0, 2.0), (5.0, 5.0), (0.0, 2.0), (2.0, 0.0)],
        &[[1, 2], [0, 1], [3, 4]],
    );
    assert_eq!(
        refuse(&x),
        Error::CrossingSegments {
            a: 1,
            b: 2,
            at: [1.0, 1.0]
        }
    );
    assert!(
        refuse(&x)
            .to_string()
            .contains("segments 1 and 2 cross at (1, 1)")
    );
}

#[test]
fn duplicate_points_merge_into_the_first_and_segments_follow() {
    let dup = input(
        &[(0.0, 0.0), (1.0, 0.0), (0.0, 0.0), (1.0, 1.0), (1.0, 0.0)],
        &[[2, 4], [0, 3], [3, 1]],
    );
    let (cleaned, report) = clean(&dup, CleanOptions::default()).unwrap();
    assert_eq!(cleaned.points.len(), 3);
    assert_eq!(report.point_map, vec![0, 1, 0, 2, 1]);
    assert_eq!(report.merged_points, 2);
    assert_eq!(report.merged_examples, vec![[2, 0], [4, 1]]);
    assert_eq!(ends(&cleaned), vec![[0, 1], [0, 2], [2, 1]]);
    let markers: Vec<i32> = cleaned.segments.iter().map(|s| s.marker).collect();
    assert_eq!(markers, vec![10, 11, 12]);
}

/// Many points on a few positions (`-0.0` among them) and many repeated pieces, more than a
/// parallel chunk holds: the merge and the drop agree with a first-come hash map, on one
/// thread and on four.
#[test]
fn merges_and_drops_in_parallel_agree_with_a_first_come_map() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(12);
    let coordinate = |rng: &mut Xoshiro256PlusPlus| match rng.random_range(0..40) {
        0 => -0.0,
        k => f64::from(k),
    };
    let points: Vec<DVec2> = (0..30_000)
        .map(|_| DVec2::new(coordinate(&mut rng), coordinate(&mut rng)))
        .collect();
    let mut first = HashMap::new();
    let mut expected_map = Vec::new();
    for (i, &p) in points.iter().enumerate() {
        let next = first.len() as u32;
        expected_map.push(*first.entry(key(p)).or_insert_with(|| (i, next)));
    }
    let pieces: Vec<Piece> = (0..20_000)
        .map(|k| Piece {
            ends: [rng.random_range(0..50), rng.random_range(50..100)],
            origin: k,
        })
        .collect();
    let mut seen = HashMap::new();
    let expected_pieces: Vec<Piece> = (pieces.iter())
        .filter(|p| {
            seen.insert([p.ends[0].min(p.ends[1]), p.ends[0].max(p.ends[1])], ())
                .is_none()
        })
        .copied()
        .collect();
    for threads in [1, 4] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let (merged, kept, report) = pool.install(|| {
            let mut kept = pieces.clone();
            let mut report = CleanReport::default();
            drop_repeats(&mut kept, &mut report);
            (merge_positions(&points), kept, report)
        });
        let map: Vec<u32> = expected_map.iter().map(|&(_, o)| o).collect();
        assert_eq!(merged.point_map, map, "{threads} threads");
        assert_eq!(merged.points.len(), first.len());
        for (i, &(f, o)) in expected_map.iter().enumerate() {
            assert_eq!(merged.points[o as usize], points[f], "{i}");
        }
        let examples: Vec<[usize; 2]> = (expected_map.iter().enumerate())
            .filter(|&(i, &(f, _))| f != i)
            .map(|(i, &(f, _))| [i, f])
            .take(REPORT_EXAMPLES)
            .collect();
        assert_eq!(merged.examples, examples);
        assert_eq!(kept, expected_pieces, "{threads} threads");
        assert_eq!(
            report.repeated_segments,
            pieces.len() - expected_pieces.len()
        );
        assert_eq!(report.repeated_examples.len(), REPORT_EXAMPLES);
    }
}

#[test]
fn repeated_segments_are_dropped() {
    let twice = input(
        &[(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)],
        &[[0, 1], [1, 2], [1, 0], [0, 1]],
    );
    let (cleaned, report) = clean(&twice, CleanOptions::default()).unwrap();
    assert_eq!(ends(&cleaned), vec![[0, 1], [1, 2]]);
    assert_eq!(report.repeated_segments, 2);
    assert_eq!(report.repeated_examples, vec![[2, 0], [3, 0]]);
    assert_eq!(report.segment_origin, vec![0, 1]);
}

#[test]
fn a_point_inside_a_segment_splits_it() {
    // Points 2 and 4 lie on segment 0, point 3 just off it (0.1 is not exactly representable,
    // but the orientation test is exact: (1/3, 1/3) in floats is on the diagonal only if equal).
    let on = input(
        &[
            (0.0, 0.0),
            (4.0, 4.0),
            (3.0, 3.0),
            (1.0, 1.0000000000000002),
            (1.0, 1.0),
        ],
        &[[0, 1], [3, 4]],
    );
    let (cleaned, report) = clean(&on, CleanOptions::default()).unwrap();
    assert_eq!(ends(&cleaned), vec![[0, 4], [4, 2], [2, 1], [3, 4]]);
    assert_eq!(report.vertex_splits, 2);
    assert_eq!(report.segment_origin, vec![0, 0, 0, 1]);
    let markers: Vec<i32> = cleaned.segments.iter().map(|s| s.marker).collect();
    assert_eq!(markers, vec![10, 10, 10, 11]);
    assert_eq!(
        report.vertex_split_examples,
        vec![
            VertexSplit {
                segment: 0,
                point: 2
            },
            VertexSplit {
                segment: 0,
                point: 4
            }
        ]
    );
}

#[test]
fn collinear_overlaps_are_split_not_refused() {
    let overlap = input(
        &[(0.0, 0.0), (2.0, 0.0), (1.0, 0.0), (3.0, 0.0)],
        &[[0, 1], [2, 3]],
    );
    let (cleaned, report) = clean(&overlap, CleanOptions::default()).unwrap();
    assert_eq!(ends(&cleaned), vec![[0, 2], [2, 1], [1, 3]]);
    assert_eq!(report.vertex_splits, 2);
    assert_eq!(report.repeated_segments, 1);
}

#[test]
fn crossings_split_when_asked() {
    let x = input(
        &[(0.0, 0.0), (2.0, 2.0), (0.0, 2.0), (2.0, 0.0)],
        &[[0, 1], [2, 3]],
    );
    let split = CleanOptions {
        split_crossings: true,
    };
    let (cleaned, report) = clean(&x, split).unwrap();
    assert_eq!(cleaned.points[4], DVec2::ONE);
    assert_eq!(ends(&cleaned), vec![[0, 4], [4, 1], [2, 4], [4, 3]]);
    assert_eq!(report.crossing_splits, 1);
    assert_eq!(
        report.crossing_examples,
        vec![CrossingSplit {
            a: 0,
            b: 1,
            point: 4,
            at: DVec2::ONE
        }]
    );
    // A cleaned input is clean.
    let (again, report) = clean(&cleaned, CleanOptions::default()).unwrap();
    assert_eq!(again, cleaned);
    assert!(report.is_clean());
}

fn random_segments(seed: u64, count: usize) -> Input {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let points: Vec<DVec2> = (0..2 * count)
        .map(|_| DVec2::new(rng.random::<f64>(), rng.random::<f64>()))
        .collect();
    let segments = (0..count as u32)
        .map(|i| Segment {
            ends: [2 * i, 2 * i + 1],
            marker: i as i32,
        })
        .collect();
    Input {
        points,
        segments,
        ..Input::default()
    }
}

#[test]
fn random_crossings_split_into_a_clean_graph_on_any_thread_count() {
    let tangle = random_segments(7, 60);
    let split = CleanOptions {
        split_crossings: true,
    };
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| clean(&tangle, split).unwrap())
    };
    let (cleaned, report) = run(1);
    assert!(report.crossing_splits > 100, "{report:?}");
    let (other, other_report) = run(3);
    assert_eq!(
        (
            cleaned.points.iter().map(|p| key(*p)).collect::<Vec<_>>(),
            &cleaned.segments
        ),
        (
            other.points.iter().map(|p| key(*p)).collect::<Vec<_>>(),
            &other.segments
        )
    );
    assert_eq!(report, other_report);
    let (again, again_report) = clean(&cleaned, CleanOptions::default()).unwrap();
    assert!(again_report.is_clean(), "{again_report:?}");
    // Checked against every pair, without the grid.
    let pieces: Vec<Piece> = cleaned
        .segments
        .iter()
        .map(|s| Piece {
            ends: s.ends,
            origin: 0,
        })
        .collect();
    for (i, &a) in pieces.iter().enumerate() {
        for &b in &pieces[i + 1..] {
            assert_eq!(meet(&cleaned.points, a, b), None, "{a:?} {b:?}");
        }
    }
    assert_eq!(again, cleaned);
    // Without the option, the first pair in segment order is named.
    match clean(&tangle, CleanOptions::default()) {
        Err(Error::CrossingSegments { a, b, .. }) => assert!(a < b),
        other => panic!("unexpected {other:?}"),
    }
}

#[test]
fn crossings_that_splitting_keeps_making_are_refused_in_few_rounds() {
    // Found by the `poly_file` fuzz target (20°, crossings split): a segment from (2, 0) to a
    // point 7.8e20 up and 1.8e10 across crosses three short ones near its foot. Its pieces are
    // nearly vertical, so each rounded split point made new crossings, more each round (6, 5,
    // 11, 20, 58, 199, 1 638, 12 168, 65 641 ...), and the points doubled until the rounds ran
    // out: minutes of work and gigabytes. A round after the first that finds more than twice
    // the first round's crossings, and some, is refused.
    let tangle = input(
        &[
            (0.0, 0.0),
            (3.5, 0.2),
            (1.5, 2.0),
            (3.0, 0.0),
            (0.0, 3.0),
            (2.0, 0.0),
            (17_777_777_774.0, 777_777_777_777_777_777_777.0),
        ],
        &[[0, 1], [2, 3], [3, 4], [6, 5]],
    );
    let split = CleanOptions {
        split_crossings: true,
    };
    match clean(&tangle, split) {
        Err(Error::CrossingsUnsettled { a, b, rounds, .. }) => {
            assert!(a < b && b <= 3, "{a} {b}");
            assert!((2..MAX_ROUNDS).contains(&rounds), "{rounds}");
        }
        other => panic!("unexpected {other:?}"),
    }
}

/// A polygon around a circle and short segments on a grid inside it: no two meet.
fn circle_and_grid(sides: usize, grid: usize) -> Input {
    let mut points = Vec::new();
    let mut segments = Vec::new();
    for k in 0..sides {
        let t = std::f64::consts::TAU * k as f64 / sides as f64;
        points.push(DVec2::new(t.cos(), t.sin()));
        segments.push(Segment {
            ends: [k as u32, ((k + 1) % sides) as u32],
            marker: 1,
        });
    }
    let step = 1.2 / grid as f64;
    for i in 0..grid {
        for j in 0..grid {
            let p = DVec2::new(-0.6 + i as f64 * step, -0.6 + j as f64 * step);
            let n = points.len() as u32;
            points.push(p);
            points.push(p + DVec2::new(0.4 * step, 0.3 * step));
            segments.push(Segment {
                ends: [n, n + 1],
                marker: 0,
            });
        }
    }
    Input {
        points,
        segments,
        ..Input::default()
    }
}

#[test]
fn ten_thousand_segments_clean_quickly() {
    let input = circle_and_grid(1000, 95);
    assert!(input.segments.len() >= 10_000);
    let start = std::time::Instant::now();
    let (cleaned, report) = clean(&input, CleanOptions::default()).unwrap();
    let took = start.elapsed();
    assert!(report.is_clean(), "{report:?}");
    assert_eq!(cleaned, input);
    assert!(took.as_secs_f64() < 10.0, "{took:?}");
}

#[test]
fn flat_and_single_point_inputs() {
    let line = input(&[(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)], &[[0, 2]]);
    let (cleaned, _) = clean(&line, CleanOptions::default()).unwrap();
    assert_eq!(ends(&cleaned), vec![[0, 1], [1, 2]]);
    let column = input(
        &[(0.0, 0.0), (0.0, 1.0), (0.0, 2.0)],
        &[[0, 1], [1, 2], [2, 0]],
    );
    let (cleaned, report) = clean(&column, CleanOptions::default()).unwrap();
    assert_eq!(ends(&cleaned), vec![[0, 1], [1, 2]]);
    assert_eq!(report.repeated_segments, 2);
    let (cleaned, _) = clean(&Input::default(), CleanOptions::default()).unwrap();
    assert_eq!(cleaned, Input::default());
}
