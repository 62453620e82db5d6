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
//!
//! Errors that depend on the mean: the engine delivers a mean shrunk towards zero (beta ramped
//! in below its least-squares value where skill is marginal, docs/forecasting.md), so what
//! happens lies, on average, a little further out than the mean says, in the mean's direction.
//! Replayed on the paper sea, the errors of the deck decisions' calls had E[u sign(mean)] =
//! +0.05 to +0.11 for roll and pitch. Put on another forecast's mean, such a member's error
//! points in a random direction, and the ensemble over-stated every bin by 1-4 points. So each
//! member also keeps its standardised mean z = mean / sigma, and per quantity and step the
//! ensemble fits u = c z + r by least squares over its members (c clamped to [-1, 1]); a
//! member is put on the current forecast as c z_now + r, its own residual on the current
//! standardised mean. With errors independent of the mean, c is 0 up to noise and nothing
//! changes.

use super::{is_unbounded, NUM_QUANTITIES};
use shipcast_wire::payload::MAX_STEPS;

/// Members before the ensemble replaces the Gaussian model: fewer verified error paths
/// (strongly dependent ones at that) leave a share too coarse to state 0.95 honestly.
pub const MIN_MEMBERS: usize = 150;

/// Default ring size and stride: at 2 forecasts per second, one member every 2 s over the
/// last 20 minutes (a sea state's scale, as the engine's skill tracking uses).
pub const DEFAULT_CAPACITY: usize = 600;
pub const DEFAULT_STRIDE: usize = 4;

/// Largest |c| of the error-on-mean regression: an error that grows by more than the mean
/// itself is not a stable fit.
const MAX_MEAN_SLOPE: f64 = 1.0;

#[derive(Debug, Clone)]
struct Member<const Q: usize> {
    steps: usize,
    u: [[f32; MAX_STEPS]; Q],
    /// The forecast's standardised mean, mean / sigma (0 where either is missing).
    z: [[f32; MAX_STEPS]; Q],
}

/// `Q` quantities, each with its own limit: the deck's four (roll, pitch, the deck's vertical
/// displacement and velocity) by default, the lift's three relative axes.
#[derive(Debug, Clone)]
pub struct ErrorEnsemble<const Q: usize = NUM_QUANTITIES> {
    members: Vec<Member<Q>>,
    capacity: usize,
    /// Next ring slot to overwrite once full.
    next: usize,
    stride: usize,
    offered: u64,
    /// Sums over the members of u z and z^2 per quantity and step, for the errors' regression
    /// on the mean: kept as members come and go, so a decision does not revisit every member
    /// for them, and summed afresh each time the ring wraps so that rounding cannot build up.
    uz: [[f64; MAX_STEPS]; Q],
    zz: [[f64; MAX_STEPS]; Q],
}

impl<const Q: usize> Default for ErrorEnsemble<Q> {
    fn default() -> Self {
        Self::new(DEFAULT_CAPACITY, DEFAULT_STRIDE)
    }
}

impl<const Q: usize> ErrorEnsemble<Q> {
    pub fn new(capacity: usize, stride: usize) -> Self {
        let capacity = capacity.max(1);
        Self {
            members: Vec::with_capacity(capacity),
            capacity,
            next: 0,
            stride: stride.max(1),
            offered: 0,
            uz: [[0.0; MAX_STEPS]; Q],
            zz: [[0.0; MAX_STEPS]; Q],
        }
    }

    pub fn len(&self) -> usize {
        self.members.len()
    }

    /// Forget every member (keeping the storage): the errors came from a motion that is gone.
    pub fn clear(&mut self) {
        self.members.clear();
        self.next = 0;
        self.offered = 0;
        self.uz = [[0.0; MAX_STEPS]; Q];
        self.zz = [[0.0; MAX_STEPS]; Q];
    }

    pub fn is_empty(&self) -> bool {
        self.members.is_empty()
    }

    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Whether there are enough members to decide from.
    pub fn ready(&self) -> bool {
        self.enough(self.members.len())
    }

