//! Flat arrays of one kind of soft constraint, and the type-erased interface the system
//! steps through (one virtual call per set and stage, never per constraint).

use crate::bsr::{BlockMatrix, BlockPattern};
use crate::energy::{self, HessianMode, Softness};
use crate::error::SoftError;
use crate::project::{project_batch, BATCH};
use constraint_core::{DMat3, DVec3, PointConstraint, StepContext};

/// A set of constraints of one type with per-constraint softness.
#[derive(Clone, Debug)]
pub struct ConstraintSet<C, const N: usize, const R: usize> {
    name: &'static str,
    constraints: Vec<C>,
    softness: Vec<Softness>,
    /// Value slots of each constraint's `N × N` blocks in the bound matrix.
    slots: Vec<[[u32; N]; N]>,
}

impl<C: PointConstraint<N, R>, const N: usize, const R: usize> ConstraintSet<C, N, R> {
    /// A named set with one softness per constraint.
    ///
    /// # Errors
    /// [`SoftError::LengthMismatch`] if the lengths differ, [`SoftError::InvalidSoftness`]
    /// for negative or NaN values, [`SoftError::InfiniteStiffness`] for `k = ∞`.
    pub fn new(
        name: &'static str,
        constraints: Vec<C>,
        softness: Vec<Softness>,
    ) -> Result<Self, SoftError> {
        if constraints.len() != softness.len() {
            return Err(SoftError::LengthMismatch);
        }
        for s in &softness {
            let ok = |v: f64| v >= 0.0; // false for NaN
            if !(ok(s.stiffness) && ok(s.damping)) {
                return Err(SoftError::InvalidSoftness { set: name });
            }
            if s.stiffness.is_infinite() || s.damping.is_infinite() {
                return Err(SoftError::InfiniteStiffness { set: name });
            }
        }
        Ok(Self {
            name,
            constraints,
            softness,
            slots: Vec::new(),
        })
    }

    /// A named set where every constraint has the same softness.
    ///
    /// # Errors
    /// As [`ConstraintSet::new`].
    pub fn uniform(
        name: &'static str,
        constraints: Vec<C>,
        softness: Softness,
    ) -> Result<Self, SoftError> {
        let n = constraints.len();
        Self::new(name, constraints, vec![softness; n])
    }

    /// The constraints.
    pub fn constraints(&self) -> &[C] {
        &self.constraints
    }

    #[inline]
    fn gather(c: &C, x: &[DVec3]) -> [DVec3; N] {
        // Indices were validated when the set joined a system.
        let idx = c.stencil();
        core::array::from_fn(|i| x[idx[i]])
    }
}

/// The last path segment of a type's name, generic arguments dropped
/// (`constraint_core::spring::Distance` → `Distance`).
pub(crate) fn short_type_name<T: ?Sized>() -> &'static str {
    let full = core::any::type_name::<T>();
    let base = full.split('<').next().unwrap_or(full);
    base.rsplit("::").next().unwrap_or(base)
}

/// What a [`SoftSystem`](crate::SoftSystem) needs from a set of soft constraints.
pub trait ForceSet: Send + Sync {
    /// The set's name (for errors and reports).
    fn name(&self) -> &'static str;
    /// Number of constraints.
    fn len(&self) -> usize;
    /// `true` when the set is empty.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Checks every stencil index against the number of particles.
    fn validate(&self, particles: usize) -> Result<(), SoftError>;
    /// What kind of constraint the set holds, for reports: the constraint type's short
    /// name (`Distance`, `Area`, `Volume`, …) for a [`ConstraintSet`]; `"custom"` unless
    /// an implementation says otherwise.
    fn kind(&self) -> &'static str {
        "custom"
    }
    /// Whether some constraint of the set is damped (`c > 0`): the step then evaluates
    /// damping forces and, in the implicit step, `∂F/∂v`. `false` unless an
    /// implementation says otherwise.
    fn damped(&self) -> bool {
        false
    }
    /// Calls `f` with each stencil.
    fn for_each_stencil(&self, f: &mut dyn FnMut(&[usize]));
    /// Records the value slots of each constraint's blocks in `pattern`.
    fn bind(&mut self, pattern: &BlockPattern) -> Result<(), SoftError>;
    /// Energy `Σ ½kC²`.
    fn energy(&self, x: &[DVec3]) -> f64;
    /// Largest `|C_r|` over the set.
    fn max_violation(&self, x: &[DVec3]) -> f64;
    /// Adds elastic forces, and damping forces when `v` is given, to `f`.
    fn add_forces(&self, x: &[DVec3], v: Option<&[DVec3]>, f: &mut [DVec3]);
    /// Adds `−h ∂F/∂v − h² ∂F/∂x` to the bound matrix, skipping blocks that touch a
    /// pinned point (`h` and `h²` from the integrator's step context `ctx`).
    fn add_implicit(
        &self,
        x: &[DVec3],
        ctx: &StepContext,
        mode: HessianMode,
        pinned: &[bool],
        a: &mut BlockMatrix,
    );
}

