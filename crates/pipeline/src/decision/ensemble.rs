//! An ensemble of verified forecast errors: the standardised error paths u = (actual - mean) /
//! sigma of recent verified forecasts, all quantities and all steps of each kept together.
//!
//! Why: the Gaussian window probability ([`super::window`]) assumes Gaussian errors, a fixed
//! step-to-step correlation and independent quantities. Replay shows it states 8-14 points
//! more than happens in its most confident calls (docs/decisions.md). Replaying the errors
//! that really happened on the current forecast (value = mean + sigma u, member by member)
//! keeps their tails, their dependence across steps and across quantities, and any lead at
//! which sigma is off, with no model of any of it. The probability that a window holds is the
//! share of members under which every limit holds at every step of it.
//!
//! Members are kept one verified forecast in `stride` (neighbouring forecasts' errors are
//! nearly the same path) in a ring of `capacity`, so the ensemble follows the sea of the last
//! `capacity * stride` forecasts.

use super::NUM_QUANTITIES;
use shipcast_wire::payload::MAX_STEPS;

/// Members before the ensemble replaces the Gaussian model: fewer verified error paths
/// (strongly dependent ones at that) leave a share too coarse to state 0.95 honestly.
pub const MIN_MEMBERS: usize = 150;

/// Default ring size and stride: at 2 forecasts per second, one member every 2 s over the
/// last 20 minutes (a sea state's scale, as the engine's skill tracking uses).
pub const DEFAULT_CAPACITY: usize = 600;
pub const DEFAULT_STRIDE: usize = 4;

#[derive(Debug, Clone)]
struct Member {
    steps: usize,
    u: [[f32; MAX_STEPS]; NUM_QUANTITIES],
}

#[derive(Debug, Clone)]
pub struct ErrorEnsemble {
    members: Vec<Member>,
    capacity: usize,
    /// Next ring slot to overwrite once full.
    next: usize,
    stride: usize,
    offered: u64,
}

impl Default for ErrorEnsemble {
    fn default() -> Self {
        Self::new(DEFAULT_CAPACITY, DEFAULT_STRIDE)
    }
}

impl ErrorEnsemble {
    pub fn new(capacity: usize, stride: usize) -> Self {
        let capacity = capacity.max(1);
        Self {
            members: Vec::with_capacity(capacity),
            capacity,
            next: 0,
            stride: stride.max(1),
            offered: 0,
        }
    }

    pub fn len(&self) -> usize {
        self.members.len()
    }

    pub fn is_empty(&self) -> bool {
        self.members.is_empty()
    }

    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Whether there are enough members to decide from.
    pub fn ready(&self) -> bool {
        self.members.len() >= MIN_MEMBERS.min(self.capacity)
    }

    /// Offer the standardised errors of one verified forecast (`u[q][k]`, `steps` steps; a
    /// non-finite u, from a zero sigma or a missing value, counts as no error). One offer in
    /// `stride` is kept. Never allocates: the ring's storage is reserved by `new`.
    pub fn offer(&mut self, u: &[[f64; MAX_STEPS]; NUM_QUANTITIES], steps: usize) {
        let keep = self.offered.is_multiple_of(self.stride as u64);
        self.offered += 1;
        if !keep {
            return;
        }
        let steps = steps.min(MAX_STEPS);
        let member = |m: &mut Member| {
            m.steps = steps;
            for (row, src) in m.u.iter_mut().zip(u) {
                for (x, &v) in row.iter_mut().zip(src).take(steps) {
                    *x = if v.is_finite() { v as f32 } else { 0.0 };
                }
            }
        };
        if self.members.len() < self.capacity {
            let mut m = Member {
                steps: 0,
                u: [[0.0; MAX_STEPS]; NUM_QUANTITIES],
            };
            member(&mut m);
            self.members.push(m);
        } else {
            member(&mut self.members[self.next]);
            self.next = (self.next + 1) % self.capacity;
        }
    }

    /// For every member covering `steps` steps, the prefix counts of the steps at which some
    /// quantity breaks its limit when the member's errors are put on `mean` and `sigma`:
    /// `fail_before[i * (MAX_STEPS + 1) + k]` for member i, k = 0..=steps. Returns, per member,
    /// whether it covers the forecast (`usable[i]`). Neither buffer is reallocated once sized.
    pub fn failures(
        &self,
        mean: &[[f64; MAX_STEPS]; NUM_QUANTITIES],
        sigma: &[[f64; MAX_STEPS]; NUM_QUANTITIES],
        limits: &[f64; NUM_QUANTITIES],
        steps: usize,
        fail_before: &mut Vec<u16>,
        usable: &mut Vec<bool>,
    ) {
        let row = MAX_STEPS + 1;
        fail_before.resize(self.capacity * row, 0);
        usable.resize(self.capacity, false);
        for (i, m) in self.members.iter().enumerate() {
            usable[i] = m.steps >= steps;
            if !usable[i] {
                continue;
            }
            let counts = &mut fail_before[i * row..(i + 1) * row];
            counts[0] = 0;
            for k in 0..steps {
                let breaks = (0..NUM_QUANTITIES).any(|q| {
                    let value = mean[q][k] + sigma[q][k] * f64::from(m.u[q][k]);
                    value.is_nan() || value.abs() > limits[q]
                });
                counts[k + 1] = counts[k] + u16::from(breaks);
            }
        }
        for u in usable.iter_mut().skip(self.members.len()) {
            *u = false;
        }
    }
}

