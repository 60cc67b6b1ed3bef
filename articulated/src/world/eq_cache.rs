//! Reuse of the equality complement between solves over the same factor.
//!
//! The equality rows' complement (`equality.rs`) is, after the tree-and-loop solve,
//!
//! ```text
//! Y_E = H⁻¹ Eᵀ  (one tree-and-loop solve per row),   S = E Y_E,   S⁺ (SVD),
//! ν = S⁺ (E x_free − r_E),   x = x_free − Y_E ν,
//! ```
//!
//! and only `ν` reads the right-hand side: `Y_E` and `S⁺` are functions of the factor
//! of `H`, the loop rows and their compliances, the rows `E` and the two truncation
//! scales. RATTLE solves the same matrix several times (each damping flow's two
//! stages, the kick and SHAKE's chord iterations) and, through the factor cache
//! (`factor_cache.rs`), the same matrix again at the next step's start (its first
//! damping flow and first kick are the previous step's last ones, positions
//! unchanged). With the arm of dm_control's manipulator (one tendon equality) the
//! complement was a third of a step: `k` tree solves and two SVDs in each of six
//! solves.
//!
//! Two complements are kept, each with a key of every input bit: the assembly the
//! factor belongs to (`h` and rate rows of a RATTLE assembly, tagged by
//! [`World::tag_equality_factor`] after the rows are loaded; untagged assemblies — the
//! velocity level and the projection, whose matrices have no key — are never kept),
//! the bodies' poses, masses and inertias, the joints' compliances and armatures (with
//! `h` and the rate rows these fix the factor, as in `factor_cache.rs`), the tree size,
//! the loop rows and compliances, the equality rows, and both truncation scales. A
//! complement whose key equals a kept one bit for bit is copied instead of computed:
//! the same operations on the same bits give the same bits, so results are unchanged.

use alloc::vec::Vec;

use super::{LoopRows, Rates, World};
use crate::body::RigidBody;
use constraint_core::compound::MAX_DOF;

/// One kept complement: its key, `Y_E` (column-major by row), `S⁺` (row-major), and
/// whether `S` had a singular value above the floor (else `ν = 0`).
#[derive(Clone, Debug, Default)]
struct Slot {
    key: Vec<u64>,
    cols: Vec<f64>,
    pinv: Vec<f64>,
    solved: bool,
    /// The clock of its last use (least recently used is replaced).
    used: u64,
}

/// The kept complements and the tag of the loaded assembly ([`World::tag_equality_factor`]).
#[derive(Clone, Debug, Default)]
pub(crate) struct EqCache {
    /// `(h bits, rates)` of the factor the loaded rows are solved with; `None`: not kept.
    tag: Option<(u64, Rates)>,
    slots: [Slot; 2],
    /// The key of the complement being looked up (scratch).
    probe: Vec<u64>,
    clock: u64,
}

/// The inputs of one complement besides the tag ([`EqCache::lookup`]).
pub(crate) struct EqInputs<'a> {
    pub bodies: &'a [RigidBody],
    pub compliance: &'a [f64],
    pub armature: &'a [[f64; MAX_DOF]],
    pub size: usize,
    pub loops: &'a LoopRows,
    pub segs: &'a [super::equality::Seg],
    pub ranges: &'a [(usize, usize)],
    /// The loop rows' free scale and the equality rows' truncation floor.
    pub scales: [f64; 2],
}

impl EqCache {
    /// Forgets the tag (the rows were loaded by an assembly without a key).
    pub(crate) fn untag(&mut self) {
        self.tag = None;
    }

    /// Looks the complement of `inputs` up under the current tag: `Some(solved)` after
    /// copying the kept `Y_E` and `S⁺` into `cols` and `pinv`; `None` (untagged or not
    /// kept) leaves them alone, and [`Self::store`] keeps the one computed next.
    pub(crate) fn lookup(
        &mut self,
        inputs: &EqInputs<'_>,
        cols: &mut Vec<f64>,
        pinv: &mut Vec<f64>,
    ) -> Option<bool> {
        let (h, rates) = self.tag?;
        fill_key(&mut self.probe, h, rates, inputs);
        self.clock += 1;
        let slot = self.slots.iter_mut().find(|s| s.key == self.probe)?;
        slot.used = self.clock;
        cols.clone_from(&slot.cols);
        pinv.clone_from(&slot.pinv);
        Some(slot.solved)
    }

    /// Keeps the complement just computed for the key of the last missed
    /// [`Self::lookup`] (nothing when untagged), replacing the least recently used.
    pub(crate) fn store(&mut self, cols: &[f64], pinv: &[f64], solved: bool) {
        if self.tag.is_none() {
            return;
        }
        let Some(slot) = self.slots.iter_mut().min_by_key(|s| s.used) else {
            return;
        };
        core::mem::swap(&mut slot.key, &mut self.probe);
        slot.cols.clear();
        slot.cols.extend_from_slice(cols);
        slot.pinv.clear();
        slot.pinv.extend_from_slice(pinv);
        slot.solved = solved;
        slot.used = self.clock;
    }
}

/// The bits of every input of a complement (module documentation).
fn fill_key(key: &mut Vec<u64>, h: u64, rates: Rates, inputs: &EqInputs<'_>) {
    key.clear();
    let rates = match rates {
        Rates::None => 0,
        Rates::Armature => 1,
        Rates::Full => 2,
    };
    let (loop_rows, loop_c, _) = inputs.loops;
    key.extend([
        h,
        rates,
        inputs.size as u64,
        inputs.bodies.len() as u64,
        loop_rows.len() as u64,
        inputs.ranges.len() as u64,
        inputs.scales[0].to_bits(),
        inputs.scales[1].to_bits(),
    ]);
    for b in inputs.bodies {
        key.extend_from_slice(&super::factor_cache::body_bits(b));
    }
    key.push(inputs.compliance.len() as u64);
    key.extend(inputs.compliance.iter().map(|a| a.to_bits()));
    for a in inputs.armature {
        key.extend_from_slice(&a.map(f64::to_bits));
    }
    let side = |a: &Option<usize>| a.map_or(u64::MAX, |i| i as u64);
    let rows =
        |key: &mut Vec<u64>, a: &Option<usize>, b: usize, g: &[constraint_core::DVec3; 4]| {
            key.extend([side(a), b as u64]);
            for v in g {
                key.extend_from_slice(&v.to_array().map(f64::to_bits));
            }
        };
    for ((a, b, g), c) in loop_rows.iter().zip(loop_c) {
        rows(key, a, *b, g);
        key.push(c.to_bits());
    }
    for &(lo, hi) in inputs.ranges {
        key.extend([lo as u64, hi as u64]);
    }
    for (a, b, g) in inputs.segs {
        rows(key, a, *b, g);
    }
}

impl World {
    /// Tags the equality rows just loaded ([`World::load_equalities`]) with the RATTLE
    /// assembly `(h, rates)` (soft rows free) whose factor solves them — its factor-cache
    /// key ([`World::reuse_factor`]) — so their complement can be kept and reused.
    pub(super) fn tag_equality_factor(&mut self, h: f64, rates: Rates) {
        if self.eq.active {
            self.eq_cache.tag = Some((h.to_bits(), rates));
        }
    }
}
