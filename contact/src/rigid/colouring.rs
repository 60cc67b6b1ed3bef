//! Graph colouring of the contact manifolds for the soft step (Box2D v3
//! `constraint_graph.c`): manifolds — the points of one collider pair — are coloured
//! greedily so that no two manifolds of one colour share a moving body, and the points
//! are then ordered colour by colour.
//!
//! Within a colour the points touch disjoint bodies, so their Gauss–Seidel updates
//! commute: the order inside a colour does not change a single bit of the result.
//! The solve order is therefore colour-major and, inside a colour, interleaved across
//! manifolds (first point of every manifold, then the second, …), which puts
//! independent rows next to each other: the processor overlaps their dependency chains
//! instead of waiting on each body update before the next row of the same pair.
//!
//! Greedy rule: manifolds are visited bottom-up (the order the caller gives) and each
//! takes the lowest colour that neither of its moving bodies already has, out of
//! [`COLOURS`]; a manifold with no colour left goes to a last, overflow colour (still
//! solved in the same sequential pass: colours order the work, they are not needed for
//! correctness). A static body (the ground slot) never blocks a colour, as in Box2D.
//! Everything is integer bookkeeping on kept buffers: deterministic, no allocation
//! once the buffers have grown.

use alloc::vec::Vec;

/// Colours tried per manifold (one bit each in a body's mask); the overflow colour is
/// `COLOURS`.
pub const COLOURS: u32 = 63;

/// Kept buffers of the colouring.
#[derive(Clone, Debug, Default)]
pub(super) struct Colouring {
    /// Manifold of each contact (natural order).
    manifold: Vec<u32>,
    /// Rank of each manifold in the bottom-up visit (`u32::MAX` before it is seen).
    rank: Vec<u32>,
    /// Colour of each manifold.
    colour: Vec<u32>,
    /// Points of each manifold placed so far.
    placed: Vec<u32>,
    /// Colours used by each body (bit `c` set: a manifold of colour `c` touches it).
    used: Vec<u64>,
    /// Sort key of each contact: colour, place in its manifold, manifold rank.
    key: Vec<u64>,
    /// Colours in use after the last call (the overflow colour counts as one).
    pub(super) colours: usize,
}

impl Colouring {
    /// Reorders `order` — contact indices, bottom-up — into colour-major order.
    /// `pair(k)` gives contact `k`'s collider pair (contacts of one pair come
    /// consecutively in natural order and form one manifold) and its two body slots;
    /// slots `≥ bodies` are static.
    pub(super) fn order<F>(&mut self, order: &mut [usize], bodies: usize, pair: F)
    where
        F: Fn(usize) -> ((usize, usize), [usize; 2]),
    {
        let n = order.len();
        // Manifolds: runs of equal pairs in natural order.
        self.manifold.clear();
        let mut count = 0u32;
        let mut last = None;
        for k in 0..n {
            let (p, _) = pair(k);
            if last != Some(p) {
                count += 1;
                last = Some(p);
            }
            self.manifold.push(count - 1);
        }
        let m = count as usize;
        self.rank.clear();
        self.rank.resize(m, u32::MAX);
        self.colour.clear();
        self.colour.resize(m, 0);
        self.placed.clear();
        self.placed.resize(m, 0);
        self.used.clear();
        self.used.resize(bodies, 0);
        self.key.clear();
        self.key.resize(n, 0);
        let mut next_rank = 0u32;
        let mut highest = 0u32;
        for &k in order.iter() {
            let j = self.manifold[k] as usize;
            if self.rank[j] == u32::MAX {
                self.rank[j] = next_rank;
                next_rank += 1;
                // Lowest colour free on both moving bodies.
                let (_, [a, b]) = pair(k);
                let mask = |s: usize| if s < bodies { self.used[s] } else { 0 };
                let taken = mask(a) | mask(b);
                let c = (!taken).trailing_zeros().min(COLOURS);
                if c < COLOURS {
                    for s in [a, b] {
                        if s < bodies {
                            self.used[s] |= 1 << c;
                        }
                    }
                }
                self.colour[j] = c;
                highest = highest.max(c);
            }
            let place = self.placed[j];
            self.placed[j] += 1;
            self.key[k] = (u64::from(self.colour[j]) << 56)
                | (u64::from(place.min(0xff)) << 48)
                | u64::from(self.rank[j]);
        }
        self.colours = if n == 0 { 0 } else { highest as usize + 1 };
        // Keys are unique (a manifold's rank and a point's place in it): the unstable
        // sort is deterministic.
        let key = &self.key;
        order.sort_unstable_by_key(|&k| key[k]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stack: ground–1, 1–2, 2–3, 3–4 with two points each, bottom-up. Colours
    /// alternate (0, 1, 0, 1: the ground does not block), and the order is colour 0's
    /// manifolds interleaved, then colour 1's.
    #[test]
    fn a_stack_alternates_two_colours() {
        // Contacts 0,1: pair (0,1) slots [4,0]; 2,3: (1,2) [0,1]; 4,5: (2,3) [1,2];
        // 6,7: (3,4) [2,3]. Slot 4 is static (4 bodies).
        let pairs = [
            ((0, 1), [4, 0]),
            ((0, 1), [4, 0]),
            ((1, 2), [0, 1]),
            ((1, 2), [0, 1]),
            ((2, 3), [1, 2]),
            ((2, 3), [1, 2]),
            ((3, 4), [2, 3]),
            ((3, 4), [2, 3]),
        ];
        let mut order: Vec<usize> = (0..8).collect();
        let mut c = Colouring::default();
        c.order(&mut order, 4, |k| pairs[k]);
        assert_eq!(order, [0, 4, 1, 5, 2, 6, 3, 7]);
        assert_eq!(c.colours, 2);
    }

    /// Manifolds of one colour never share a moving body, on a random-ish graph of
    /// 30 manifolds over 8 bodies (static slot 8), and every contact appears once.
    #[test]
    fn one_colour_never_shares_a_moving_body() {
        let mut pairs = Vec::new();
        let mut s = 12345u64;
        for j in 0..30 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let a = (s >> 33) as usize % 9;
            let b = (s >> 45) as usize % 8;
            let b = if b == a { 8 } else { b };
            for _ in 0..1 + j % 4 {
                pairs.push(((j, j + 1), [a, b]));
            }
        }
        let mut order: Vec<usize> = (0..pairs.len()).collect();
        let mut c = Colouring::default();
        c.order(&mut order, 8, |k| pairs[k]);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..pairs.len()).collect::<Vec<_>>());
        for k in 0..pairs.len() {
            for l in 0..pairs.len() {
                let (jk, jl) = (c.manifold[k] as usize, c.manifold[l] as usize);
                if jk == jl || c.colour[jk] != c.colour[jl] || c.colour[jk] == COLOURS {
                    continue;
                }
                for s in pairs[k].1 {
                    assert!(s == 8 || !pairs[l].1.contains(&s), "{k} {l} share {s}");
                }
            }
        }
        // Colour-major: colours never decrease along the order.
        let colours: Vec<u32> = order
            .iter()
            .map(|&k| c.colour[c.manifold[k] as usize])
            .collect();
        assert!(colours.windows(2).all(|w| w[0] <= w[1]), "{colours:?}");
        assert!(c.colours >= 2);
    }
}