/// The share of usable members under which every limit holds over steps [start, end), with
/// one held and one broken pseudo-member added (the ensemble never states certainty). None
/// without a usable member.
pub fn share_within(fail_before: &[u16], usable: &[bool], start: usize, end: usize) -> Option<f64> {
    let row = MAX_STEPS + 1;
    let (mut held, mut total) = (0u32, 0u32);
    for (i, _) in usable.iter().enumerate().filter(|(_, &u)| u) {
        let c = &fail_before[i * row..(i + 1) * row];
        total += 1;
        held += u32::from(c[end] == c[start]);
    }
    (total > 0).then(|| (f64::from(held) + 1.0) / (f64::from(total) + 2.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::decision::window::{chain_within, Lattice};
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// AR(1)-in-lead Gaussian error paths with correlation rho.
    fn ar1_paths(
        rho: f64,
        count: usize,
        steps: usize,
        seed: u64,
    ) -> Vec<[[f64; MAX_STEPS]; NUM_QUANTITIES]> {
        let normal = Normal::new(0.0, 1.0).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let innovation = (1.0 - rho * rho).sqrt();
        (0..count)
            .map(|_| {
                let mut u = [[0.0; MAX_STEPS]; NUM_QUANTITIES];
                for row in u.iter_mut() {
                    row[0] = normal.sample(&mut rng);
                    for k in 1..steps {
                        row[k] = rho * row[k - 1] + innovation * normal.sample(&mut rng);
                    }
                }
                u
            })
            .collect()
    }

    #[test]
    fn the_share_of_gaussian_members_matches_the_gaussian_window_probability() {
        // Only quantity 0 is limited (the others' limits are out of reach), so the ensemble's
        // share must match the AR(1) chain probability of that quantity alone.
        let (steps, rho) = (20, 0.9);
        let paths = ar1_paths(rho, 4000, steps, 3);
        let mut ensemble = ErrorEnsemble::new(4000, 1);
        for u in &paths {
            ensemble.offer(u, steps);
        }
        assert!(ensemble.ready());
        let mut mean = [[0.0; MAX_STEPS]; NUM_QUANTITIES];
        let mut sigma = [[0.0; MAX_STEPS]; NUM_QUANTITIES];
        for k in 0..steps {
            mean[0][k] = 0.3 * (k as f64 * 0.4).sin();
            sigma[0][k] = 0.4 + 0.02 * k as f64;
        }
        let limits = [1.0, 1e9, 1e9, 1e9];
        let (mut fail, mut usable) = (Vec::new(), Vec::new());
        ensemble.failures(&mean, &sigma, &limits, steps, &mut fail, &mut usable);
        let lattice = Lattice::new(4096, MAX_STEPS);
        for (start, len) in [(0, 20), (0, 5), (7, 10)] {
            let share = share_within(&fail, &usable, start, start + len).unwrap();
            let exact = chain_within(
                &mean[0][start..start + len],
                &sigma[0][start..start + len],
                1.0,
                rho,
                &lattice,
            );
            // 4000 independent members: binomial standard error below 0.008.
            assert!(
                (share - exact).abs() < 0.03,
                "{start} {len}: {share} vs {exact}"
            );
        }
    }

    #[test]
    fn a_member_that_breaks_one_quantity_breaks_the_window_and_shorter_members_are_not_used() {
        let mut ensemble = ErrorEnsemble::new(10, 1);
        let mut calm = [[0.0; MAX_STEPS]; NUM_QUANTITIES];
        let mut rough = calm;
        rough[2][5] = 10.0; // deck displacement error of 10 sigma at step 5
        ensemble.offer(&calm, 10);
        ensemble.offer(&rough, 10);
        calm[0][0] = f64::NAN; // counts as no error
        ensemble.offer(&calm, 10);
        ensemble.offer(&calm, 4); // too short for a 10-step forecast
        let mean = [[0.0; MAX_STEPS]; NUM_QUANTITIES];
        let sigma = [[0.1; MAX_STEPS]; NUM_QUANTITIES];
        let (mut fail, mut usable) = (Vec::new(), Vec::new());
        ensemble.failures(&mean, &sigma, &[0.5; 4], 10, &mut fail, &mut usable);
        assert_eq!(&usable[..4], &[true, true, true, false]);
        // Over steps 0..10: 2 of 3 usable hold, plus the two pseudo-members.
        assert_eq!(share_within(&fail, &usable, 0, 10), Some(3.0 / 5.0));
        // Before step 5 every usable member holds.
        assert_eq!(share_within(&fail, &usable, 0, 5), Some(4.0 / 5.0));
    }

    #[test]
    fn the_ring_keeps_one_offer_in_stride_and_forgets_the_oldest() {
        let mut ensemble = ErrorEnsemble::new(3, 2);
        for i in 0..10 {
            let mut u = [[0.0; MAX_STEPS]; NUM_QUANTITIES];
            u[0][0] = i as f64;
            ensemble.offer(&u, 1);
        }
        // Offers 0, 2, 4, 6, 8 were kept; the ring of 3 holds 4, 6 and 8.
        let mut kept: Vec<f32> = ensemble.members.iter().map(|m| m.u[0][0]).collect();
        kept.sort_by(f32::total_cmp);
        assert_eq!(kept, vec![4.0, 6.0, 8.0]);
        // A ring smaller than MIN_MEMBERS is ready once full.
        assert!(ensemble.ready());
        assert!(!ErrorEnsemble::new(MIN_MEMBERS, 1).ready());
    }
}
