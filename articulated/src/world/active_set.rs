//! The one-sided rows by an active set inside the tree factor: `O(n)` per iteration
//! where the dense path ([`super::unilateral`]) costs one tree solve per row, a dense
//! Delassus matrix and a dense complementarity solve.
//!
//! Each row is *active* (held as an equality `w = G v' − bias = 0`, a row of the
//! augmented tree factor of [`crate::tree_rows`]), *inactive* (`z = 0`) or *at a
//! bound* (`z = lo` or `hi`, moved to the right-hand side as a known impulse `Gᵀ z`).
//! One iteration factors and solves
//!
//! ```text
//! [H    G_Aᵀ] [x ]   [b + G_Fᵀ z_F]
//! [G_A   0  ] [−z_A] = [bias_A     ]       (F: the rows at a bound)
//! ```
//!
//! and updates the set by the signs of the natural map (the primal–dual active set, a
//! semismooth Newton step on `z = mid(lo, z − w, hi)`): an active one-sided row with
//! `z < 0` leaves, an inactive one with `w < 0` enters; an active boxed or friction
//! row beyond its bound goes to it, one at its bound whose `w` turned against the
//! bound (`w > 0` at `hi`, `w < 0` at `lo`) comes back. Friction bounds `±μ z_n` use
//! the normal impulse of the previous iteration (the staggered coupling of
//! [`constraint_contact::lcp::Coupling::Staggered`], iterated here to its fixed
//! point: the step ends when the set is unchanged and every bound moved by less than
//! `1e-11` of the largest impulse, or earlier, on the first iterate whose natural-map
//! residual `max |z − mid(lo, z − w, hi)|` is at most [`ACCEPT_FRACTION`] of the dense
//! path's acceptance, `World::natural_residual`). An iteration that leaves the set
//! unchanged but moves bounds jumps to the bounds' fixed point for that set (one small linear solve,
//! `World::extrapolate_bounds`) instead of creeping to it. The set starts from the
//! last step's, matched by row identity (limit: joint, degree of freedom, side;
//! contact: collider pair and feature id, axis).
//!
//! Rows that keep the tree a tree ([`crate::tree_rows`]: limits and dry friction of
//! tree joints, contacts with the static world) go into the factor. Contacts between
//! two bodies (a humanoid's hand on its thigh) would close a loop: they are *coupled*
//! rows, held outside the factor; active, they are solved by their Schur complement
//! `G_C H_A⁻¹ G_Cᵀ` after each factor solve (per active coupled row one forward pass
//! over its bodies' paths to the root, [`World::schur_columns`]),
//! together with the active rows whose pivot the factor drops (more rows at a node
//! than its subtree has freedoms), as loop rows are; at a bound their impulse is on
//! the right-hand side as any row's. Rows still unsatisfied after it are dependent
//! and checked by value. The same primal–dual iteration decides the statuses of both
//! kinds.
//!
//! Equality rows ([`super::equality`], MuJoCo's `equality/joint` and `equality/tendon`:
//! rows over several bodies, so neither a tree node's row nor a two-body one) are
//! Schur rows too, always active and two-sided: appended after the coupled rows in
//! every iteration, with the target `r_E = −β C/h`, their multipliers `ν = ζ` (the
//! dense path's `x = x_free − Y_E ν`), never in the status update. An equality row the
//! others leave unreachable by more than the tolerance (a redundant row whose target
//! disagrees) sends the step to the dense path, whose minimum-norm solve takes it.
//! Measured (issue 13, dm_control's manipulator and stacker, one `equality/tendon`
//! coupling the fingers; 1 s passive, RATTLE): `World::step` 0.575M → 0.556M and
//! 1.240M → 0.756M instructions per step against sending their steps to the dense
//! path; manipulator 766 tries, 19 failed, 83 steps skipped by the back-off, stacker
//! 723, 28, 62 (5 s: 4 765, 22, 84 and 4 723, 28, 62). The same models without the
//! equality: 0.500M and 0.716M, with the same active-set instructions, so the rows
//! cost the active set next to nothing; of the rest (manipulator, 56K per step) 23K
//! is the position projection's equality complement, the remainder the rows' assembly
//! and the dense steps. The failures (5 s) are sets not settled within
//! [`MAX_ITERATIONS`] (manipulator 12, stacker 24), cycles (9, 3) and a dependent
//! one-sided row (1, 1); no step failed on an unreachable equality row.
//!
//! A step with a row neither kind holds (a tendon limit), with loop joints, whose set
//! does not settle within [`MAX_ITERATIONS`] or returns to a set met
//! earlier in the step (the update cycles), with more than
//! [`MAX_SCHUR`] Schur rows, or where a dependent one-sided row left short has no
//! active row to give way for it or repeats a release between two dependent rows
//! ([`dependent`]), goes to
//! the dense path unchanged (counted in [`super::UnilateralStats`]); after three or
//! more such steps in a row, the next ones go there without trying (a doubling
//! back-off, `World::solve_unilateral_sparse`). An iteration whose set of factor rows
//! is the last one's reuses its factor and the Schur rows' columns.
//!
//! Why humanoid steps still go to the dense path (issue 13, measured on dm_control's
//! humanoid_CMU, 5 s passive: lying on the floor, about 47 contacts and 141 rows): of
//! 2 500 steps, 1 353 tried the active set, 1 164 settled; of the 189 failures, 131
//! did not settle within 20 iterations, the cap then (at the 20th iteration the update still
//! changed 8 to 22 rows, with 25 to 36 Schur rows: the primal–dual update does not
//! settle on the many dependent contact rows of a body lying flat) and 58 ended on a
//! dependent one-sided row the Schur rows could not hold; the back-off then sent
//! 1 147 steps to the dense path without trying. (A further 46 failures, the factor
//! reporting a singular body, were round-off pivots kept beyond a node's rank:
//! removed by `tree_rows`' rank cap.) dm_control's humanoid, 5 s passive: 742 tries,
//! 698 settled, 20 dependent rows, 13 cycles, 11 not settled, 219 steps skipped.
//! These are limits of the method (a non-settling update), not of a parameter:
//! raising [`MAX_SCHUR`] changes nothing, as no step exceeds it.
//!
//! Measured again (dm_control's humanoid, 2 s passive, 400 steps): 32 tries failed, 18
//! on a dependent one-sided Schur row that missed its target by 2e-10 to 5e-4 m/s
//! (beyond the solver tolerance, 1e-10), 11 not settled within [`MAX_ITERATIONS`] and 3
//! cycles; the back-off then skipped 217 steps. The dense steps' complementarity solve
//! (the staggered coupling) is 56 % of the run's instructions: 15.6 normal/friction
//! alternations per step on average, 14 steps at the cap of 50. Tried and left out:
//! accepting such a miss up to `0.01 · slop / h` (the tries then ran out of iterations
//! instead: 5.12 → 5.21M instructions per step), probing with two iterations during
//! the back-off (6.06M), truncating the Schur rows' factor at `1e-6` or `1e-3` of its
//! largest pivot instead of `1e-10` (5.11M, 5.05M).
//!
//! Measured again (issue 13, main ed085de, dm_control's humanoid 2 s passive, 400
//! steps): 185 tries, 150 settled, 176 steps skipped; of the 35 failures 22 a dependent
//! one-sided row short by 2.1e-10 to 5.0e-4 m/s (tolerance 1e-10 to 3.8e-10), each with
//! one to four dependent one-sided Schur rows the minimum-norm solve left beyond their
//! targets (`w > tol`); 12 not settled, where both feet's normals and friction rows
//! repeat a period-8 pattern (a normal pulled by friction at bounds from the last
//! normals leaves, comes back with `w < 0`, its friction rows re-enter at `|w|` of
//! 1e-9) that the cycle fingerprint misses, the normals' values differing; 1 cycle.
//! Tried and left out (one trajectory is chaotic: any change of bits moves the tries
//! and failures, so each lever was also run on an ensemble of four 2 s runs per
//! humanoid, passive, controlled and two root kicks; instructions per step of
//! `World::step`): releasing the over-satisfied dependent one-sided rows when one is
//! short (the primal–dual rule for `w > 0` while active) turned the failures into
//! non-settling updates (28: 2 dependent, 19 not settled, 7 cycles; 71 settled tries,
//! 262 skipped steps); moving `ζ` along `S`'s null space to make the minimum-norm
//! split non-negative (Goldfarb–Idnani's step for a dependent constraint) found the
//! dependencies among the Schur rows themselves (`H_A⁻¹ G_Dᵀ n` of norm 2e-15) and
//! changed little (35 failures, 19 dependent, 75 settled tries); a dependent row's
//! allowance of 10 and 100 × the tolerance (3.18M → 3.83M and 3.19M, chaotic); no
//! back-off (ensemble sum, dm_control 18.01M → 20.26M, gymnasium 6.06M → 6.09M) and a
//! back-off capped at 3 steps (18.75M, 6.08M).
//!
//! Ending on the residual (issue 13, [`ACCEPT_FRACTION`]). The failed tries were
//! mostly near-solutions the status rules would not stop on: with dm_control's
//! humanoid, 2 s passive, the iterate of a try that failed on a dependent one-sided
//! row had a natural-map residual of 2e-10 to 1.6e-9 in 8 of 22 tries (the row short
//! by a hair over `tol_w`), and 70 of the 78 tries that then ran out of iterations had
//! met a residual below 1e-8 at their first iteration (the warm-started set), the
//! update then wandering off on friction rows of `|w| ≈ 1e-9`. The dense path accepts
//! its answer at a residual of `friction_tolerance` (1e-6, relative to
//! `max(1, max |q|)`; its answers there measured 1.5e-7 to 9.8e-7); the active set now
//! ends on the first iterate within a tenth of it (relative to `bias_scale ≥ 1`). Same
//! run (`simulate … humanoid.xml --duration 2`, callgrind `--toggle-collect` on
//! `World::step`): 1 394M → 1 156M instructions (3.48M → 2.89M per step); tries
//! 106 → 289, failed 39 → 36 (26 dependent rows, 10 not settled), dense steps 294 →
//! 108; active set 159M → 321M, dense path 829M → 428M. Ensemble (passive, two root
//! kicks `--qvel 1,0,0.5,0,0,0` and `0,-1,0,1,2,0`, controlled where the control file
//! is at hand; 2 s each, `World::step` instructions summed): dm_control's humanoid
//! 5 630M → 5 190M, gymnasium's humanoid 3 504M → 3 501M, humanoidstandup (no
//! controlled run) 2 745M → 2 495M; the passive run's end state: root height
//! 0.27502 → 0.27500 m, settled penetration 1.0000001e-4 m both, energy 177.31 →
//! 177.35 J (no rise). Tried with it and left out (same ensemble, chaotic to ± 20 % on
//! single runs): a residual of 1e-8 instead of 1e-7 (dm_control 5 339M, standup
//! 2 496M); also ending a failed try on its best iterate below 1e-6 instead of the
//! dense path (dm_control 5 393M, gymnasium 3 606M); releasing the most (or every)
//! over-satisfied dependent one-sided row when one is short (dm_control passive: the
//! failures became non-settling updates, 28 failed tries and 196 dense steps at 1e-8);
//! back-off without skipping (10 987M all three against 11 202M, but 11 502M with
//! 8 iterations), capped at 1 or 3 steps (11 228M with 8 iterations, 11 217M), 8 or 6
//! iterations (11 077M, 11 874M): within the chaos, so both are left as they were.
//! Handing the dense path the failed try's impulses as its warm start (through the
//! contact warm start) left its work unchanged (149 → 160 iterations, 14.7 → 14.8
//! alternations per dense step).
//!
//! An inactive friction or boxed row whose `w` is off zero enters where the natural
//! map puts it, `mid(lo, z − w, hi)` at `z = 0` (Hintermüller, Ito and Kunisch's
//! primal–dual active set): at a bound where `−w` passes it, free only within; it used
//! to enter free. Free, a sliding foot's friction row took an impulse beyond `μ z_n`
//! that pulled its normal negative; the normal left, the friction with it, and the set
//! came back two iterations later (the cycles of issue 13's cheetahs). Measured (2 s,
//! `simulate MODEL --duration 2 [--ctrl target/models/work/SUITE_NAME.ctrl.csv]`,
//! callgrind `--toggle-collect='constraint_articulated::world::World::step'`):
//! gymnasium's half_cheetah controlled 46.15M → 43.88M instructions (failed tries 7 →
//! 0), dm_control's cheetah controlled 53.44M → 48.41M (failed 18 → 7), hopper passive
//! 73.53M → 73.12M, controlled 85.94M → 83.73M (failed 13 → 10); humanoid 1 s 205.18M
//! both, humanoid_CMU 0.5 s 411.36M both. The rule at a bound whose `w` turned
//! against it (go to the other bound where `z − w` passes it, not free) was tried with
//! it and changed no try on these runs, so it is left as it was.
//!
//! What still fails there (same runs, with the rule): dm_control's cheetah 7 tries (6
//! cycles, 1 not settled), hopper controlled 10 (5 a dependent one-sided row, 3
//! cycles, 2 not settled), passive 6. They are not near-solutions: the best iterate's
//! natural-map residual was 5.6e-3 to 1.0 (cheetah) and 6.4e-7 to 1.0e-1 (hopper, one
//! try below 1e-6), so ending a failed try on an acceptable iterate would take one
//! try of seventeen. A cheetah cycle of one contact (normal and two friction rows): the
//! friction row goes to its bound `μ z_n` from the last normal, which pulls the normal
//! negative; the normal leaves, the bound falls to zero, and the first set returns.
//! Tried and left out: holding such a normal active for one bounds' fixed point
//! (`World::extrapolate_bounds`) instead of letting it leave (cheetah controlled
//! 48.41M → 47.53M, but half_cheetah 43.88M → 43.95M, hopper passive 73.12M → 73.26M,
//! controlled 83.73M → 83.96M, humanoid 205.18M → 205.33M, humanoid_CMU 411.36M →
//! 411.52M: the per-iteration scan for such normals costs more than the tries it
//! saves, outside the cheetah; deciding the hold only where a normal leaves, from the
//! two tangent rows after it, measured the same: 47.51M, 43.93M, 73.22M, 83.88M,
//! 205.29M, 411.51M, the hopper and humanoid trajectories unchanged). dm hopper's
//! remaining cost is per iteration, spread (2 s passive, 400 steps, about 880
//! iterations, 515 factors, 1 623 factor solves:
//! `RowTree::solve` 7.1M, `factor` 6.5M, `assemble` 3.7M, `forward_marked` 3.2M, the
//! active set's own loops and Schur rows 9.0M of 34.1M), with no single hot spot.
//!
//! Counted again (issue 13, the same run, callgrind call counts): 391 steps try the
//! active set; 641 iterations reach the factor solve, over about 14 rows each (8 907
//! row gathers); 515 factors (1.3 a step: the first of each step, the matrix having
//! moved, and 124 for a changed set); 497 builds of the Schur columns, 3.9 rows on
//! average (1 922 forward passes over their paths); 802 Schur corrections (641 in the
//! iterations, 161 in `World::extrapolate_bounds`), each a whole factor solve: 3.5M of
//! `RowTree::solve`'s 7.1M. Tried and left out: the correction's forward pass taken
//! from the Schur columns' (the pass is linear: `Σ_c ζ_c s_c` on their paths, rows of
//! one path summed contiguously first, then the backward pass alone). It changes bits
//! (round-off: the summaries' figures move in their 13th digit) and measured
//! half_cheetah 43.39M → 42.98M, dm cheetah 47.63M → 47.13M, but dm hopper 72.43M →
//! 72.76M (the path values of its Schur rows, summed, cost about the forward pass they
//! replace), swimmer6 121.84M → 121.72M, pusher 49.50M → 49.42M: too little for a
//! change of bits.
//!
//! Where dm hopper's cost at rest goes (issue 13, 2 s passive, 400 steps, lying on the
//! floor: 5 contacts, 3 limits, 19 rows; callgrind call counts and a count of each
//! try's path): `World::step` 153K instructions a step, the active set 77.9K a try
//! (390 tries; counted before the extrapolation's update below). The warm start holds:
//! 244 tries end on their first iterate, 115 need a second (friction rows at `μ z_n`
//! whose normal moved since the last step: one bounds' extrapolation, then the
//! checking iterate), 26 more; 5 failed (3 a
//! dependent one-sided row, 1 cycle, 1 not settled) and 1 step was skipped, and those
//! 6 dense steps cost 336K each (2.0M, 3 % of the run). Per try: the factor of the
//! augmented tree 23.5K (1.28 factors: the first, the matrix having moved, then one
//! per changed set; `RowTree::assemble` and `factor`), the Schur rows 23.8K (3.7 rows
//! per build: the foot's and calf's contacts beyond the one row their hinge leaves
//! free: their forward passes 7.7K, `S` and its own loops 11K, [`PsdFactor`] 2K),
//! 4.1 factor solves 17.4K (per iterate the solve and the Schur correction, two per
//! normal in the extrapolation), the rows' gathers, residuals and updates the rest.
//! So a try that ends on its first iterate still pays one factor, one build of the
//! Schur rows and two solves: the base cost is the pipeline, not repeated work. The
//! same count on the other small models (2 s, tries ending on their first iterate /
//! second / failed): dm hopper perturbed 228/112/12, controlled 94/211/10, walker
//! passive 799/1/0, perturbed 589/161/9, controlled 280/379/3, stacker 1703/19/1,
//! 1689/109/4, 1704/33/1 (20.4 Schur rows per build perturbed: the boxes' contacts
//! with each other), manipulator 1772/34/4, 1787/35/7, 1768/57/4.
//!
//! Friction entering with its normal (issue 13): a normal that enters at iteration `k`
//! had its friction rows held inactive (their bounds `±μ z_n` zero while `z_n = 0`),
//! to enter only at `k + 1`. They now enter with it, at the bound `−w` points to
//! (where `|w| > tol_w`). Measured (`instr34`, callgrind `--toggle-collect` on
//! `World::step`, 2 s; against the base 7a31e40): half_cheetah controlled 35.61M →
//! 35.58M, dm cheetah controlled 38.03M → 37.06M, dm hopper passive 58.77M → 54.32M,
//! walker controlled 134.44M → 131.50M, pusher unchanged; ensembles (passive,
//! controlled, root kicks `--qvel 1,0,0.5,0,0,0` and `0,-1,0,1,2,0`) dm_control's
//! humanoid 1 369.9M → 1 333.4M, gymnasium's humanoid (no controlled run) 1 046.9M →
//! 983.4M, humanoid_CMU 0.5 s passive and controlled 611.4M → 604.9M. The gain is
//! in failed tries (dense steps), not iterations: failed tries dm cheetah 6 → 4,
//! walker 5 → 0, hopper passive 3 → 1, controlled 11 → 3, gymnasium's humanoid
//! passive 13 → 8, kicked 16 → 5, humanoid_CMU controlled 23 → 16; iterations per
//! settled try about the same (half_cheetah 1.77 → 1.79, dm cheetah 1.62 → 1.66,
//! hopper 1.19 → 1.21). The summaries (`simulate --summary`: joint separation,
//! penetration, settled penetration, energy, root height) agree to 3–4 digits on
//! the small models and within the humanoids' chaos. Tried and left out: entering
//! free (sticking) instead of at a bound: half_cheetah 37.22M, dm cheetah 41.21M,
//! dm humanoid passive 365.7M, controlled 354.9M (a sliding row entered free goes to
//! its bound an iteration later, a change of the factor's rows, where one entered at
//! its bound is no factor row).
//!
//! The Schur rows' bookkeeping (issue 13, dm_control's humanoid perturbed, 2 s, 400
//! steps, callgrind `--toggle-collect` on `World::step`, main d600c41: 537.5M, of
//! which 233.6M in 334 tries). The build of `S` ([`World::schur_columns`]) was
//! 113.4M in 768 builds (a build follows every new factor of `H_A` with Schur rows
//! not yet held; 14.9 rows, 7.4 distinct paths, 128 path nodes and 824 path values
//! a build on average, 235 builds rank-deficient at `d` 9 to 28): `S`'s factor
//! 29.6M, the forward passes 23.1M, the products `u_a s_b` 14.3M, and 46M of
//! bookkeeping around them, mostly per path node and per pair of rows. Cut with the
//! same bits (the same operations in the same order; the 13 reference runs
//! `cmp`-equal): the forward pass walks the path's elimination steps
//! ([`RowTree::forward_steps`], the steps and length once per distinct path) instead
//! of testing a mark at every node; a path's values are taken in one call whose
//! slices are known apart (inlined, the compiler checked them for overlap at every
//! node), into arenas that only grow; the shared nodes of a pair of paths are found
//! once per pair met; a row's free scale once per step; `S`'s Cholesky update and
//! Householder step in functions of their own (no overlap check per row), the
//! Householder vectors kept contiguous for [`PsdFactor::reflect`]. The same run:
//! 537.5M → 515.9M (tries 233.6M → 211.9M); humanoid_CMU perturbed 0.5 s 210.3M →
//! 208.6M, gymnasium's humanoid perturbed 381.9M → 372.0M, humanoidstandup 446.2M →
//! 424.6M; the 13 runs of `instr34`: dm humanoid passive −4.3 %, controlled −1.0 %,
//! gymnasium's humanoid passive −2.8 %, humanoid_CMU passive −1.5 %, controlled
//! −0.3 %, dm hopper −0.4 %, the others within +0.15 % (swimmer6 +0.12 %, pusher
//! +0.15 %: paths of few, small nodes, where the per-node call costs about what the
//! inlined copies did). Tried and left out: the pairs of rows in blocks per pair of
//! paths (517.2M → 517.4M), the row-wise Householder step from 1 column on instead
//! of 4 (516.0M → 516.1M), the path values inlined (520.7M: the overlap checks
//! return). What is left is arithmetic (the products, `S`'s factor, the forward
//! passes) or per build: any change of a factor row changes the root's block, on
//! every Schur row's path, so no build can reuse the last one's columns whole.
//! Tried and left out (issue 13, this session): a row's forward-pass values kept
//! across builds of one step where the factor kept the nodes (`RowTree`'s reuse
//! test: the node and every node below it kept their rows; the same bits, the 13
//! reference runs `cmp`-equal), the kept nodes' values put back and only their
//! update of a recomputed parent sent: dm humanoid 2 s passive, 2 121 of 9 025 row
//! passes reused, but `forward_steps` 19.24M → 15.09M + 4.15M for the reusing pass
//! (few path nodes are kept: a change at a foot recomputes its leg to the root), and
//! `World::step` 338.65M → 340.61M (dm humanoid controlled 309.09M → 310.62M, dm
//! hopper 58.77M → 59.02M, half_cheetah 35.61M → 35.68M, humanoid_CMU controlled
//! 393.28M → 392.87M). Line counts of the same run (a build with line tables): the
//! products `u_a s_b` 10M of the 51M the Schur rows' own code costs over 497 builds
//! (18.6 rows, 183 pairs a build), the rest spread over the builds' loops.
//!
//! The active set's own cost (issue 13, main 9d8e62a, dm humanoid 2 s passive,
//! `World::step` 328.2M instructions, `active_set_solve`'s own code 64.5M; its lines
//! by the inlined frames of each instruction, `addr2line -i` on a build with line
//! tables): `S`'s products 16.4M (3.6M products in 90K pairs, 17 instructions per
//! four), the Schur build's bookkeeping 16.2M, [`PsdFactor::factor`] 9.2M, and
//! `RowTree::assemble` 7.4M (inlined here, counted as ours). Reuse across the builds
//! of one step does not pay: of 503 builds one had the factor of the build before,
//! 11 % of the rows' path values were bit-equal to their last build's, and 4 % of the
//! products were of two such rows (a change at a foot reaches the root, on every
//! path). Cut with the same bits (13 reference runs `cmp`-equal): rows on the bodies
//! of the row before take its path without a walk or search; `S_ab` by runs of rows
//! on one path, up to four rows `a` against one `b` in vector lanes ([`products`]);
//! small loops of [`PsdFactor::factor`] without index checks; the Schur rows' values
//! gathered once per iteration. `World::step`, main → this (`instr34`, 2 s;
//! humanoid_CMU 0.5 s): dm humanoid passive 328.19M → 317.34M (−3.3 %), controlled
//! 300.22M → 299.91M, gymnasium's humanoid passive 279.81M → 276.87M (−1.1 %),
//! humanoid_CMU passive 213.75M → 212.53M, controlled 379.80M → 379.54M, dm hopper
//! 53.16M → 53.05M, walker controlled 127.92M → 127.82M, the other six within
//! −0.12 % to +0.002 %.
//! Tried and left out: a kernel of two rows (as many instructions a product as one
//! row's, and a call); `u = s / d⁻¹` in one run over a row with the path's `d⁻¹`
//! gathered once (317.57M → 324.18M: the per-node copy became `memcpy` and `memset`
//! calls).
//!
//! Where the humanoids' steps go (issue 13, main 5f05998; callgrind `World::step`
//! instructions, `simulate` 2 s, humanoid_CMU 0.5 s; tries, iterations and dense
//! steps from [`super::UnilateralStats`] per step). dm humanoid passive 319.6M: the
//! active set 184.2M in 357 tries (347 settled, 1.36 iterations each), of which the
//! Schur rows 99.4M (589 builds of about 17 rows: a foot's contacts beyond its
//! ankle's two freedoms, a welded head or hand's) and the tree factor 26.6M (580
//! factors); the dense path 21.7M in 14 steps; the position projection 60.9M, the
//! assembly 25.9M, contact generation 9.5M. Controlled 290.3M: active set 126.5M
//! (378 settled, 2.44 iterations; Schur rows 51.5M), dense 8.5M in 11 steps,
//! projection 98.9M. Perturbed 423.8M: active set 220.1M (307 of 332 tries settled,
//! 1.93 iterations; Schur rows 122.1M in 848 builds), dense 95.3M in 57 steps (1.67M
//! each: the Delassus matrix 28.5M, the staggered solve 63.5M), projection 48.6M.
//! The failed tries: passive 10 (9 not settled, 1 repeated release), controlled 11 (7
//! cycles, 4 not settled), perturbed 25 (17 not settled, 4 cycles, 4 repeated
//! releases); what still runs to the cap is the friction rows of two or three sliding
//! contacts moving between their bounds and free with no set repeating, the normals
//! moving with them. humanoid_CMU passive 208.7M: every try settles (250, 1.10
//! iterations, no dense step); the active set 72.2M (Schur rows 30.8M, factor
//! 18.9M), the rest the per-step pipeline: projection 68.1M, assembly 36.7M, contact
//! generation 20.0M (twice a step, at the start and for the projection). Controlled
//! 350.2M: active set 127.4M (229 of 239 tries settled, 1.60 iterations), dense 43.0M
//! in 21 steps, projection 104.0M. So humanoid_CMU passive's larger ratio to MuJoCo
//! (4.4× against 2.3× controlled) is the fixed cost of a step at rest (projection,
//! assembly, contacts: 60 % of it), not the active set's iterations.
//!
//! Profiled again (issue 13, main 7bcef91, callgrind `--toggle-collect` on
//! `World::step`, inclusive): humanoid_CMU 0.5 s passive 195.4M: the active set 67.7M
//! (Schur rows 28.4M, the tree factor 17.7M), the projection 65.4M (its factor solves
//! 21.1M, `projection_error` 20.0M, of which the compound coordinates 10.6M), the
//! velocity level's assembly 31.0M, contact generation 20.0M in 500 calls (the sweep
//! 11M of it, framing 5.1M, narrow phase 3.9M). dm humanoid 2 s passive 290.3M: the
//! active set 168.4M (Schur rows 92.9M: 9 310 forward passes 20.5M, products 9.9M,
//! the rest bookkeeping and `S`'s factor), the dense path 22.7M, the projection
//! 52.6M, contact generation 9.5M. Perturbed 414.0M: the active set 166.8M, the dense
//! path 141.6M in 76 steps (24 failed tries, 52 skipped by the back-off; the staggered
//! solve 102.6M, [`super::unilateral`]'s Delassus build 34.8M), the projection 51.2M.
//! The failed tries (perturbed): 12 not settled, 9 cycles, 3 repeated releases;
//! controlled 11 cycles and 2 not settled of 13. The second contact generation is now
//! a Verlet list's (`contact.rs`, `NearPairs`): humanoid_CMU passive 195.36M →
//! 189.51M, the same bits. Tried and left out: the dependent release's ratio test
//! without the active rows whose impulse is already negative (they leave by the
//! status rule anyway; taken only where no other row falls): the same failures on
//! each run (perturbed 24, passive 11 → 12, controlled 13, humanoid_CMU controlled
//! 13), only their timing moved; dm humanoid perturbed 414.04M → 360.73M (52 → 8
//! skipped steps) but passive 290.35M → 298.98M, gymnasium's humanoid kicked
//! (`--qvel 1,0,0.5,0,0,0`) 340.62M → 358.09M, humanoidstandup 335.46M → 338.12M; a
//! 14-run ensemble (passive, perturbed, controlled, two kicks) −0.5 %, within the
//! chaos.
//!
//! dm stacker controlled (issue 13, lead42 at main 7bcef91 plus the Verlet list,
//! callgrind on `World::step`, inclusive, 2 s = 2 000 steps) 702.5M, 351K a step: the
//! velocity level 394.6M in 1 785 steps (the other 215 take the RATTLE step, 56.9M):
//! the active set 286.3M in 1 784 tries, 2 077 iterations, 1 897 factors (the rows'
//! factor 54.7M; its assembly, inlined in the try, 9.8M of the try's own 59M), 2 042
//! Schur solves (120.0M: 28 096 forward passes, 13.8 a solve, 28.6M, the
//! correction's solve 19.9M, the path values 7.7M, the products and bookkeeping
//! 50.6M; the tendon coupling's equality is a Schur row in every iteration), the
//! rows' solve 25.3M; the dense path 28.3M in 14 steps (2M each); the assembly 67.5M.
//! The projection 163.9M: 1 120 of 1 785 steps take one Newton iteration (the
//! joints' separation above the 1e-8 tolerance in 974, the tendon equality in 146,
//! the contacts in none), its factor solves 39.5M, `projection_error` 34.4M in 2 905
//! calls; contact generation 85.6M (the stacker's
//! mask is not swept, so nothing is listed: 45.0M at the steps' starts, 40.7M in the
//! projections). Nothing is factored twice for one set: the factor changes every step
//! with `H` (the boxes' world inertia turns), the Schur columns are kept while the
//! factor and the Schur rows are.