    /// Whether `members` of them (those covering a forecast, from [`Self::failures`]) are
    /// enough to decide from: as many as make the ensemble ready.
    pub fn enough(&self, members: usize) -> bool {
        members >= MIN_MEMBERS.min(self.capacity)
    }

    /// The most steps that enough members cover ([`Self::enough`]), at most `steps`: how far
    /// ahead windows can be judged from verified paths (0 when none is far enough).
    pub fn covered_steps(&self, steps: usize) -> usize {
        let top = steps.min(MAX_STEPS);
        // Members per length, those longer than `top` counted at `top`.
        let mut of_length = [0usize; MAX_STEPS + 1];
        for m in &self.members {
            of_length[m.steps.min(top)] += 1;
        }
        let mut covering = 0;
        for length in (1..=top).rev() {
            covering += of_length[length];
            if self.enough(covering) {
                return length;
            }
        }
        0
    }

    /// Offer the standardised errors of one verified forecast (`u[q][k]`, `steps` steps) and
    /// its standardised means (`z[q][k]`). A non-finite u (a missing value) counts as no
    /// error; a non-finite z as a zero mean. A miss at sigma 0 arrives finite
    /// ([`super::UNBOUNDED_ERROR`]), and [`Self::failures`] counts it as broken. One offer in
    /// `stride` is kept. Never allocates: the ring's storage is reserved by `new`.
    pub fn offer(&mut self, u: &[[f64; MAX_STEPS]; Q], z: &[[f64; MAX_STEPS]; Q], steps: usize) {
        let keep = self.offered.is_multiple_of(self.stride as u64);
        self.offered += 1;
        if !keep {
            return;
        }
        let steps = steps.min(MAX_STEPS);
        let finite = |v: f64| if v.is_finite() { v as f32 } else { 0.0 };
        let member = |m: &mut Member<Q>| {
            m.steps = steps;
            for q in 0..Q {
                for k in 0..steps {
                    m.u[q][k] = finite(u[q][k]);
                    m.z[q][k] = finite(z[q][k]);
                }
            }
        };
        if self.members.len() < self.capacity {
            let mut m = Member {
                steps: 0,
                u: [[0.0; MAX_STEPS]; Q],
                z: [[0.0; MAX_STEPS]; Q],
            };
            member(&mut m);
            Self::accumulate(&mut self.uz, &mut self.zz, &m, 1.0);
            self.members.push(m);
        } else {
            let slot = self.next;
            let old = &self.members[slot];
            Self::accumulate(&mut self.uz, &mut self.zz, old, -1.0);
            member(&mut self.members[slot]);
            self.next = (slot + 1) % self.capacity;
            if self.next == 0 {
                self.uz = [[0.0; MAX_STEPS]; Q];
                self.zz = [[0.0; MAX_STEPS]; Q];
                for m in &self.members {
                    Self::accumulate(&mut self.uz, &mut self.zz, m, 1.0);
                }
            } else {
                let new = &self.members[slot];
                Self::accumulate(&mut self.uz, &mut self.zz, new, 1.0);
            }
        }
    }

    fn accumulate(
        uz: &mut [[f64; MAX_STEPS]; Q],
        zz: &mut [[f64; MAX_STEPS]; Q],
        m: &Member<Q>,
        sign: f64,
    ) {
        for q in 0..Q {
            for k in 0..m.steps {
                let (u, z) = (f64::from(m.u[q][k]), f64::from(m.z[q][k]));
                uz[q][k] += sign * u * z;
                zz[q][k] += sign * z * z;
            }
        }
    }

    /// Per quantity and step, the least-squares slope c of the members' errors on their
    /// standardised means (u = c z + r) over the members reaching that step; 0 where no
    /// member has a mean.
    fn mean_slopes(&self, steps: usize, c: &mut [[f64; MAX_STEPS]; Q]) {
        for ((row, uz), zz) in c.iter_mut().zip(&self.uz).zip(&self.zz) {
            for ((c, &uz), &zz) in row.iter_mut().zip(uz).zip(zz).take(steps) {
                // Sums this small are what rounding leaves of members gone (or zero means).
                *c = if zz > 1e-6 {
                    (uz / zz).clamp(-MAX_MEAN_SLOPE, MAX_MEAN_SLOPE)
                } else {
                    0.0
                };
            }
        }
    }