impl<C, const N: usize, const R: usize> ForceSet for ConstraintSet<C, N, R>
where
    C: PointConstraint<N, R> + Send + Sync,
{
    fn name(&self) -> &'static str {
        self.name
    }

    fn len(&self) -> usize {
        self.constraints.len()
    }

    fn kind(&self) -> &'static str {
        short_type_name::<C>()
    }

    fn damped(&self) -> bool {
        self.softness.iter().any(|s| s.damping > 0.0)
    }

    fn validate(&self, particles: usize) -> Result<(), SoftError> {
        for c in &self.constraints {
            for i in c.stencil() {
                if i >= particles {
                    return Err(SoftError::IndexOutOfBounds {
                        index: i,
                        len: particles,
                    });
                }
            }
        }
        Ok(())
    }

    fn for_each_stencil(&self, f: &mut dyn FnMut(&[usize])) {
        for c in &self.constraints {
            f(&c.stencil());
        }
    }

    fn bind(&mut self, pattern: &BlockPattern) -> Result<(), SoftError> {
        self.slots.clear();
        self.slots.reserve(self.constraints.len());
        for c in &self.constraints {
            let idx = c.stencil();
            let mut s = [[0u32; N]; N];
            for (i, row) in s.iter_mut().enumerate() {
                for (j, slot) in row.iter_mut().enumerate() {
                    let k = pattern
                        .slot(idx[i], idx[j])
                        .ok_or(SoftError::IndexOutOfBounds {
                            index: idx[i].max(idx[j]),
                            len: pattern.len(),
                        })?;
                    *slot = k as u32;
                }
            }
            self.slots.push(s);
        }
        Ok(())
    }

    fn energy(&self, x: &[DVec3]) -> f64 {
        self.constraints
            .iter()
            .zip(&self.softness)
            .map(|(c, s)| energy::energy(c, *s, &Self::gather(c, x)))
            .sum()
    }

    fn max_violation(&self, x: &[DVec3]) -> f64 {
        self.constraints
            .iter()
            .flat_map(|c| c.value(&Self::gather(c, x)))
            .fold(0.0, |m: f64, v| {
                if m.is_nan() || v.is_nan() {
                    f64::NAN
                } else {
                    m.max(v.abs())
                }
            })
    }

    fn add_forces(&self, x: &[DVec3], v: Option<&[DVec3]>, f: &mut [DVec3]) {
        for (c, s) in self.constraints.iter().zip(&self.softness) {
            let xl = Self::gather(c, x);
            let vl = v.map(|v| Self::gather(c, v));
            let fl = energy::force(c, *s, &xl, vl.as_ref());
            for (&i, fi) in c.stencil().iter().zip(fl) {
                f[i] += fi;
            }
        }
    }

    fn add_implicit(
        &self,
        x: &[DVec3],
        ctx: &StepContext,
        mode: HessianMode,
        pinned: &[bool],
        a: &mut BlockMatrix,
    ) {
        // Elements go through in batches so that their projections can share one
        // eigen-iteration (project::BATCH); the result is the same as one at a time.
        let n = self
            .constraints
            .len()
            .min(self.softness.len())
            .min(self.slots.len());
        let mut start = 0;
        while start < n {
            let end = (start + BATCH).min(n);
            let mut xs = [[DVec3::ZERO; N]; BATCH];
            let mut stiff = [[[DMat3::ZERO; N]; N]; BATCH];
            let mut damp: [Option<[[DMat3; N]; N]>; BATCH] = [None; BATCH];
            let mut selected = [false; BATCH];
            for (l, k) in (start..end).enumerate() {
                let c = &self.constraints[k];
                xs[l] = Self::gather(c, x);
                let parts = energy::implicit_parts(c, self.softness[k], &xs[l], ctx, mode);
                stiff[l] = parts.stiffness;
                selected[l] = parts.project;
                damp[l] = parts.damping;
            }
            if selected.iter().any(|&s| s) {
                project_batch(&mut stiff[..end - start], &xs[..end - start], &selected);
            }
            for (l, k) in (start..end).enumerate() {
                let idx = self.constraints[k].stencil();
                let slots = &self.slots[k];
                let blocks = &mut stiff[l];
                if let Some(d) = &damp[l] {
                    for i in 0..N {
                        for j in 0..N {
                            blocks[i][j] += d[i][j];
                        }
                    }
                }
                for i in 0..N {
                    if pinned[idx[i]] {
                        continue;
                    }
                    for j in 0..N {
                        if !pinned[idx[j]] {
                            a.values[slots[i][j] as usize] += blocks[i][j];
                        }
                    }
                }
            }
            start = end;
        }
    }
}