use alloc::vec::Vec;

use constraint_contact::lcp::RowBound;
use constraint_core::{DMat3, DVec3};

use super::unilateral::{RowSource, URow};
use super::*;
use crate::tree::NONE;
use crate::tree_rows::{ExtraRow, RowTree};

mod dependent;
mod products;

/// Iterations of the active set before the step goes to the dense path. The steps that
/// settle do so in 1–2 iterations (the odd one in about 11), and a failed try costs
/// about three dense steps, so the cap is 12 (it was 20: dm_control's humanoid, 1 s
/// passive, 815M → 783M instructions, the same trajectory to the last printed digit;
/// humanoid_CMU, 2 s passive, the same penetration, root height within 2.5e-5 m).
/// Tried and left out (issue 13, `World::step` instructions per step, 1 s passive):
/// 8 (stacker 0.756M → 0.714M, manipulator 0.556M → 0.553M, dm_control's humanoid
/// 3.12M → 3.02M, humanoid_CMU 3.93M → 3.89M), but a random limited chain of
/// `tests/active_set.rs` then needs more and goes to the dense path; 20 (stacker
/// 0.801M, manipulator 0.559M).
pub const MAX_ITERATIONS: usize = 12;

/// The active set ends on the first iterate whose natural-map residual
/// (`World::natural_residual`) is at most this fraction of the dense path's acceptance
/// (`RowSettings::friction_tolerance`, by default 1e-6, so 1e-7): an answer ten times
/// tighter than the dense path would return, without waiting for the set to settle.
const ACCEPT_FRACTION: f64 = 0.1;

