//! Seeded point generators for tests, benches and `quadmesh bench`: uniform, Gaussian clusters
//! (sigma down to 1e-6) and Kuzmin (the PBBS distribution, spread ~1e12 at a million points).

use std::str::FromStr;

use glam::DVec2;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;

/// A point distribution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distribution2d {
    /// Uniform in the unit square.
    Uniform,
    /// Gaussian clusters with centres uniform in the unit square and sigmas from 1e-2 to 1e-6.
    Cluster,
    /// Kuzmin's disc: radius `sqrt(1 / (1 - u)^2 - 1)`, uniform direction.
    Kuzmin,
    /// Points of the integer lattice (a random subset of a square grid).
    Grid,
}

impl Distribution2d {
    /// Every distribution.
    pub const ALL: [Distribution2d; 4] = [
        Distribution2d::Uniform,
        Distribution2d::Cluster,
        Distribution2d::Kuzmin,
        Distribution2d::Grid,
    ];
}

impl FromStr for Distribution2d {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "uniform" => Ok(Self::Uniform),
            "cluster" | "clustered" => Ok(Self::Cluster),
            "kuzmin" => Ok(Self::Kuzmin),
            "grid" => Ok(Self::Grid),
            _ => Err(format!(
                "unknown distribution '{s}' (uniform, cluster, kuzmin, grid)"
            )),
        }
    }
}

/// `n` points of `dist` from `seed`; the same arguments give the same points on every machine.
pub fn points(dist: Distribution2d, n: usize, seed: u64) -> Vec<DVec2> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    match dist {
        Distribution2d::Uniform => (0..n)
            .map(|_| DVec2::new(rng.random(), rng.random()))
            .collect(),
        Distribution2d::Cluster => clusters(n, &mut rng),
        Distribution2d::Kuzmin => (0..n).map(|_| kuzmin(&mut rng)).collect(),
        Distribution2d::Grid => lattice(n, &mut rng),
    }
}

fn clusters(n: usize, rng: &mut Xoshiro256PlusPlus) -> Vec<DVec2> {
    let count = (n / 1000).clamp(1, 1000);
    let centres: Vec<(DVec2, f64)> = (0..count)
        .map(|_| {
            let sigma = 10f64.powf(-rng.random_range(2.0..=6.0));
            (DVec2::new(rng.random(), rng.random()), sigma)
        })
        .collect();
    (0..n)
        .map(|_| {
            let (c, sigma) = centres[rng.random_range(0..count)];
            let normal = Normal::new(0.0, sigma).expect("positive sigma");
            c + DVec2::new(normal.sample(rng), normal.sample(rng))
        })
        .collect()
}

fn kuzmin(rng: &mut Xoshiro256PlusPlus) -> DVec2 {
    let angle = rng.random_range(0.0..std::f64::consts::TAU);
    let s: f64 = rng.random();
    let r = (1.0 / ((1.0 - s) * (1.0 - s)) - 1.0).sqrt();
    DVec2::new(angle.cos(), angle.sin()) * r
}

fn lattice(n: usize, rng: &mut Xoshiro256PlusPlus) -> Vec<DVec2> {
    let side = ((2 * n) as f64).sqrt().ceil().max(2.0) as u64;
    let mut picked = std::collections::BTreeSet::new();
    while picked.len() < n {
        picked.insert((rng.random_range(0..side), rng.random_range(0..side)));
    }
    let mut pts: Vec<DVec2> = picked
        .into_iter()
        .map(|(x, y)| DVec2::new(x as f64, y as f64))
        .collect();
    // Shuffle so the input order carries no Morton order.
    for i in (1..pts.len()).rev() {
        pts.swap(i, rng.random_range(0..=i));
    }
    pts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeded_and_sized() {
        for dist in Distribution2d::ALL {
            let a = points(dist, 500, 7);
            assert_eq!(a.len(), 500);
            assert_eq!(a, points(dist, 500, 7));
            assert_ne!(a, points(dist, 500, 8));
            assert!(a.iter().all(|p| p.is_finite()));
        }
    }
}
