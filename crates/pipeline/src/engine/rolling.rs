//! Sums over a rolling window of record time, per DOF and forecast step, kept in blocks so that
//! old evidence leaves the window without storing every scored value.
//!
//! The window is `blocks` full blocks of `block_values` new record values each, plus the block
//! being filled. A running total makes every query O(1); a block that leaves the window is
//! subtracted from it. Nothing allocates after construction.

use shipcast_wire::payload::{MAX_STEPS, NUM_DOF};

/// `S` sums per (DOF, step), over the most recent blocks.
#[derive(Debug, Clone)]
pub struct RollingSums<const S: usize> {
    block_values: usize,
    blocks: usize,
    /// `(blocks + 1) * NUM_DOF * MAX_STEPS` entries: one slot per block, the current included.
    data: Vec<[f64; S]>,
    total: Vec<[f64; S]>,
    current: usize,
    filled: usize,
    /// Completed blocks held (at most `blocks`).
    held: usize,
}

fn at(block: usize, d: usize, k: usize) -> usize {
    (block * NUM_DOF + d) * MAX_STEPS + k
}

impl<const S: usize> RollingSums<S> {
    /// A window of about `window_values` values, in `blocks` blocks (both at least 1).
    pub fn new(window_values: usize, blocks: usize) -> Self {
        let blocks = blocks.max(1);
        let block_values = window_values.div_ceil(blocks).max(1);
        Self {
            block_values,
            blocks,
            data: vec![[0.0; S]; (blocks + 1) * NUM_DOF * MAX_STEPS],
            total: vec![[0.0; S]; NUM_DOF * MAX_STEPS],
            current: 0,
            filled: 0,
            held: 0,
        }
    }

    /// Add `v` to the sums of DOF `d`, step index `k` (0-based).
    #[inline]
    pub fn add(&mut self, d: usize, k: usize, v: [f64; S]) {
        let slot = &mut self.data[at(self.current, d, k)];
        let total = &mut self.total[d * MAX_STEPS + k];
        for i in 0..S {
            slot[i] += v[i];
            total[i] += v[i];
        }
    }

    /// Sums of DOF `d`, step index `k` over the window.
    #[inline]
    pub fn get(&self, d: usize, k: usize) -> [f64; S] {
        self.total[d * MAX_STEPS + k]
    }

    /// One new record value has been scored: move on to the next block when this one is full.
    pub fn tick(&mut self) {
        self.filled += 1;
        if self.filled < self.block_values {
            return;
        }
        self.filled = 0;
        self.held = (self.held + 1).min(self.blocks);
        self.current = (self.current + 1) % (self.blocks + 1);
        // The slot about to be reused holds the oldest block: it leaves the window.
        self.drop_block(self.current);
        if self.current == 0 {
            self.resum();
        }
    }

    fn drop_block(&mut self, block: usize) {
        for d in 0..NUM_DOF {
            for k in 0..MAX_STEPS {
                let i = at(block, d, k);
                let old = std::mem::replace(&mut self.data[i], [0.0; S]);
                let total = &mut self.total[d * MAX_STEPS + k];
                for s in 0..S {
                    total[s] -= old[s];
                }
            }
        }
    }

    /// Recompute the totals from the blocks, so that rounding from subtracting old blocks
    /// never accumulates.
    fn resum(&mut self) {
        for d in 0..NUM_DOF {
            for k in 0..MAX_STEPS {
                let mut t = [0.0; S];
                for b in 0..=self.blocks {
                    let v = self.data[at(b, d, k)];
                    for s in 0..S {
                        t[s] += v[s];
                    }
                }
                self.total[d * MAX_STEPS + k] = t;
            }
        }
    }

    /// Multiply the evidence of DOF `d` by `factor` (in [0, 1]): what it knew counts as that
    /// fraction of the values it came from. Used when the sea has changed.
    pub fn discount(&mut self, d: usize, factor: f64) {
        for b in 0..=self.blocks {
            for k in 0..MAX_STEPS {
                for v in self.data[at(b, d, k)].iter_mut() {
                    *v *= factor;
                }
            }
        }
        for k in 0..MAX_STEPS {
            for v in self.total[d * MAX_STEPS + k].iter_mut() {
                *v *= factor;
            }
        }
    }

    /// Forget everything of DOF `d`.
    pub fn clear(&mut self, d: usize) {
        self.discount(d, 0.0);
    }

    /// Record values the window spans at most.
    pub fn window_values(&self) -> usize {
        self.block_values * self.blocks
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn old_blocks_leave_the_window() {
        // 4 blocks of 10 values; add 1 per value at (d 2, step 3).
        let mut r = RollingSums::<1>::new(40, 4);
        for i in 0..200 {
            r.add(2, 3, [1.0]);
            r.tick();
            let expect = (i + 1).min(40 + (i + 1) % 10) as f64;
            assert_eq!(r.get(2, 3)[0], expect, "after {} values", i + 1);
        }
        assert_eq!(r.get(0, 0)[0], 0.0);
    }

    #[test]
    fn discount_scales_and_clear_forgets() {
        let mut r = RollingSums::<2>::new(20, 2);
        for _ in 0..15 {
            r.add(1, 0, [2.0, 3.0]);
            r.tick();
        }
        r.discount(1, 0.5);
        assert_eq!(r.get(1, 0), [15.0, 22.5]);
        r.clear(1);
        assert_eq!(r.get(1, 0), [0.0, 0.0]);
        // New evidence after a clear counts from zero, and old blocks do not come back: after
        // 55 ticks the window holds 2 full blocks and 5 values of the current one.
        for _ in 0..40 {
            r.add(1, 0, [1.0, 1.0]);
            r.tick();
        }
        assert_eq!(r.get(1, 0)[0], 25.0);
    }
}