/// [`near_repeat`]: the largest move of the friction bounds' normals, as a fraction
/// of the largest of them, at which a set with the statuses of an earlier one repeats it
/// (the creeping cycles measured moved 0.1 % a period; at 2 % a dm humanoid try that
/// settles ended: [`World::unilateral_set_is_new`]).
const NEAR_REPEAT: f64 = 0.01;

/// Most steps [`World::solve_unilateral_sparse`]'s back-off sends to the dense path
/// without trying the active set.
const MAX_SKIP: u32 = 15;

/// Most rows solved by their Schur complement in one iteration (dropped pivots and
/// active coupled rows together); beyond it the dense path is as cheap.
const MAX_SCHUR: usize = 48;

/// The "node" of a coupled row: a contact between two bodies, which no tree node's
/// neighbourhood holds. Active, it is solved by its Schur complement with the factor
/// of the tree rows, as a dropped pivot is (one tree solve per such row).
const COUPLED: usize = usize::MAX;

/// A row's state in the active set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum RowStatus {
    /// `z = 0`.
    Inactive,
    /// `w = 0`, `z` free (within its bounds).
    Active,
    /// `z` at its lower bound.
    Lo,
    /// `z` at its upper bound.
    Hi,
}

/// A row's identity across steps: kind (0 limit, 1 dry friction, 2 + axis contact) and
/// what names it.
type RowKey = (u8, usize, usize, u64);

/// Scratch of the active-set solve, kept across steps.
#[derive(Clone, Debug, Default)]
pub(super) struct ActiveSet {
    factor: RowTree,
    /// Per row: its tree node, status, impulse, value `w`, key.
    node: Vec<usize>,
    status: Vec<RowStatus>,
    z: Vec<f64>,
    w: Vec<f64>,
    keys: Vec<RowKey>,
    /// The active rows of the current iteration and their row indices.
    rows: Vec<ExtraRow>,
    map: Vec<usize>,
    /// The augmented unknowns.
    x: Vec<f64>,
    /// The rows solved by their Schur complement this iteration (row indices): the
    /// active rows whose pivot the factor dropped, then the active coupled rows; their
    /// factor positions (`usize::MAX` for a coupled row), their forward-pass values
    /// `s = D⁺ L⁻¹ Gᵀ` and `u = L⁻¹ Gᵀ` on their paths to the root
    /// ([`World::schur_columns`]), and the small system `S ζ = r` with its solution.
    schur: Vec<usize>,
    schur_pos: Vec<usize>,
    /// Per distinct path `p` of the Schur rows (a row's bodies and their ancestors;
    /// a foot's or a box's contact rows share one): its nodes in
    /// `path_nodes[path_start[p]..path_start[p + 1]]` (one entry more than the paths).
    /// Per Schur row `c`: its path's index `path_id[c]`, and its unknowns' `s` and `u`
    /// on the path, packed node after node, in `path_s[val_start[c]..val_start[c +
    /// 1]]`, `path_u[..]` likewise (one entry more than the rows: the end).
    path_nodes: Vec<usize>,
    path_start: Vec<usize>,
    val_start: Vec<usize>,
    path_s: Vec<f64>,
    path_u: Vec<f64>,
    path_id: Vec<usize>,
    /// Per tree node: whether it is on the path being built, and where the path at
    /// hand keeps its values (`usize::MAX`: not on it); both clear between uses.
    mark: Vec<bool>,
    node_slot: Vec<usize>,
    /// Per pair of distinct paths `(p, q)` (`g` of them), in `seg[seg_at[p · g + q]]`:
    /// the nodes of `p` on `q`, along `p`, as `(offset in p's values, offset in q's
    /// values, length)`, nodes adjacent in both merged. A row's values are laid out as
    /// its path's, so the offsets hold for every row on either path.
    seg: Vec<(usize, usize, usize)>,
    seg_at: Vec<(usize, usize)>,
    /// The Schur rows in runs of consecutive rows on one path, `(path, first row,
    /// end)`.
    runs: Vec<(usize, usize, usize)>,
    /// Per distinct path: its nodes as elimination steps ([`RowTree::forward_steps`])
    /// in `steps[s0..s1]` and its number of unknowns, `(s0, s1, len)`.
    steps: Vec<usize>,
    path_steps: Vec<(usize, usize, usize)>,
    /// Per row (one-sided, then equality) of the step: its scale without the tree,
    /// `g M⁻¹ gᵀ` ([`World::schur_free_scale`]), NaN until first needed.
    row_scale: Vec<f64>,
    /// A full-length column for one forward pass, zero between uses.
    col: Vec<f64>,
    /// `H_A⁻¹ G_Dᵀ ζ` (one factor solve), the Schur rows' correction of a solution.
    corr: Vec<f64>,
    s_mat: Vec<f64>,
    s_rhs: Vec<f64>,
    zeta: Vec<f64>,
    /// `S`'s factor ([`PsdFactor`], truncated at its floor), and whether it is
    /// current for this iteration's columns.
    s_fac: PsdFactor,
    s_ready: bool,
    /// Bound extrapolation ([`World::extrapolate_bounds`]): the normals whose
    /// friction rows are at a bound, their values before and after the solve, the
    /// responses to them and the small system.
    ex_normals: Vec<usize>,
    ex_t0: Vec<f64>,
    ex_t1: Vec<f64>,
    ex_resp: Vec<f64>,
    ex_mat: Vec<f64>,
    ex_dz: Vec<f64>,
    /// The iterate's `ζ` and, per normal, the Schur rows' response `ζ_b` (`p × d`),
    /// for the linear update of [`World::extrapolate_bounds`].
    ex_zeta0: Vec<f64>,
    ex_zeta: Vec<f64>,
    /// The factor rows (`map`) of the iteration that built `factor`, and whether it
    /// was built in this step: an iteration with the same rows reuses it.
    factor_map: Vec<usize>,
    factor_current: bool,
    /// The Schur rows whose path values and factor of `S` (`s_fac`) were built on the
    /// current factor; `y_current` says
    /// they are valid (cleared when the factor is rebuilt).
    y_schur: Vec<usize>,
    y_current: bool,
    /// Fingerprints of the sets met in this step's iterations (cycle detection); per
    /// set, the fingerprint of its statuses alone and the impulses at the time
    /// (`m` a set, in `near_z`), for [`World::unilateral_set_is_new`]'s near repeats.
    history: Vec<u64>,
    status_history: Vec<u64>,
    near_z: Vec<f64>,
    /// This step's releases of a dependent Schur row for another ([`dependent`]), in
    /// the order made.
    released: Vec<dependent::Release>,
    /// Consecutive steps whose active set failed, and the steps still to go straight
    /// to the dense path ([`World::solve_unilateral_sparse`]'s back-off).
    failures: u32,
    skip: u32,
    /// The last step's rows in their order: key, status, impulse.
    warm: Vec<(RowKey, RowStatus, f64)>,
    /// `warm`'s indices sorted by key (built on the first lookup that misses the
    /// same-position guess; `sorted_ok` says it is current).
    sorted: Vec<usize>,
    sorted_ok: bool,
}

impl ActiveSet {
    /// The impulses the solve gives the rows it holds: `z = −x` at a factor row, `−ζ`
    /// at a coupled Schur row (of the `m` one-sided rows); other rows keep their `z`.
    fn solution_impulses(&mut self, m: usize) {
        for (k, &i) in self.map.iter().enumerate() {
            self.z[i] = -self.x[self.factor.row_position(k)];
        }
        for (c, &i) in self.schur.iter().enumerate() {
            if self.schur_pos[c] == usize::MAX && i < m {
                self.z[i] = -self.zeta[c];
            }
        }
    }
}

/// Each row's impulse by its status, in row order: zero inactive, kept active, its bound
/// at a bound (friction bounds `±μ z_n` from the normals' current impulses, rows before
/// it already updated, as the status update reads them).
fn status_impulses(urows: &[URow], st: &mut ActiveSet) {
    for (i, r) in urows.iter().enumerate() {
        st.z[i] = match st.status[i] {
            RowStatus::Inactive => 0.0,
            RowStatus::Active => st.z[i],
            RowStatus::Lo => bounds(&r.bound, &st.z).0,
            RowStatus::Hi => bounds(&r.bound, &st.z).1,
        };
    }
}

impl World {
    fn row_key(&self, r: &URow) -> RowKey {
        match r.source {
            RowSource::Limit { joint, dof, upper } => (0, joint, 2 * dof + upper as usize, 0),
            RowSource::DryFriction { joint, dof } => (1, joint, dof, 0),
            RowSource::TendonLimit { tendon, upper } => (5, tendon, upper as usize, 0),
            RowSource::Contact { contact, axis } => {
                #[cfg(feature = "contact")]
                {
                    let (a, b, id) = self.contacts[contact].key();
                    (2 + axis, a, b, id)
                }
                #[cfg(not(feature = "contact"))]
                {
                    (2 + axis, contact, 0, 0)
                }
            }
        }
    }

    /// The tree node a row joins, [`COUPLED`] for a contact between two bodies (held
    /// outside the factor, by its Schur complement), or `None` when the row cannot be
    /// taken (a tendon limit spans several joints).
    fn row_node(&self, r: &URow) -> Option<usize> {
        let s = &self.solver;
        match r.source {
            RowSource::Limit { joint, .. } | RowSource::DryFriction { joint, .. } => {
                let n = *s.joint_node.get(joint)?;
                (n != NONE).then_some(n)
            }
            // A tendon spans several joints: not a row of one node.
            RowSource::TendonLimit { .. } => None,
            RowSource::Contact { .. } => match (r.a, r.b) {
                (None, Some(i)) | (Some(i), None) if i < s.n_bodies => {
                    let p = s.parent[i];
                    Some(if p == NONE { i } else { p })
                }
                (Some(i), Some(k)) if i < s.n_bodies && k < s.n_bodies && i != k => Some(COUPLED),
                _ => None,
            },
        }
    }