    /// For every member covering `steps` steps, the prefix counts of the steps at which some
    /// quantity breaks its limit when the member's errors are put on `mean` and `sigma` (its
    /// residual on the errors' regression on the mean, on the current mean's place in it):
    /// `fail_before[i * (MAX_STEPS + 1) + k]` for member i, k = 0..=steps. Returns, per member,
    /// whether it covers the forecast (`usable[i]`), and how many do. Neither buffer is
    /// reallocated once sized.
    pub fn failures(
        &self,
        mean: &[[f64; MAX_STEPS]; Q],
        sigma: &[[f64; MAX_STEPS]; Q],
        limits: &[f64; Q],
        steps: usize,
        fail_before: &mut Vec<u16>,
        usable: &mut Vec<bool>,
    ) -> usize {
        let row = MAX_STEPS + 1;
        fail_before.resize(self.capacity * row, 0);
        usable.resize(self.capacity, false);
        let steps = steps.min(MAX_STEPS);
        let mut c = [[0.0f64; MAX_STEPS]; Q];
        self.mean_slopes(steps, &mut c);
        // The current forecast's place on the regression, c z_now, per quantity and step.
        let mut shift = [[0.0f64; MAX_STEPS]; Q];
        for q in 0..Q {
            for k in 0..steps {
                let s = sigma[q][k];
                shift[q][k] = if s > 0.0 {
                    c[q][k] * mean[q][k] / s
                } else {
                    0.0
                };
            }
        }
        for (i, m) in self.members.iter().enumerate() {
            usable[i] = m.steps >= steps;
            if !usable[i] {
                continue;
            }
            let counts = &mut fail_before[i * row..(i + 1) * row];
            counts[0] = 0;
            for k in 0..steps {
                let breaks = (0..Q).any(|q| {
                    let u = f64::from(m.u[q][k]);
                    let residual = u - c[q][k] * f64::from(m.z[q][k]);
                    let value = mean[q][k] + sigma[q][k] * (shift[q][k] + residual);
                    // A miss where sigma was 0 breaks the limit whatever this forecast's sigma
                    // is: put on a sigma of 0 it would vanish, and a source that always states
                    // 0 would be told its misses hold (review).
                    value.is_nan() || value.abs() > limits[q] || is_unbounded(u)
                });
                counts[k + 1] = counts[k] + u16::from(breaks);
            }
        }
        for u in usable.iter_mut().skip(self.members.len()) {
            *u = false;
        }
        usable.iter().filter(|&&u| u).count()
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

    /// Standardised means of forecasts that predicted zero: no regression on the mean.
    const NO_MEAN: [[f64; MAX_STEPS]; NUM_QUANTITIES] = [[0.0; MAX_STEPS]; NUM_QUANTITIES];

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
            ensemble.offer(u, &NO_MEAN, steps);
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
    fn errors_that_grow_with_the_mean_are_put_on_the_current_mean_by_their_regression() {
        // One step, quantity 0 limited at 2.5 sigma. Members: forecasts with standardised
        // means z ~ N(0, 1) whose errors are u = c z + e, e ~ N(0, 1): what happened lay c z
        // further out than the mean said. The current forecast has mean 1.5 sigma, so the
        // value is 1.5 (1 + c) + e and the window holds with Phi(2.5 - 1.5 (1 + c)) -
        // Phi(-2.5 - 1.5 (1 + c)). Treating the members' errors as noise independent of the
        // mean would give about Phi(1.0 / sqrt(1 + c^2)): 0.83 against 0.71 for c = 0.3.
        use crate::deck::normal_cdf;
        let normal = Normal::new(0.0, 1.0).unwrap();
        let within = |centre: f64, sd: f64| {
            normal_cdf((2.5 - centre) / sd) - normal_cdf((-2.5 - centre) / sd)
        };
        let mut mean = [[0.0; MAX_STEPS]; NUM_QUANTITIES];
        let mut sigma = [[0.0; MAX_STEPS]; NUM_QUANTITIES];
        mean[0][0] = 1.5;
        sigma[0][0] = 1.0;
        let limits = [2.5, 1e9, 1e9, 1e9];
        for (c, seed) in [(0.3, 7), (0.0, 8), (-0.2, 9)] {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let mut ensemble = ErrorEnsemble::new(4000, 1);
            let (mut u, mut z) = (NO_MEAN, NO_MEAN);
            for _ in 0..4000 {
                z[0][0] = normal.sample(&mut rng);
                u[0][0] = c * z[0][0] + normal.sample(&mut rng);
                ensemble.offer(&u, &z, 1);
            }
            let (mut fail, mut usable) = (Vec::new(), Vec::new());
            ensemble.failures(&mean, &sigma, &limits, 1, &mut fail, &mut usable);
            let share = share_within(&fail, &usable, 0, 1).unwrap();
            let exact = within(1.5 * (1.0 + c), 1.0);
            let naive = within(1.5, (1.0 + c * c).sqrt());
            // 4000 independent members: binomial standard error below 0.008; the fitted c
            // is within about 0.02 of its value.
            assert!((share - exact).abs() < 0.03, "c {c}: {share} vs {exact}");
            if c != 0.0 {
                assert!(
                    (naive - exact).abs() > 0.06,
                    "c {c}: the case must discriminate"
                );
            }
        }
    }

    #[test]
    fn the_regression_sums_follow_the_members_as_the_ring_turns() {
        // Paths of varying length into a ring of 7: after every offer the running sums equal
        // the sums over the members held, wrapped or not.
        let normal = Normal::new(0.0, 1.0).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let mut ensemble = ErrorEnsemble::new(7, 1);
        let (mut u, mut z) = (NO_MEAN, NO_MEAN);
        for i in 0..100 {
            let steps = 1 + i % 5;
            for q in 0..NUM_QUANTITIES {
                for k in 0..steps {
                    z[q][k] = 3.0 * normal.sample(&mut rng);
                    u[q][k] = 0.5 * z[q][k] + normal.sample(&mut rng);
                }
            }
            ensemble.offer(&u, &z, steps);
            for q in 0..NUM_QUANTITIES {
                for k in 0..5 {
                    let (mut uz, mut zz) = (0.0, 0.0);
                    for m in ensemble.members.iter().filter(|m| m.steps > k) {
                        uz += f64::from(m.u[q][k]) * f64::from(m.z[q][k]);
                        zz += f64::from(m.z[q][k]).powi(2);
                    }
                    assert!((ensemble.uz[q][k] - uz).abs() < 1e-9, "{i} {q} {k}");
                    assert!((ensemble.zz[q][k] - zz).abs() < 1e-9, "{i} {q} {k}");
                }
            }
        }
    }

    #[test]
    fn a_member_that_breaks_one_quantity_breaks_the_window_and_shorter_members_are_not_used() {
        let mut ensemble = ErrorEnsemble::new(10, 1);
        let mut calm = [[0.0; MAX_STEPS]; NUM_QUANTITIES];
        let mut rough = calm;
        rough[2][5] = 10.0; // deck displacement error of 10 sigma at step 5
        ensemble.offer(&calm, &NO_MEAN, 10);
        ensemble.offer(&rough, &NO_MEAN, 10);
        calm[0][0] = f64::NAN; // counts as no error
        ensemble.offer(&calm, &NO_MEAN, 10);
        ensemble.offer(&calm, &NO_MEAN, 4); // too short for a 10-step forecast
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
            ensemble.offer(&u, &NO_MEAN, 1);
        }
        // Offers 0, 2, 4, 6, 8 were kept; the ring of 3 holds 4, 6 and 8.
        let mut kept: Vec<f32> = ensemble.members.iter().map(|m| m.u[0][0]).collect();
        kept.sort_by(f32::total_cmp);
        assert_eq!(kept, vec![4.0, 6.0, 8.0]);
        // A ring smaller than MIN_MEMBERS is ready once full.
        assert!(ensemble.ready());
        assert!(!ErrorEnsemble::<NUM_QUANTITIES>::new(MIN_MEMBERS, 1).ready());
    }
}
