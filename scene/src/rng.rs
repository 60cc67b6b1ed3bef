//! A small seeded pseudo-random generator for scenes, sweeps and tests: the same
//! numbers on every platform for the same seed, so a seeded configuration (a jittered
//! cloth, a random Jacobian check) is reproducible anywhere.

use constraint_core::{DMat3, DVec3};

/// A small seeded pseudo-random generator: xoshiro256\*\* with its state filled by
/// splitmix64 from a 64-bit seed. Deterministic on every platform; not cryptographic.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rng {
    s: [u64; 4],
}

impl Rng {
    /// A generator seeded with `seed` (every seed, including 0, is fine).
    pub fn new(seed: u64) -> Self {
        let mut z = seed;
        let mut next = || {
            z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut v = z;
            v = (v ^ (v >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            v = (v ^ (v >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            v ^ (v >> 31)
        };
        Self {
            s: [next(), next(), next(), next()],
        }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let result = s[1].wrapping_mul(5).rotate_left(7).wrapping_mul(9);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// Uniform in `[0, 1)` with 53 random bits.
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }

    /// Log-uniform in `[lo, hi)` (`0 < lo ≤ hi`): every decade equally likely.
    pub fn log_uniform(&mut self, lo: f64, hi: f64) -> f64 {
        (self.uniform(lo.ln(), hi.ln())).exp()
    }

    /// `+1` or `−1` with equal probability.
    pub fn sign(&mut self) -> f64 {
        if self.next_u64() >> 63 == 0 {
            1.0
        } else {
            -1.0
        }
    }

    /// `true` with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        self.next_f64() < p
    }

    /// A uniformly distributed unit vector.
    pub fn unit_vector(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(
                self.uniform(-1.0, 1.0),
                self.uniform(-1.0, 1.0),
                self.uniform(-1.0, 1.0),
            );
            let l2 = v.length_squared();
            if l2 > 1e-4 && l2 <= 1.0 {
                return v / l2.sqrt();
            }
        }
    }

    /// A point uniform in the axis-aligned box `center ± half_extent`.
    pub fn in_box(&mut self, center: DVec3, half_extent: f64) -> DVec3 {
        center
            + half_extent
                * DVec3::new(
                    self.uniform(-1.0, 1.0),
                    self.uniform(-1.0, 1.0),
                    self.uniform(-1.0, 1.0),
                )
    }

    /// A uniformly random rotation as a proper orthonormal matrix (columns `u, v, u×v`).
    pub fn rotation(&mut self) -> DMat3 {
        let u = self.unit_vector();
        let (a, b) = u.any_orthonormal_pair();
        let phi = self.uniform(0.0, core::f64::consts::TAU);
        let v = phi.cos() * a + phi.sin() * b;
        DMat3::from_cols(u, v, u.cross(v))
    }

    /// Row weights for a curvature check: each `±` log-uniform in `[0.5, 2)`.
    pub fn weights<const R: usize>(&mut self) -> [f64; R] {
        core::array::from_fn(|_| self.sign() * self.log_uniform(0.5, 2.0))
    }
}