    /// Solves the one-sided rows with the assembled (not yet factored) joint system by
    /// the active set; on success the solution is in `self.rhs` (the tree's layout) and
    /// the impulses in `self.uz`. `false`: not eligible or not settled, and neither
    /// `self.rhs` nor the solver was touched (the dense path follows).
    ///
    /// Back-off: after `k ≥ 3` consecutive steps whose active set failed (a contact
    /// patch whose update cycles keeps cycling while it rests: gymnasium's ant standing
    /// on four feet failed 430 of 479 steps at its 10 ms step, each after several
    /// factorizations), the next `2^(k−2) − 1` steps (at most [`MAX_SKIP`]) go to the
    /// dense path without trying; a step that settles resets the count. One or two
    /// failures in a row skip nothing.
    pub(super) fn solve_unilateral_sparse(&mut self) -> bool {
        let mut st = self.aset.take().unwrap_or_default();
        if st.skip > 0 {
            st.skip -= 1;
            self.aset = Some(st);
            return false;
        }
        let ok = self.active_set_solve(&mut st);
        if ok {
            st.failures = 0;
        } else {
            st.failures = st.failures.saturating_add(1);
            st.skip = ((1u32 << st.failures.saturating_sub(2).min(6)) - 1).min(MAX_SKIP);
        }
        self.aset = Some(st);
        ok
    }

    fn active_set_solve(&mut self, st: &mut ActiveSet) -> bool {
        let m = self.urows.len();
        st.node.clear();
        st.keys.clear();
        for r in &self.urows {
            let Some(n) = self.row_node(r) else {
                return false;
            };
            st.node.push(n);
            st.keys.push(self.row_key(r));
        }
        self.ustats.rows = m;
        self.ustats.limit_rows = self
            .urows
            .iter()
            .filter(|r| matches!(r.source, RowSource::Limit { .. }))
            .count();
        // Warm start: the last step's status and impulse of the row with the same key
        // (first guess: the same position, where the rows came in the same order), else
        // a guess from the row's target (a row asked to push apart, bias ≥ 0, starts
        // active) and z = 0.
        st.z.clear();
        st.status.clear();
        for (i, r) in self.urows.iter().enumerate() {
            let key = st.keys[i];
            let hit = match st.warm.get(i) {
                Some(w) if w.0 == key => Some(i),
                _ => {
                    if !st.sorted_ok {
                        st.sorted.clear();
                        st.sorted.extend(0..st.warm.len());
                        let warm = &st.warm;
                        st.sorted.sort_unstable_by_key(|&k| warm[k].0);
                        st.sorted_ok = true;
                    }
                    st.sorted
                        .binary_search_by(|&k| st.warm[k].0.cmp(&key))
                        .ok()
                        .map(|p| st.sorted[p])
                }
            };
            let (s, z) = match hit {
                Some(p) => (st.warm[p].1, st.warm[p].2),
                None => (
                    match r.bound {
                        RowBound::Unilateral if r.bias >= 0.0 => RowStatus::Active,
                        RowBound::Unilateral => RowStatus::Inactive,
                        RowBound::Friction { .. } => RowStatus::Inactive,
                        RowBound::Boxed { .. } => RowStatus::Active,
                    },
                    0.0,
                ),
            };
            st.status.push(s);
            st.z.push(z);
        }
        let bias_scale = (0..self.eq.len())
            .map(|e| self.eq.target(e))
            .chain(self.urows.iter().map(|r| r.bias))
            .fold(1.0f64, |s, b| s.max(b.abs()));
        let tol_w = self.unilateral.solver.tolerance * bias_scale;
        let accept = ACCEPT_FRACTION * self.unilateral.solver.friction_tolerance;
        let mut iterations = 0;
        let mut settled = false;
        // The one-sided rows' natural-map residual of the last iterate (every exit
        // that settles leaves `st.z`, `st.w` as that iterate's), for the statistics.
        let mut worst: f64 = 0.0;
        st.history.clear();
        st.status_history.clear();
        st.near_z.clear();
        st.released.clear();
        st.row_scale.clear();
        st.row_scale.resize(m + self.eq.len(), f64::NAN);
        st.factor_current = false;
        st.y_current = false;
        while iterations < MAX_ITERATIONS {
            iterations += 1;
            // Impulses of the rows off the factor (bounds from the current normals).
            status_impulses(&self.urows, st);
            st.rows.clear();
            st.map.clear();
            for (i, r) in self.urows.iter().enumerate() {
                if st.status[i] == RowStatus::Active && st.node[i] != COUPLED {
                    st.rows.push(ExtraRow {
                        node: st.node[i],
                        a: r.a,
                        b: r.b,
                        j: r.j,
                    });
                    st.map.push(i);
                }
            }
            // The factor depends on the set of active factor rows alone (their
            // Jacobians are fixed within the step): an iteration that only moved
            // bounds or impulses at a bound keeps it, and the Schur rows' columns.
            if !(st.factor_current && st.factor_map == st.map) {
                st.factor_current = false;
                st.y_current = false;
                if !st.factor.assemble(&self.solver, &st.rows)
                    || st.factor.factor(&self.solver).is_err()
                {
                    return false;
                }
                st.factor_current = true;
                st.factor_map.clear();
                st.factor_map.extend_from_slice(&st.map);
            }
            // Right-hand side: the tree's, the known impulses, the active rows' targets.
            let f = &st.factor;
            // No zero-fill: the runs cover the tree's unknowns and the loop below the
            // scatter sets every extra row's (`st.map` holds one per factor row), so
            // every entry is written before it is read.
            st.x.resize(f.size, 0.0);
            f.copy_from_tree(&self.rhs, &mut st.x);
            for (i, r) in self.urows.iter().enumerate() {
                if matches!(st.status[i], RowStatus::Lo | RowStatus::Hi) && st.z[i] != 0.0 {
                    scatter(f, &mut st.x, r, st.z[i]);
                }
            }
            for (k, &i) in st.map.iter().enumerate() {
                st.x[f.row_position(k)] = self.urows[i].bias;
            }
            f.solve(&self.solver, &mut st.x);
            if !self.schur_rows(st, tol_w) {
                return false;
            }
            st.solution_impulses(m);
            let f = &st.factor;
            let mut zmax: f64 = 0.0;
            for i in 0..m {
                zmax = zmax.max(st.z[i].abs());
            }
            // (One `extend` of the rows' map: sized once, no capacity check per row.)
            st.w.clear();
            st.w.extend(self.urows.iter().map(|r| gather(f, &st.x, r) - r.bias));
            // The first iterate within a tenth of the dense path's acceptance ends the
            // step (its set may still change by rows of |w| near the tolerance).
            let (one_sided, residual) = self.natural_residual(st, bias_scale);
            worst = one_sided;
            if residual <= accept {
                settled = true;
                break;
            }
            // Rows dependent on the others (the Schur complement's truncated directions)
            // hold only if the others imply it: for a one-sided one that does not (the
            // shortest), an active one-sided row gives way ([`dependent`]); a boxed or
            // friction one slides, to the bound against its rate.
            let mut changed = false;
            let mut short: Option<(usize, f64)> = None;
            for &i in &st.schur {
                if i >= m {
                    // An equality row the others make unreachable (a redundant row
                    // whose target disagrees): the dense path's minimum-norm solve.
                    if (self.schur_gather(f, &st.x, i) - self.schur_bias(i)).abs() > tol_w {
                        return false;
                    }
                    continue;
                }
                let w = st.w[i];
                match self.urows[i].bound {
                    RowBound::Unilateral if w < -tol_w && short.is_none_or(|(_, ws)| w < ws) => {
                        short = Some((i, w));
                    }
                    RowBound::Unilateral => {}
                    _ if w.abs() > tol_w => {
                        st.status[i] = if w < 0.0 {
                            RowStatus::Hi
                        } else {
                            RowStatus::Lo
                        };
                        changed = true;
                    }
                    _ => {}
                }
            }
            // A dependent one-sided row left short: the active row that gives way for
            // it ([`dependent`]), released; none, the dense path.
            if let Some((i, _)) = short {
                let Some(j) = self.dependent_release(st, i) else {
                    return false;
                };
                // Two dependent Schur rows trading places again from about the same
                // impulses: a cycle ([`dependent::Release::repeats`]), the dense path.
                if st.schur.contains(&j) {
                    let r = dependent::Release {
                        short: i,
                        released: j,
                        z_short: st.z[i],
                        z_released: st.z[j],
                    };
                    if st.released.iter().any(|e| r.repeats(e)) {
                        self.ustats.active_set_iterations = iterations;
                        return false;
                    }
                    st.released.push(r);
                }
                st.status[j] = RowStatus::Inactive;
                changed = true;
            }
            let tz = 1e-12 * zmax;
            let mut drift: f64 = 0.0;
            for i in 0..m {
                let (z, w) = (st.z[i], st.w[i]);
                let old = st.status[i];
                let new = match self.urows[i].bound {
                    RowBound::Unilateral => match old {
                        RowStatus::Active if z < -tz => RowStatus::Inactive,
                        RowStatus::Inactive if w < -tol_w => RowStatus::Active,
                        s => s,
                    },
                    b => {
                        let (lo, hi) = bounds(&b, &st.z);
                        if lo == 0.0 && hi == 0.0 {
                            // A friction row whose normal enters now (active, no
                            // impulse yet: its bounds ±μ z_n are still zero) enters
                            // with it where it is off zero, at the bound that `−w`
                            // points to (the natural map's choice once the bounds
                            // open); its impulse follows the normal's (the bounds'
                            // drift and extrapolation), and it comes back free where
                            // `w` turns against the bound. It waited an iteration
                            // before, inactive until the normal had an impulse.
                            let entering = match b {
                                RowBound::Friction { normal, .. } => {
                                    st.status.get(normal) == Some(&RowStatus::Active)
                                        && st.z.get(normal) == Some(&0.0)
                                }
                                _ => false,
                            };
                            if entering && old == RowStatus::Inactive && w.abs() > tol_w {
                                if w < 0.0 {
                                    RowStatus::Hi
                                } else {
                                    RowStatus::Lo
                                }
                            } else {
                                RowStatus::Inactive
                            }
                        } else {
                            match old {
                                RowStatus::Active if z > hi + tz => RowStatus::Hi,
                                RowStatus::Active if z < lo - tz => RowStatus::Lo,
                                RowStatus::Hi if w > tol_w => RowStatus::Active,
                                RowStatus::Lo if w < -tol_w => RowStatus::Active,
                                // z = 0 inside the bounds holds while w = 0; else the
                                // natural map's choice, `mid(lo, z − w, hi)` with
                                // z = 0: a bound where −w passes it, free within.
                                RowStatus::Inactive if w.abs() > tol_w => {
                                    if -w < lo {
                                        RowStatus::Lo
                                    } else if -w > hi {
                                        RowStatus::Hi
                                    } else {
                                        RowStatus::Active
                                    }
                                }
                                s => {
                                    // A bound that moved with its normal.
                                    let target = match s {
                                        RowStatus::Hi => hi,
                                        RowStatus::Lo => lo,
                                        _ => z,
                                    };
                                    drift = drift.max((target - z).abs());
                                    s
                                }
                            }
                        }
                    }
                };
                if new != old {
                    st.status[i] = new;
                    changed = true;
                }
            }
            if changed && !self.unilateral_set_is_new(st) {
                // A set met before in this step: the update cycles (an ant's four
                // feet, two diagonal pairs in turn) and will not settle.
                self.ustats.active_set_iterations = iterations;
                return false;
            }
            if !changed && drift <= 1e-11 * zmax {
                settled = true;
                break;
            }
            if !changed {
                // Same set, bounds still moving with their normals: jump to the
                // bounds' fixed point for this set.
                if self.extrapolate_bounds(st) {
                    // The iterate moved along the responses to the new normals (the
                    // set unchanged, the system linear in the bounds): its residual
                    // decides whether the checking iterate is needed.
                    self.iterate_values(st);
                    let (one_sided, residual) = self.natural_residual(st, bias_scale);
                    worst = one_sided;
                    if residual <= accept {
                        settled = true;
                        break;
                    }
                    for (a, &n) in st.ex_normals.iter().enumerate() {
                        st.z[n] = st.ex_dz[a];
                    }
                }
            }
        }
        self.ustats.active_set_iterations = iterations;
        if !settled {
            return false;
        }
        // The solution in the tree's layout, the impulses, the statistics.
        let f = &st.factor;
        f.copy_to_tree(&st.x, &mut self.rhs);
        self.mu.clear();
        self.uz.clear();
        self.uz.extend_from_slice(&st.z);
        // The equality multipliers ν = ζ of their Schur rows (x = x_A − Y ζ, as the
        // dense complement's x = x_free − Y_E ν); zero where the others held them.
        let ne = self.eq.len();
        if ne > 0 {
            let (schur, zeta) = (&st.schur, &st.zeta);
            self.eq.set_impulses((0..ne).map(|e| {
                schur
                    .iter()
                    .position(|&i| i == m + e)
                    .map_or(0.0, |c| zeta.get(c).copied().unwrap_or(0.0))
            }));
        }
        self.ustats.sparse = true;
        self.ustats.solver.iterations = iterations;
        self.ustats.residual = worst / bias_scale;
        remember(st, &self.uz);
        true
    }

    /// The iterate's impulses and row values from `st.x` and `st.zeta`: `z = −x` at a
    /// factor row, `−ζ` at a coupled Schur row, the bound at a bound (from the
    /// iterate's normals), zero inactive; `w = G x − bias`.
    fn iterate_values(&self, st: &mut ActiveSet) {
        let m = self.urows.len();
        st.solution_impulses(m);
        status_impulses(&self.urows, st);
        let f = &st.factor;
        st.w.clear();
        st.w.extend(self.urows.iter().map(|r| gather(f, &st.x, r) - r.bias));
    }

    /// The natural-map residual of the current iterate (`st.z`, `st.w`, `st.x`), the
    /// dense path's measure ([`constraint_contact::lcp::row_residual`]):
    /// `max_i |z_i − mid(lo_i, z_i − w_i, hi_i)|` over the one-sided rows (friction
    /// bounds `±μ z_n` at the iterate's normals), and `|E x − r_E|` over the equality
    /// rows, relative to `bias_scale`. Zero exactly at a solution; an iterate that
    /// leaves the set to change by rows of `|w|` near the tolerance still has it small.
    /// Returns the one-sided rows' maximum (absolute, for the step's statistics) and
    /// the whole measure.
    fn natural_residual(&self, st: &ActiveSet, bias_scale: f64) -> (f64, f64) {
        let m = self.urows.len();
        let mut worst: f64 = 0.0;
        for i in 0..m {
            let (lo, hi) = bounds(&self.urows[i].bound, &st.z);
            let (z, w) = (st.z[i], st.w[i]);
            worst = worst.max((z - (z - w).min(hi).max(lo)).abs());
        }
        let one_sided = worst;
        for e in 0..self.eq.len() {
            let r = self.schur_gather(&st.factor, &st.x, m + e) - self.schur_bias(m + e);
            worst = worst.max(r.abs());
        }
        (one_sided, worst / bias_scale)
    }

    /// The staggered friction bounds' fixed point for the current set. With the
    /// statuses held, the normals `t` the solve returns depend affinely on the normals
    /// `t₀` the bounds `±μ t₀` of the friction rows at a bound were taken from:
    /// `t = t₁ + D (t₀' − t₀)`, `D` the normals' response to those friction rows'
    /// impulses (one factor solve per normal, through the Schur rows). The fixed
    /// point `(I − D) t = t₁ − D t₀` replaces the linear convergence of the plain
    /// iteration (factor 0.9 per iteration on a humanoid lying on the floor, where
    /// `1e-11` took hundreds of iterations) by one small solve. The set held, the
    /// solution is affine in the normals, so the iterate moves along the responses
    /// already solved for `D` (`x += Σ_b x_b (t_b − t₀_b)`, `ζ` likewise) and
    /// `true` is returned: the caller ends the step on it when its natural residual
    /// is acceptable (as on any iterate), else the normals are set to the fixed point
    /// for the next iteration, which checks it like any other. The checking iterate
    /// this replaces (a solve, the Schur rows' right-hand side and correction) was
    /// the second iteration of 115 of dm hopper's 390 tries at rest (2 s passive) and
    /// 211 of 400 controlled. Measured (issue 13, `World::step` instructions per step,
    /// 2 s; the step's bits change by round-off): dm hopper passive 153.4K → 151.0K,
    /// perturbed 174.9K → 172.1K, controlled 176.4K → 169.4K; walker 130.0K, 208.6K,
    /// 177.6K → 130.2K, 205.0K, 170.9K; stacker 245.0K, 388.5K, 395.6K → 245.7K,
    /// 297.5K, 395.0K (perturbed: tries that crept through iterations of 20 Schur
    /// rows now end, and its 3 unconverged steps are gone); manipulator 229.6K,
    /// 276.6K, 334.4K → 229.6K, 274.7K, 334.8K. Does nothing (`false`) when no normal
    /// qualifies, the Schur rows' solve is not current, or the small system is
    /// singular or gives a negative normal.
    ///
    /// A bound of zero (`t₀ = 0`: a normal that entered in the last iteration, whose
    /// friction rows came in at their bounds `±μ · 0`, or one clipped at zero) is taken
    /// too: the friction impulses are `±μ max(t₀, 0)` exactly, so the solve is as affine
    /// in `t₀` there as anywhere. It used to be refused, and the entering normal's
    /// bounds then crept by one plain iteration before the fixed point. Measured
    /// (`instr34`, 2 s, `World::step` instructions; iterations = `schur_rows` calls):
    /// half_cheetah controlled 34.28M → 34.02M (300 → 279 iterations in 168 tries),
    /// dm cheetah controlled 35.80M → 35.09M (327 → 312, dense steps 5 → 1), walker
    /// controlled 126.64M → 126.23M (1 075 → 1 045), dm hopper passive 53.02M → 53.07M
    /// (479 → 475), dm humanoid controlled 303.9M → 290.4M (1 100 → 1 013, dense steps
    /// 19 → 11). Tried with it and left out: holding a normal that its own friction
    /// pulled negative (friction to its bound `±μ · 0` instead of both leaving):
    /// iterations half_cheetah 279 → 268, dm cheetah 312 → 311, but hopper passive 475
    /// → 480, controlled 615 → 631, walker 1 045 → 1 062.
    fn extrapolate_bounds(&self, st: &mut ActiveSet) -> bool {
        let m = self.urows.len();
        let at_bound = |s: RowStatus| matches!(s, RowStatus::Lo | RowStatus::Hi);
        st.ex_normals.clear();
        st.ex_t0.clear();
        for i in 0..m {
            if !at_bound(st.status[i]) {
                continue;
            }
            if let RowBound::Friction { normal, mu } = self.urows[i].bound {
                if mu > 0.0
                    && st.status.get(normal) == Some(&RowStatus::Active)
                    && !st.ex_normals.contains(&normal)
                {
                    st.ex_normals.push(normal);
                    st.ex_t0.push(st.z[i].abs() / mu);
                }
            }
        }
        let p = st.ex_normals.len();
        if p == 0 || p > MAX_SCHUR || (!st.schur.is_empty() && !st.s_ready) {
            return false;
        }
        // `t₀ ≥ 0` always (`|z| / μ`); `!(… ≥ 0)` refuses a NaN.
        if st.ex_t0.iter().any(|t| !(*t >= 0.0)) {
            return false;
        }
        st.ex_zeta0.clear();
        st.ex_zeta0.extend_from_slice(&st.zeta);
        st.ex_zeta.clear();
        st.ex_t1.clear();
        for &n in &st.ex_normals {
            st.ex_t1.push(st.z[n]);
        }
        let f = &st.factor;
        let size = f.size;
        let d = st.schur.len();
        st.ex_resp.clear();
        st.ex_resp.resize(p * size, 0.0);
        st.ex_mat.clear();
        st.ex_mat.resize(p * p, 0.0);
        for b in 0..p {
            let col = &mut st.ex_resp[b * size..(b + 1) * size];
            for i in 0..m {
                if let (true, RowBound::Friction { normal, mu }) =
                    (at_bound(st.status[i]), self.urows[i].bound)
                {
                    if normal == st.ex_normals[b] {
                        let sign = if st.status[i] == RowStatus::Hi {
                            1.0
                        } else {
                            -1.0
                        };
                        scatter(f, col, &self.urows[i], sign * mu);
                    }
                }
            }
            f.solve(&self.solver, col);
            if d > 0 {
                st.s_rhs.clear();
                for &i in &st.schur {
                    st.s_rhs.push(self.schur_gather(f, col, i));
                }
                if !st.s_fac.apply(&st.s_rhs, &mut st.zeta) {
                    return false;
                }
                self.schur_correction(f, &st.schur, &st.zeta, &mut st.corr);
                for (x, y) in col.iter_mut().zip(&st.corr) {
                    *x -= y;
                }
                st.ex_zeta.extend_from_slice(&st.zeta);
            }
            // The normals' response: −x at a factor row, −ζ at a Schur row.
            for (a, &n) in st.ex_normals.iter().enumerate() {
                let dz = if let Some(c) = st.schur.iter().position(|&i| i == n) {
                    -st.zeta[c]
                } else if let Some(k) = st.map.iter().position(|&i| i == n) {
                    -col[f.row_position(k)]
                } else {
                    0.0
                };
                st.ex_mat[a * p + b] = dz;
            }
        }
        // (I − D) t = t₁ − D t₀.
        st.ex_dz.clear();
        for a in 0..p {
            let mut r = st.ex_t1[a];
            for b in 0..p {
                r -= st.ex_mat[a * p + b] * st.ex_t0[b];
            }
            st.ex_dz.push(r);
        }
        for a in 0..p {
            for b in 0..p {
                let v = -st.ex_mat[a * p + b] + if a == b { 1.0 } else { 0.0 };
                st.ex_mat[a * p + b] = v;
            }
        }
        if !small_solve(&mut st.ex_mat, &mut st.ex_dz, p) || st.ex_dz.iter().any(|t| *t < 0.0) {
            return false;
        }
        for (a, &n) in st.ex_normals.iter().enumerate() {
            st.z[n] = st.ex_dz[a];
        }
        // The iterate at the new normals: x += Σ_b x_b (t_b − t₀_b), ζ likewise (the
        // responses `x_b` in `ex_resp`, `ζ_b` in `ex_zeta`).
        st.zeta.clear();
        st.zeta.extend_from_slice(&st.ex_zeta0);
        for b in 0..p {
            let dt = st.ex_dz[b] - st.ex_t0[b];
            let col = &st.ex_resp[b * size..(b + 1) * size];
            for (x, c) in st.x.iter_mut().zip(col) {
                *x += c * dt;
            }
            if d > 0 {
                for (z, c) in st.zeta.iter_mut().zip(&st.ex_zeta[b * d..(b + 1) * d]) {
                    *z += c * dt;
                }
            }
        }
        for (c, &pos) in st.schur_pos.iter().enumerate() {
            if pos != usize::MAX {
                st.x[pos] = st.zeta[c];
            }
        }
        true
    }

    /// Whether the next iteration's input is one met before in this step: the
    /// statuses and the normals the bounds of the friction rows at a bound come from
    /// (the iteration is a function of these alone, so a repeat is a cycle that will
    /// not settle). By a 64-bit FNV-1a fingerprint (a collision only sends the step
    /// to the dense path); records it. Also `false` on a near repeat ([`near_repeat`]):
    /// the statuses of an earlier set (a fingerprint of them alone) with those normals
    /// within [`NEAR_REPEAT`] of their values then, a cycle whose normals creep.
    ///
    /// Measured (issue 13, main 5f05998; dm humanoid perturbed 2 s at the
    /// `--qpos`/`--qvel` of `target/models/work/mujoco.tsv`): a try at step 248 repeats
    /// a period-3 pattern (two contacts of one foot and a hand's contact entering and
    /// leaving in turn, the normals' impulses moving 0.1 % a period) to the iteration
    /// cap; of the 17 tries that ran to the cap, 5 now end at a near repeat (at
    /// iterations 5, 5, 8, 12, 12), 254 → 236 iterations in failed tries (dm humanoid
    /// passive 116 → 104); `World::step` instructions 423.82M → 419.02M, passive
    /// 319.58M → 317.23M, the other humanoid runs of `instr41` within ±0.04 %. A failed try leaves the step to the dense path unchanged, so only tries
    /// that would have failed anyway may end earlier: at 1 % the 16 reference runs and
    /// dm humanoid perturbed are `cmp`-equal; 2 % and 5 % changed dm humanoid controlled
    /// (and at 5 % gymnasium's humanoid): a try there settles after a near repeat.
    fn unilateral_set_is_new(&self, st: &mut ActiveSet) -> bool {
        const PRIME: u64 = 0x0000_0100_0000_01b3;
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut hs = h;
        for (i, s) in st.status.iter().enumerate() {
            h = (h ^ *s as u64).wrapping_mul(PRIME);
            hs = (hs ^ *s as u64).wrapping_mul(PRIME);
            if let (RowStatus::Lo | RowStatus::Hi, RowBound::Friction { normal, .. }) =
                (s, self.urows[i].bound)
            {
                h = (h ^ st.z.get(normal).map_or(0, |z| z.to_bits())).wrapping_mul(PRIME);
            }
        }
        if st.history.contains(&h) {
            return false;
        }
        let m = st.status.len();
        for (e, _) in st
            .status_history
            .iter()
            .enumerate()
            .filter(|(_, &g)| g == hs)
        {
            let Some(earlier) = st.near_z.get(e * m..(e + 1) * m) else {
                continue;
            };
            if near_repeat(&self.urows, &st.status, &st.z, earlier) {
                return false;
            }
        }
        st.history.push(h);
        st.status_history.push(hs);
        st.near_z.extend_from_slice(&st.z[..m]);
        true
    }

    /// The rows solved by their Schur complement with the factor of the other active
    /// rows, `H_A`: the active rows whose pivot the tree factor dropped, and the active
    /// coupled rows (contacts between two bodies, [`COUPLED`]). A dropped row is a row
    /// of a node beyond the rank its child's unknowns give it (a foot's contacts under
    /// its hinge, more rows than the foot has freedoms): not dependent in the whole
    /// system, only in the subtree below it. Both kinds are solved as loop rows are
    /// ([`crate::tree`]): with `S = G_D H_A⁻¹ G_Dᵀ` ([`Self::schur_columns`]: one
    /// forward pass of the factor without them per row, on the row's paths to the
    /// root), `S ζ_D = G_D x_A − bias_D` for the minimum-norm `ζ_D`
    /// ([`PsdFactor`]: pivots below `1e-10 ×` the rows' scale without joints,
    /// `max g M⁻¹ gᵀ`, or of the largest diagonal, are truncated: those directions are
    /// dependent and `ζ` has no part along them),
    /// then `x = x_A − H_A⁻¹ G_Dᵀ ζ_D` (one factor solve), and the rows' impulses are
    /// `z = −ζ`; skipped when the
    /// other rows already hold every one of them (`|w| ≤ tol_w`). `false` when the small
    /// solve fails or there are too many such rows (more than [`MAX_SCHUR`]: the dense
    /// path is as cheap).
    fn schur_rows(&self, st: &mut ActiveSet, tol_w: f64) -> bool {
        st.schur.clear();
        st.schur_pos.clear();
        let f = &st.factor;
        for (k, &i) in st.map.iter().enumerate() {
            if f.dropped(f.row_position(k)) {
                st.schur.push(i);
                st.schur_pos.push(f.row_position(k));
            }
        }
        for i in 0..st.status.len() {
            if st.status[i] == RowStatus::Active && st.node[i] == COUPLED {
                st.schur.push(i);
                st.schur_pos.push(usize::MAX);
            }
        }
        // The equality rows, always active (two-sided, never dropped): row `m + e`.
        let m = self.urows.len();
        for e in 0..self.eq.len() {
            st.schur.push(m + e);
            st.schur_pos.push(usize::MAX);
        }
        let d = st.schur.len();
        st.s_ready = false;
        st.zeta.clear();
        st.zeta.resize(d, 0.0);
        // The rows' values `G_D x_A − bias_D` (the right-hand side of `S ζ = r`,
        // gathered once: `st.x` is not touched until the correction). Rows the others
        // already hold (|w| ≤ tol) need nothing more.
        st.s_rhs.clear();
        for &i in &st.schur {
            st.s_rhs
                .push(self.schur_gather(f, &st.x, i) - self.schur_bias(i));
        }
        if st.s_rhs.iter().all(|w| w.abs() <= tol_w) {
            return true;
        }
        if d > MAX_SCHUR {
            return false;
        }
        if !(st.y_current && st.y_schur == st.schur) {
            st.y_current = false;
            if !self.schur_columns(st) {
                return false;
            }
            st.y_current = true;
            st.y_schur.clear();
            st.y_schur.extend_from_slice(&st.schur);
        }
        if st.s_rhs.iter().any(|v| !v.is_finite()) || !st.s_fac.apply(&st.s_rhs, &mut st.zeta) {
            return false;
        }
        st.s_ready = true;
        // x = x_A − H_A⁻¹ G_Dᵀ ζ: one factor solve.
        self.schur_correction(&st.factor, &st.schur, &st.zeta, &mut st.corr);
        for (x, y) in st.x.iter_mut().zip(&st.corr) {
            *x -= y;
        }
        for (c, &p) in st.schur_pos.iter().enumerate() {
            if p != usize::MAX {
                st.x[p] = st.zeta[c];
            }
        }
        true
    }

    /// `S = G_D H_A⁻¹ G_Dᵀ` of the Schur rows in its pivoted Cholesky factor
    /// ([`PsdFactor`]) truncated at the floor `1e-10 max g M⁻¹ gᵀ`, for
    /// [`Self::schur_rows`]; it depends on the factor and the Schur rows only, so
    /// iterations that keep both reuse it. With the factor `H_A = L D Lᵀ` (leaves
    /// first), `g H_A⁻¹ g'ᵀ = uᵀ D⁺ u'` for `u = L⁻¹ gᵀ`, and the forward pass of a row
    /// on one or two bodies touches only those bodies and their ancestors
    /// ([`RowTree::forward_steps`]): per row a pass over its paths to the root
    /// (about a quarter of a humanoid's nodes, no backward pass) instead of a whole
    /// factor solve, and `S_ab = Σ u_a s_b` over `a`'s path (`s = D⁺ u`, the pass's
    /// output; `D⁺`: zero at a dropped pivot). `false` when `S` or its factor is not
    /// finite.
    fn schur_columns(&self, st: &mut ActiveSet) -> bool {
        let f = &st.factor;
        let d = st.schur.len();
        let m = self.urows.len();
        let nodes = self.solver.parent.len();
        // `col`, `mark` and `node_slot` are left all zero / false / `usize::MAX` by
        // every call (the loops below clear what they set: the forward pass of a
        // marked node writes it and its parent, marked too), so they only grow.
        st.col.resize(f.size, 0.0);
        st.mark.resize(nodes, false);
        st.node_slot.resize(nodes, usize::MAX);
        st.path_nodes.clear();
        st.path_start.clear();
        st.path_start.push(0);
        st.val_start.clear();
        st.path_id.clear();
        st.steps.clear();
        st.path_steps.clear();
        let mut free_scale: f64 = 0.0;
        let mut inertia = FreeInertia::default();
        let mut vals = 0;
        for (c, &i) in st.schur.iter().enumerate() {
            st.val_start.push(vals);
            self.schur_scatter(f, &mut st.col, i, 1.0);
            // A one-sided row on the bodies of the row before it (a contact's normal
            // and tangents, a foot's contacts) is on that row's path: no walk and no
            // search (the walk is a function of the bodies alone).
            let same = c > 0 && i < m && {
                let h = st.schur[c - 1];
                h < m && self.urows[h].a == self.urows[i].a && self.urows[h].b == self.urows[i].b
            };
            let id = if same {
                st.path_id[c - 1]
            } else {
                let first = st.path_nodes.len();
                self.schur_path(i, &mut st.mark, &mut st.path_nodes);
                for &k in &st.path_nodes[first..] {
                    st.mark[k] = false;
                }
                let path = &st.path_nodes[first..];
                let g = st.path_steps.len();
                // (The first node, the row's body, is compared first: a slice
                // comparison of equal lengths is a `bcmp` call.)
                let rep = (0..g).position(|r| {
                    let (a, b) = (st.path_start[r], st.path_start[r + 1]);
                    st.path_nodes.get(a) == path.first() && st.path_nodes[a..b] == *path
                });
                match rep {
                    Some(r) => {
                        st.path_nodes.truncate(first);
                        r
                    }
                    None => {
                        // A new path: its nodes stay, in the elimination order (a
                        // chain to the root already is: children come first; a
                        // two-body row's second walk is merged in) and with its number
                        // of unknowns.
                        st.path_start.push(st.path_nodes.len());
                        let s0 = st.steps.len();
                        st.steps
                            .extend(st.path_nodes[first..].iter().map(|&k| f.step_of(k)));
                        insertion_sort(&mut st.steps[s0..]);
                        let len = st.path_nodes[first..].iter().map(|&k| f.node_len(k)).sum();
                        st.path_steps.push((s0, st.steps.len(), len));
                        g
                    }
                }
            };
            st.path_id.push(id);
            let (s0, s1, len) = st.path_steps[id];
            f.forward_steps(&mut st.col, &st.steps[s0..s1]);
            // Keep s and u = s / d⁻¹ on the path; leave `col` clear. The row's values
            // are sized once and written node slice by node slice (a `memcpy` call and
            // a capacity check per node and per unknown before).
            let path = &st.path_nodes[st.path_start[id]..st.path_start[id + 1]];
            // (The arenas only grow: no zero fill of what is written next.)
            let at = vals;
            vals += len;
            if st.path_s.len() < vals {
                st.path_s.resize(vals, 0.0);
                st.path_u.resize(vals, 0.0);
            }
            take_path_values(
                f,
                path,
                &mut st.col,
                &mut st.path_s[at..],
                &mut st.path_u[at..],
            );
            // The row's scale is the step's (its Jacobian and bodies are fixed in it).
            let scale = match st.row_scale.get(i) {
                Some(v) if !v.is_nan() => *v,
                _ => {
                    let v = self.schur_free_scale(i, &mut inertia);
                    if let Some(slot) = st.row_scale.get_mut(i) {
                        *slot = v;
                    }
                    v
                }
            };
            free_scale = free_scale.max(scale);
        }
        st.val_start.push(vals);
        // S_ab = Σ u_a s_b over the nodes a's path shares with b's, node after node
        // along a's path (rows on one path: every node, one contiguous run). The shared
        // nodes are found once per pair of distinct paths met (it was once per row `b`
        // and path of `a`), with `b`'s offsets in `node_slot`. Against one row `b`, the
        // rows `a ≥ b` go up to four at a time while they share a path (one walk of the
        // shared nodes, `s_b` read once for them: [`products`]). No fill: every `S_ab`
        // is written below (`a ≥ b`, both halves).
        let g = st.path_steps.len();
        st.seg.clear();
        st.seg_at.clear();
        st.seg_at.resize(g * g, (usize::MAX, 0));
        st.s_mat.resize(d * d, 0.0);
        let mut finite = true;
        // The runs of consecutive rows on one path, `(path, first row, end)`: against
        // a row `b`, the rows `a ≥ b` of a run share the nodes of `b`'s path.
        st.runs.clear();
        for (c, &p) in st.path_id.iter().enumerate() {
            match st.runs.last_mut() {
                Some(r) if r.0 == p => r.2 = c + 1,
                _ => st.runs.push((p, c, c + 1)),
            }
        }
        let mut run_b = 0;
        for b in 0..d {
            let (vb, q) = (st.val_start[b], st.path_id[b]);
            let path_b = &st.path_nodes[st.path_start[q]..st.path_start[q + 1]];
            let mut slots = false;
            while st.runs[run_b].2 <= b {
                run_b += 1;
            }
            for ri in run_b..st.runs.len() {
                let (p, r0, r1) = st.runs[ri];
                if st.seg_at[p * g + q].0 == usize::MAX {
                    if !slots {
                        let mut off = 0;
                        for &k in path_b {
                            st.node_slot[k] = off;
                            off += f.node_len(k);
                        }
                        slots = true;
                    }
                    let first = st.seg.len();
                    let mut ra = 0;
                    for &k in &st.path_nodes[st.path_start[p]..st.path_start[p + 1]] {
                        let n = f.node_len(k);
                        let ob = st.node_slot[k];
                        if ob != usize::MAX {
                            match st.seg[first..].last_mut() {
                                Some(sg) if sg.0 + sg.2 == ra && sg.1 + sg.2 == ob => sg.2 += n,
                                _ => st.seg.push((ra, ob, n)),
                            }
                        }
                        ra += n;
                    }
                    st.seg_at[p * g + q] = (first, st.seg.len());
                }
                let (s0, s1) = st.seg_at[p * g + q];
                let mut a = r0.max(b);
                while a < r1 {
                    let e = (a + 4).min(r1);
                    let mut v = [0.0f64; 4];
                    for &(ra, ob, n) in &st.seg[s0..s1] {
                        let sb = &st.path_s[vb + ob..vb + ob + n];
                        // Row `a + t`'s values on the shared nodes (from; the kernels
                        // take the length of `sb`).
                        let ua = |t: usize| &st.path_u[st.val_start[a + t] + ra..];
                        match e - a {
                            1 => v[0] = products::dot_on(v[0], &ua(0)[..n], sb),
                            // (Two rows: one at a time, inlined; the kernel of two cost
                            // as many instructions a product, and a call.)
                            2 => {
                                v[0] = products::dot_on(v[0], &ua(0)[..n], sb);
                                v[1] = products::dot_on(v[1], &ua(1)[..n], sb);
                            }
                            // (Three rows: the third twice, the fourth lane dropped.)
                            3 => v = products::dot4_on(v, [ua(0), ua(1), ua(2), ua(2)], sb),
                            _ => v = products::dot4_on(v, [ua(0), ua(1), ua(2), ua(3)], sb),
                        }
                    }
                    for (t, &x) in v[..e - a].iter().enumerate() {
                        st.s_mat[(a + t) * d + b] = x;
                        st.s_mat[b * d + a + t] = x;
                        finite &= x.is_finite();
                    }
                    a = e;
                }
            }
            if slots {
                for &k in path_b {
                    st.node_slot[k] = usize::MAX;
                }
            }
        }
        if !finite {
            return false;
        }
        st.s_fac.factor(&mut st.s_mat, d, 1e-10 * free_scale)
    }

    /// Marks Schur row `i`'s bodies and their ancestors in `mark` and appends the
    /// newly marked nodes to `nodes` (a walk stops at a node already marked: its
    /// ancestors are).
    fn schur_path(&self, i: usize, mark: &mut [bool], nodes: &mut Vec<usize>) {
        let parent = &self.solver.parent;
        let mut walk = |body: usize| {
            let mut k = body;
            while k < mark.len() && !mark[k] {
                mark[k] = true;
                nodes.push(k);
                k = parent[k];
            }
        };
        let m = self.urows.len();
        match self.urows.get(i) {
            Some(r) => {
                for body in [r.a, r.b].into_iter().flatten() {
                    walk(body);
                }
            }
            None => {
                for (a, b, _) in self.eq.segments(i - m) {
                    if let Some(a) = a {
                        walk(*a);
                    }
                    walk(*b);
                }
            }
        }
    }

    /// `corr = H_A⁻¹ G_Dᵀ ζ` for the Schur rows `schur` and their `ζ` (one factor solve
    /// with the factor `f` of `H_A`).
    fn schur_correction(&self, f: &RowTree, schur: &[usize], zeta: &[f64], corr: &mut Vec<f64>) {
        corr.clear();
        corr.resize(f.size, 0.0);
        for (c, &i) in schur.iter().enumerate() {
            let z = zeta[c];
            if z != 0.0 {
                self.schur_scatter(f, corr, i, z);
            }
        }
        // `G_Dᵀ ζ` is zero off the Schur rows' bodies: the forward pass skips the
        // nodes still zero when reached (the same result, [`RowTree::solve_sparse`]).
        f.solve_sparse(&self.solver, corr);
    }

    /// `G x` of Schur row `i` in the augmented layout: one-sided row `i` below
    /// `m = urows.len()`, equality row `i − m` ([`super::equality`], `E x`, a sum of
    /// two-body segments) from `m` on.
    fn schur_gather(&self, f: &RowTree, x: &[f64], i: usize) -> f64 {
        let m = self.urows.len();
        match self.urows.get(i) {
            Some(r) => gather(f, x, r),
            None => self
                .eq
                .segments(i - m)
                .iter()
                .map(|(a, b, j)| gather_seg(f, x, *a, Some(*b), j))
                .sum(),
        }
    }

    /// `x += s · Gᵀ` for Schur row `i` ([`Self::schur_gather`]'s numbering).
    fn schur_scatter(&self, f: &RowTree, x: &mut [f64], i: usize, s: f64) {
        let m = self.urows.len();
        match self.urows.get(i) {
            Some(r) => scatter(f, x, r, s),
            None => {
                for (a, b, j) in self.eq.segments(i - m) {
                    scatter_seg(f, x, *a, Some(*b), j, s);
                }
            }
        }
    }

    /// Schur row `i`'s target: the one-sided row's bias, the equality's `r_E = −β C/h`.
    fn schur_bias(&self, i: usize) -> f64 {
        match self.urows.get(i) {
            Some(r) => r.bias,
            None => self.eq.target(i - self.urows.len()),
        }
    }

    /// `G M⁻¹ Gᵀ` of Schur row `i` with its bodies free (the rows' scale without the
    /// tree, for the truncation floor of `S`), `|g_v|²/m + g_ωᵀ R I⁻¹ Rᵀ g_ω` per body;
    /// `R I⁻¹ Rᵀ` from `inertia` where it holds the body's.
    fn schur_free_scale(&self, i: usize, inertia: &mut FreeInertia) -> f64 {
        let Some(r) = self.urows.get(i) else {
            return self.eq.row_free_scale(&self.bodies, i - self.urows.len());
        };
        let mut g = 0.0;
        for (side, body) in [(0usize, r.a), (1usize, r.b)] {
            if let Some(k) = body {
                let b = &self.bodies[k];
                g += r.j[2 * side].length_squared() / b.mass()
                    + r.j[2 * side + 1].dot(inertia.get(k, b) * r.j[2 * side + 1]);
            }
        }
        g
    }

    /// After a dense solve: the statuses its impulses imply, for the next step's warm
    /// start of the active set.
    pub(super) fn remember_dense_statuses(&mut self) {
        let mut st = self.aset.take().unwrap_or_default();
        st.keys.clear();
        st.status.clear();
        for (i, r) in self.urows.iter().enumerate() {
            st.keys.push(self.row_key(r));
            let z = self.uz.get(i).copied().unwrap_or(0.0);
            let (lo, hi) = bounds(&r.bound, &self.uz);
            let tol = 1e-9 * hi.abs().max(lo.abs());
            let s = match r.bound {
                RowBound::Unilateral if z > 0.0 => RowStatus::Active,
                RowBound::Unilateral => RowStatus::Inactive,
                _ if lo == 0.0 && hi == 0.0 => RowStatus::Inactive,
                _ if z >= hi - tol => RowStatus::Hi,
                _ if z <= lo + tol => RowStatus::Lo,
                _ => RowStatus::Active,
            };
            st.status.push(s);
        }
        remember(&mut st, &self.uz);
        self.aset = Some(st);
    }
}

/// The world inverse inertias `R I⁻¹ Rᵀ` of the last two bodies asked for (a Schur
/// row's two sides; the rows of one contact pair come together), so that
/// [`World::schur_free_scale`] forms each once per run of rows rather than per row.
#[derive(Default)]
struct FreeInertia {
    slots: [Option<(usize, DMat3)>; 2],
}

impl FreeInertia {
    /// Body `k`'s `R I⁻¹ Rᵀ` (`b`: the body), formed on a miss.
    fn get(&mut self, k: usize, b: &constraint_core::RigidBody) -> DMat3 {
        for (j, m) in self.slots.iter().flatten() {
            if *j == k {
                return *m;
            }
        }
        let m = b.world_inv_inertia();
        self.slots = [Some((k, m)), self.slots[0]];
        m
    }
}

/// Keeps the rows' keys, statuses and impulses in row order for the next step.
fn remember(st: &mut ActiveSet, z: &[f64]) {
    st.warm.clear();
    for (i, (k, s)) in st.keys.iter().zip(&st.status).enumerate() {
        st.warm.push((*k, *s, z.get(i).copied().unwrap_or(0.0)));
    }
    st.sorted_ok = false;
}

/// The row's bounds `(lo, hi)` at the impulses `z` (friction: `±μ max(z_n, 0)`).
/// [`World::unilateral_set_is_new`]'s near repeat: with the same statuses as an
/// earlier set, the normals behind the friction rows at a bound moved by at most
/// [`NEAR_REPEAT`] of the largest of them since (`earlier`: the impulses then):
/// `max_n |z_n − z'_n| ≤ NEAR_REPEAT · max_n |z_n|`. `false` where an index is out
/// of range or an impulse is NaN.
fn near_repeat(urows: &[URow], status: &[RowStatus], z: &[f64], earlier: &[f64]) -> bool {
    let (mut moved, mut size) = (0.0f64, 0.0f64);
    for (r, s) in urows.iter().zip(status) {
        if let (RowStatus::Lo | RowStatus::Hi, RowBound::Friction { normal, .. }) = (s, r.bound) {
            let (Some(a), Some(b)) = (z.get(normal), earlier.get(normal)) else {
                return false;
            };
            let d = (a - b).abs();
            if d.is_nan() {
                return false;
            }
            moved = moved.max(d);
            size = size.max(a.abs());
        }
    }
    moved <= NEAR_REPEAT * size
}

fn bounds(b: &RowBound, z: &[f64]) -> (f64, f64) {
    match *b {
        RowBound::Unilateral => (0.0, f64::INFINITY),
        RowBound::Friction { normal, mu } => {
            let m = mu * z.get(normal).copied().unwrap_or(0.0).max(0.0);
            (-m, m)
        }
        RowBound::Boxed { lo, hi } => (lo, hi),
    }
}

/// A forward pass's values on a path's nodes `path` (factor `f`), packed node after
/// node: `s` (taken from `col`, left zero there) into `ps`, `u = s / d⁻¹` (zero at a
/// dropped pivot) into `pu`. A function of its own so that the slices are known apart
/// (inlined into the loop over the path's nodes, the compiler checked them for overlap
/// at every node: 60 instructions a node).
#[inline(never)]
fn take_path_values(f: &RowTree, path: &[usize], col: &mut [f64], ps: &mut [f64], pu: &mut [f64]) {
    let mut at = 0;
    for &k in path {
        let (o, n) = (f.node_offset(k), f.node_len(k));
        let (ps, pu) = (&mut ps[at..at + n], &mut pu[at..at + n]);
        let src = col[o..o + n].iter_mut().zip(f.pivot_inverses(o, n));
        for ((sv, &di), (ps, pu)) in src.zip(ps.iter_mut().zip(pu.iter_mut())) {
            let sv = core::mem::take(sv);
            *ps = sv;
            *pu = if di != 0.0 { sv / di } else { 0.0 };
        }
        at += n;
    }
}

/// Sorts a short list in place (a path's few elimination steps, mostly in order).
fn insertion_sort(v: &mut [usize]) {
    for i in 1..v.len() {
        let mut j = i;
        while j > 0 && v[j - 1] > v[j] {
            v.swap(j - 1, j);
            j -= 1;
        }
    }
}

/// `x += s · Gᵀ` on the row's bodies' unknowns in the augmented layout.
fn scatter(f: &RowTree, x: &mut [f64], r: &URow, s: f64) {
    scatter_seg(f, x, r.a, r.b, &r.j, s);
}

/// `x += s · gᵀ` for a two-body row `g = [v_a, ω_a, v_b, ω_b]` in the augmented layout.
#[inline]
fn scatter_seg(
    f: &RowTree,
    x: &mut [f64],
    a: Option<usize>,
    b: Option<usize>,
    j: &[DVec3; 4],
    s: f64,
) {
    for (side, body) in [(0usize, a), (1usize, b)] {
        let Some(body) = body else { continue };
        let o = f.node_offset(body);
        // One bounds check for the body's six unknowns.
        let t = &mut x[o..o + 6];
        for c in 0..3 {
            t[c] += s * j[2 * side][c];
            t[3 + c] += s * j[2 * side + 1][c];
        }
    }
}

/// `G x` on the row's bodies' unknowns in the augmented layout.
#[inline(always)]
fn gather(f: &RowTree, x: &[f64], r: &URow) -> f64 {
    gather_seg(f, x, r.a, r.b, &r.j)
}

/// `g x` for a two-body row `g = [v_a, ω_a, v_b, ω_b]` in the augmented layout.
/// (Inlined: out of line, the call cost about a quarter of its 48 instructions, at
/// some 90 calls a step on dm stacker.)
#[inline(always)]
fn gather_seg(f: &RowTree, x: &[f64], a: Option<usize>, b: Option<usize>, j: &[DVec3; 4]) -> f64 {
    let mut s = 0.0;
    for (side, body) in [(0usize, a), (1usize, b)] {
        let Some(body) = body else { continue };
        let o = f.node_offset(body);
        // One bounds check for the body's six unknowns.
        let t = &x[o..o + 6];
        s += j[2 * side].dot(DVec3::new(t[0], t[1], t[2]))
            + j[2 * side + 1].dot(DVec3::new(t[3], t[4], t[5]));
    }
    s
}

/// The factor of the symmetric positive semi-definite `d × d` row-major `S` of the
/// Schur rows, for [`PsdFactor::apply`]'s minimum-norm solve: Cholesky with diagonal
/// pivoting (Higham, "Accuracy and Stability of Numerical Algorithms", 2nd ed.,
/// §10.3; LAPACK's `dpstrf`), `Π S Πᵀ = L Lᵀ` with `L` lower trapezoidal, `d × r`,
/// stopped at rank `r` when every diagonal of the remaining Schur complement is at
/// most the cut `max(1e-10 max_i S_ii, floor)` (those directions are dependent:
/// `S`'s truncated eigenvalues in the eigendecomposition this replaces, a 30–100×
/// cheaper factor at the sizes met, `d ≈ 10–30`). With `B = Πᵀ L` (full column
/// rank, `S ≈ B Bᵀ`) the minimum-norm solution is `S⁺ r = B (BᵀB)⁻² Bᵀ r` (as
/// `(BBᵀ)⁺ = B⁺ᵀ B⁺`, `B⁺ = (BᵀB)⁻¹ Bᵀ`); for `r < d` it is applied through
/// `Π L = Q R` (Householder QR of the `d × r` factor): `S⁺ = Πᵀ Q R⁻ᵀ R⁻¹ Qᵀ Π`.
#[derive(Clone, Debug, Default)]
struct PsdFactor {
    /// Order `d` and rank `r`.
    d: usize,
    rank: usize,
    /// `L` in the lower trapezoid of the `d × d` row-major matrix (row `i` is `Π`'s
    /// row `i`, the original row `perm[i]`).
    l: Vec<f64>,
    perm: Vec<usize>,
    /// For `r < d` only: `L = Q R` (`d × r` row-major: `R` on and above the
    /// diagonal, the Householder vectors below it), the vectors' first entries and
    /// the reflections' `τ`.
    qr: Vec<f64>,
    hv0: Vec<f64>,
    /// The vectors below their first entries, reflection after reflection (`hv_at`:
    /// where each starts), for [`Self::reflect`].
    hv: Vec<f64>,
    hv_at: Vec<usize>,
    tau: Vec<f64>,
    /// Scratch of `r` values.
    tmp: Vec<f64>,
}

/// [`PsdFactor::factor`]'s Householder step updates the columns right of the pivot row
/// by row from this many columns on, column by column below.
const ROW_WISE_COLUMNS: usize = 4;

impl PsdFactor {
    /// Factors the `d × d` row-major `s` (symmetric, positive semi-definite; consumed
    /// as scratch) with the truncation floor `floor`. `false` when `s` or the factor
    /// is not finite.
    fn factor(&mut self, s: &mut Vec<f64>, d: usize, floor: f64) -> bool {
        core::mem::swap(&mut self.l, s);
        self.d = d;
        self.rank = 0;
        self.perm.clear();
        self.perm.extend(0..d);
        let a = &mut self.l;
        let dmax = (0..d).map(|i| a[i * d + i]).fold(0.0f64, f64::max);
        if !dmax.is_finite() {
            return false;
        }
        let cut = (1e-10 * dmax).max(floor);
        if dmax <= floor {
            return true;
        }
        let mut rank = d;
        let mut col = core::mem::take(&mut self.tmp);
        for k in 0..d {
            // The pivot: the largest remaining diagonal (the Schur complement's), the
            // first of equals (a walk down the diagonal, one stride a step).
            let (mut p, mut best) = (k, a[k * d + k]);
            for i in k + 1..d {
                let x = a[i * d + i];
                if x > best {
                    (p, best) = (i, x);
                }
            }
            if !(a[p * d + p] > cut) {
                rank = k;
                break;
            }
            if p != k {
                swap_lower(a, d, k, p);
                self.perm.swap(k, p);
            }
            // Column k of L: l_kk = √a_kk, l_ik = a_ik / l_kk; then the Schur
            // complement a_ij −= l_ik l_jk (k < j ≤ i), its lower triangle only (the
            // upper one is never read), row by row on slices against column k
            // gathered once into `col` (the same products in the same order).
            let lkk = libm::sqrt(a[k * d + k]);
            a[k * d + k] = lkk;
            col.clear();
            for row in a[(k + 1) * d..d * d].chunks_exact_mut(d) {
                row[k] /= lkk;
                col.push(row[k]);
            }
            schur_update_lower(a, d, k, &col);
        }
        self.tmp = col;
        self.rank = rank;
        if rank == d || rank == 0 {
            return (0..d).all(|i| a[i * d + i].is_finite());
        }
        // B_π = L (d × r) = Q R by Householder reflections (Golub and Van Loan,
        // §5.2.2): S⁺ = Πᵀ Q R⁻ᵀ R⁻¹ Qᵀ Π, with triangular solves on R (condition
        // √κ(S) each) rather than on the Gram matrix LᵀL.
        let r = rank;
        self.qr.clear();
        self.qr.resize(d * r, 0.0);
        let rows = self.qr.chunks_exact_mut(r).zip(a.chunks_exact(d));
        for (i, (q, l)) in rows.enumerate() {
            let w = i.min(r - 1) + 1;
            q[..w].copy_from_slice(&l[..w]);
        }
        self.hv0.clear();
        self.tau.clear();
        let q = &mut self.qr[..d * r];
        // `t_j` of the columns right of `k`, per reflection.
        let mut t = core::mem::take(&mut self.tmp);
        t.clear();
        t.resize(r, 0.0);
        for k in 0..r {
            // H_k = I − τ v vᵀ, v = x − α e₁ on rows k.., α = −sign(x₀) ‖x‖.
            // ‖x‖² summed from x₀², and the sum below x₀ on its own (for `vᵀv`), in
            // one walk down the column (each sum in `i` order, as two walks did).
            let x0 = q[k * r + k];
            let (mut nn, mut below) = (-0.0 + x0 * x0, -0.0);
            for row in q[(k + 1) * r..].chunks_exact(r) {
                let x = row[k] * row[k];
                nn += x;
                below += x;
            }
            let norm = libm::sqrt(nn);
            let alpha = if x0 > 0.0 { -norm } else { norm };
            let v0 = x0 - alpha;
            let vv = v0 * v0 + below;
            let tau = if vv > 0.0 { 2.0 / vv } else { 0.0 };
            // Each column j > k: `t_j = τ (v₀ q_kj + Σ_{i>k} q_ik q_ij)`, `q_kj −= t_j v₀`,
            // `q_ij −= t_j q_ik`, each sum in `i` order from `v₀ q_kj`. Columns are
            // independent (each reads column k and itself), so with several of them the
            // sums advance row by row over the contiguous columns (the same products and
            // sums, vector lanes instead of a strided walk down each column); with few,
            // column by column (a row's loop setup would cost more than it saves).
            let (head, rows) = q.split_at_mut((k + 1) * r);
            let qk = &mut head[k * r..];
            if r - k > ROW_WISE_COLUMNS {
                reflect_row_wise(qk, rows, &mut t[k + 1..r], k, r, v0, tau);
            } else {
                for j in k + 1..r {
                    let mut sdot = v0 * qk[j];
                    for row in rows.chunks_exact(r) {
                        sdot += row[k] * row[j];
                    }
                    let tj = tau * sdot;
                    qk[j] -= tj * v0;
                    for row in rows.chunks_exact_mut(r) {
                        row[j] -= tj * row[k];
                    }
                }
            }
            qk[k] = alpha;
            if !(alpha.abs() > 0.0) || !alpha.is_finite() {
                self.tmp = t;
                return false;
            }
            self.hv0.push(v0);
            self.tau.push(tau);
        }
        self.tmp = t;
        // Each reflection's vector below its first entry, contiguous, for `reflect`
        // (read down a column of `qr` it cost a bounds check and a multiply a value).
        self.hv.clear();
        self.hv_at.clear();
        for k in 0..r {
            self.hv_at.push(self.hv.len());
            let below = self.qr[(k + 1) * r..d * r].chunks_exact(r);
            self.hv.extend(below.map(|row| row[k]));
        }
        true
    }

    /// `t ← H_k t` for the Householder reflection `k` of [`Self::factor`].
    fn reflect(&self, k: usize, t: &mut [f64]) {
        let (d, v0) = (self.d, self.hv0[k]);
        let (tk, rest) = t[k..d].split_at_mut(1);
        let h = &self.hv[self.hv_at[k]..self.hv_at[k] + rest.len()];
        let mut sdot = v0 * tk[0];
        for (x, y) in h.iter().zip(rest.iter()) {
            sdot += x * y;
        }
        let c = self.tau[k] * sdot;
        tk[0] -= c * v0;
        for (x, y) in rest.iter_mut().zip(h) {
            *x -= c * y;
        }
    }

    /// The minimum-norm `ζ = S⁺ rhs` ([`PsdFactor`]): `Π ζ = L⁻ᵀ L⁻¹ Π rhs` at full rank,
    /// `Π ζ = L C⁻¹ C⁻¹ Lᵀ Π rhs` below it; `ζ = 0` at rank zero (every direction at
    /// most the floor). `false` when `ζ` is not finite.
    fn apply(&mut self, rhs: &[f64], zeta: &mut [f64]) -> bool {
        let (d, r) = (self.d, self.rank);
        zeta.iter_mut().for_each(|z| *z = 0.0);
        if r == 0 {
            return true;
        }
        let mut t = core::mem::take(&mut self.tmp);
        t.clear();
        t.resize(d, 0.0);
        let l = &self.l;
        if r == d {
            // L y = Π rhs, then Lᵀ u = y; ζ = Πᵀ u.
            // (Iterators over rows and strided columns: the same products and
            // sums in the same order, without an index check and multiply a term.)
            for i in 0..d {
                let mut v = rhs[self.perm[i]];
                for (a, b) in l[i * d..i * d + i].iter().zip(&t[..i]) {
                    v -= a * b;
                }
                t[i] = v / l[i * d + i];
            }
            for i in (0..d).rev() {
                let mut v = t[i];
                for k in i + 1..d {
                    v -= l[k * d + i] * t[k];
                }
                t[i] = v / l[i * d + i];
            }
            for i in 0..d {
                zeta[self.perm[i]] = t[i];
            }
        } else {
            // t = Qᵀ Π rhs; R y = t₁..ᵣ, Rᵀ u = y; Π ζ = Q [u; 0].
            for i in 0..d {
                t[i] = rhs[self.perm[i]];
            }
            for k in 0..r {
                self.reflect(k, &mut t);
            }
            let q = &self.qr;
            for i in (0..r).rev() {
                let mut v = t[i];
                for (a, b) in q[i * r + i + 1..(i + 1) * r].iter().zip(&t[i + 1..r]) {
                    v -= a * b;
                }
                t[i] = v / q[i * r + i];
            }
            for i in 0..r {
                let mut v = t[i];
                for k in 0..i {
                    v -= q[k * r + i] * t[k];
                }
                t[i] = v / q[i * r + i];
            }
            t[r..].iter_mut().for_each(|v| *v = 0.0);
            for k in (0..r).rev() {
                self.reflect(k, &mut t);
            }
            for i in 0..d {
                zeta[self.perm[i]] = t[i];
            }
        }
        self.tmp = t;
        zeta.iter().all(|z| z.is_finite())
    }
}

/// [`PsdFactor::factor`]'s Schur complement update after pivot `k`: `a_ij −= l_ik l_jk`
/// for `k < j ≤ i` on the lower triangle of the `d × d` row-major `a`, row by row
/// against column `k` below the pivot, `col` (`l_jk` at `j − k − 1`). A function of
/// its own so that `a` and `col` are known apart (inlined, every row's loop checked
/// them for overlap first).
#[inline(never)]
fn schur_update_lower(a: &mut [f64], d: usize, k: usize, col: &[f64]) {
    for i in k + 1..d {
        let lik = col[i - k - 1];
        if lik != 0.0 {
            let row = &mut a[i * d + k + 1..=i * d + i];
            for (x, l) in row.iter_mut().zip(&col[..i - k]) {
                *x -= lik * l;
            }
        }
    }
}

/// [`PsdFactor::factor`]'s Householder step `k` on the columns `j > k` of the `d × r`
/// row-major QR arena, row by row over the contiguous columns: `qk` is row `k` (from
/// column 0), `rows` the rows below it, `tj` scratch for the columns `k + 1..r`:
/// `t_j = τ (v₀ q_kj + Σ_{i>k} q_ik q_ij)` (the sum in `i` order), `q_kj −= t_j v₀`,
/// `q_ij −= t_j q_ik`. A function of its own so that the slices are known apart.
#[inline(never)]
fn reflect_row_wise(
    qk: &mut [f64],
    rows: &mut [f64],
    tj: &mut [f64],
    k: usize,
    r: usize,
    v0: f64,
    tau: f64,
) {
    for (s, &x) in tj.iter_mut().zip(&qk[k + 1..r]) {
        *s = v0 * x;
    }
    for row in rows.chunks_exact(r) {
        let qik = row[k];
        for (s, &x) in tj.iter_mut().zip(&row[k + 1..]) {
            *s += qik * x;
        }
    }
    for (s, x) in tj.iter_mut().zip(&mut qk[k + 1..r]) {
        *s *= tau;
        *x -= *s * v0;
    }
    for row in rows.chunks_exact_mut(r) {
        let (left, right) = row.split_at_mut(k + 1);
        let qik = left[k];
        for (x, &s) in right.iter_mut().zip(&*tj) {
            *x -= s * qik;
        }
    }
}

/// Swaps rows and columns `k < p` of the symmetric `d × d` row-major `a` held in its
/// lower triangle (LAPACK's `dsyswapr`, lower): `a ← Π a Πᵀ` for the transposition
/// `Π = (k p)`, with the factored columns `c < k` (rows of `L`) swapped as rows.
fn swap_lower(a: &mut [f64], d: usize, k: usize, p: usize) {
    // Rows k and p left of column k: two contiguous runs (one slice swap).
    let (upper, lower) = a.split_at_mut(p * d);
    upper[k * d..k * d + k].swap_with_slice(&mut lower[..k]);
    a.swap(k * d + k, p * d + p);
    for i in k + 1..p {
        a.swap(i * d + k, p * d + i);
    }
    // Columns k and p below row p: one row at a time.
    for row in a[(p + 1) * d..d * d].chunks_exact_mut(d) {
        row.swap(k, p);
    }
}

/// Solves the `p × p` row-major `a x = b` in place (`b` becomes `x`) by Gaussian
/// elimination with partial pivoting; `false` when a pivot is below `1e-12 ×` the
/// largest entry (singular) or the result is not finite.
fn small_solve(a: &mut [f64], b: &mut [f64], p: usize) -> bool {
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for c in 0..p {
        let mut piv = c;
        for r in c + 1..p {
            if a[r * p + c].abs() > a[piv * p + c].abs() {
                piv = r;
            }
        }
        if !(a[piv * p + c].abs() > 1e-12 * scale) {
            return false;
        }
        if piv != c {
            for k in 0..p {
                a.swap(c * p + k, piv * p + k);
            }
            b.swap(c, piv);
        }
        for r in c + 1..p {
            let f = a[r * p + c] / a[c * p + c];
            if f != 0.0 {
                for k in c..p {
                    a[r * p + k] -= f * a[c * p + k];
                }
                b[r] -= f * b[c];
            }
        }
    }
    for c in (0..p).rev() {
        let mut v = b[c];
        for k in c + 1..p {
            v -= a[c * p + k] * b[k];
        }
        b[c] = v / a[c * p + c];
    }
    b.iter().all(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::{near_repeat, PsdFactor, RowStatus, NEAR_REPEAT};
    use crate::world::unilateral::{RowSource, URow};
    use alloc::vec::Vec;
    use constraint_contact::lcp::RowBound;
    use constraint_core::DVec3;

    /// A contact's normal (row 0) and two friction rows on it, `μ = 1`.
    fn contact_rows() -> Vec<URow> {
        (0u8..3)
            .map(|axis| URow {
                a: None,
                b: Some(0),
                j: [DVec3::ZERO; 4],
                bias: 0.0,
                bound: if axis == 0 {
                    RowBound::Unilateral
                } else {
                    RowBound::Friction { normal: 0, mu: 1.0 }
                },
                source: RowSource::Contact { contact: 0, axis },
            })
            .collect()
    }

    /// The creeping cycle of dm humanoid perturbed (step 248: the normal behind a
    /// friction bound at 1.442 then 1.443, 0.07 %) is a near repeat; a move of 2 % is
    /// not, nor a NaN impulse; without friction rows at a bound the statuses decide.
    #[test]
    fn a_near_repeat_is_the_same_friction_bounds_within_one_percent() {
        let rows = contact_rows();
        let at_bound = [RowStatus::Active, RowStatus::Hi, RowStatus::Lo];
        let earlier = [1.442, 1.442, -1.442];
        // Moved 0.001 of 1.443 (0.07 %, limit 1 %).
        assert!(near_repeat(
            &rows,
            &at_bound,
            &[1.443, 1.443, -1.443],
            &earlier
        ));
        // Moved 0.03 of 1.472 (2.0 %).
        assert!(!near_repeat(
            &rows,
            &at_bound,
            &[1.472, 1.472, -1.472],
            &earlier
        ));
        const { assert!(NEAR_REPEAT < 0.03 / 1.472) };
        assert!(!near_repeat(
            &rows,
            &at_bound,
            &[f64::NAN, 0.0, 0.0],
            &earlier
        ));
        // Friction rows free or inactive: no bound to compare, the same statuses repeat.
        let free = [RowStatus::Active, RowStatus::Active, RowStatus::Inactive];
        assert!(near_repeat(&rows, &free, &[2.0, 0.5, 0.0], &earlier));
    }

    /// A deterministic value in `[-1, 1)` (a 64-bit LCG).
    fn next(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((*seed >> 11) as f64) / ((1u64 << 53) as f64) * 2.0 - 1.0
    }

    /// `PsdFactor`'s solve is the minimum-norm `S⁺ r` (nalgebra's SVD pseudo-inverse)
    /// at full rank and below it, for right-hand sides in and out of `S`'s range.
    #[test]
    fn psd_factor_is_the_minimum_norm_solve() {
        let mut seed = 7u64;
        for &(d, r) in &[(1, 1), (5, 5), (12, 12), (6, 3), (18, 11), (30, 17), (9, 1)] {
            let b = nalgebra::DMatrix::from_fn(d, r, |_, _| next(&mut seed));
            let s = &b * b.transpose();
            let rhs = nalgebra::DVector::from_fn(d, |_, _| next(&mut seed));
            let pinv = s.clone().pseudo_inverse(1e-10 * s.norm()).unwrap();
            let want = &pinv * &rhs;
            let mut mat: Vec<f64> = (0..d * d).map(|k| s[(k / d, k % d)]).collect();
            let mut f = PsdFactor::default();
            assert!(f.factor(&mut mat, d, 0.0));
            assert_eq!(f.rank, r, "d {d}");
            let mut zeta = alloc::vec![0.0; d];
            assert!(f.apply(rhs.as_slice(), &mut zeta));
            let err = (0..d)
                .map(|i| (zeta[i] - want[i]).abs())
                .fold(0.0, f64::max);
            assert!(err <= 1e-8 * want.amax().max(1.0), "d {d} r {r}: {err:e}");
        }
    }

    /// A matrix at most the floor has no kept direction: `ζ = 0`.
    #[test]
    fn psd_factor_below_the_floor_is_zero() {
        let mut mat = alloc::vec![1e-12, 0.0, 0.0, 2e-12];
        let mut f = PsdFactor::default();
        assert!(f.factor(&mut mat, 2, 1e-9));
        let mut zeta = alloc::vec![1.0; 2];
        assert!(f.apply(&[1.0, 1.0], &mut zeta));
        assert_eq!(zeta, [0.0, 0.0]);
    }
}
