//! Landing go/no-go decisions from a forecast: operator limits on roll, pitch and the deck
//! point's vertical displacement and velocity, a minimum operation time (MOT), and for every
//! forecast the probability that every limit holds over the whole of a window of MOT, from the
//! joint distribution of the forecast errors across steps (docs/decisions.md).
//!
//! Error model: per quantity, the standardised errors form a Gaussian AR(1) chain in lead
//! (corr between steps i and j = rho^|i-j|, rho from verified forecasts: [`ErrorCorrelation`]),
//! and the quantities' chains are treated as independent of one another, so the window
//! probability is the product of the per-quantity chain probabilities ([`window`]). Once
//! enough forecasts were verified, the errors that really happened replace that model: the
//! probability is the share of an ensemble of recent verified error paths under which the
//! window holds ([`ensemble`]).

pub mod correlation;
pub mod ensemble;
pub mod outcomes;
pub mod recalibrate;
pub mod reliability;
pub mod score;
pub mod statements_file;
pub mod still;
mod tracks;
mod verdict;
pub mod window;

use crate::config::DeckConfig;
use crate::deck::ShipPoint;
pub use correlation::ErrorCorrelation;
pub use ensemble::ErrorEnsemble;
use recalibrate::StatementRecord;
use shipcast_wire::payload::{Forecast, MAX_STEPS};
use shipcast_wire::Dof;
use still::{StillWatch, Stillness, WATCHED};
pub use tracks::{
    is_unbounded, standardised_error, standardised_errors, standardised_means, Tracks,
    UNBOUNDED_ERROR,
};
pub use verdict::{withdrawn_sample, Decision};
use window::{chain_within, cholesky_block, correlated_within, Lattice};

/// The limited quantities, in the order of every per-quantity array here.
pub const QUANTITIES: [&str; 4] = ["roll", "pitch", "deck_vertical_m", "deck_vertical_mps"];
pub const NUM_QUANTITIES: usize = 4;

const HEAVE: usize = Dof::Heave.index();
const ROLL: usize = Dof::Roll.index();
const PITCH: usize = Dof::Pitch.index();

/// Lattice points per window probability: 128 keeps the estimate within about a point of the
/// exact value (window::tests measure it against a Monte Carlo) at a cost the live service
/// and replay can afford for every candidate window.
pub const LATTICE_POINTS: usize = 128;

/// Steps in a window of `mot_s` at step `dt_s` (usize::MAX for a step that is not positive).
pub fn window_steps(mot_s: f64, dt_s: f64) -> usize {
    if dt_s.is_nan() || dt_s <= 0.0 {
        return usize::MAX;
    }
    ((mot_s / dt_s) - 1e-9).ceil().max(1.0) as usize
}

/// Operator limits in SI units (rad, rad, m, m/s), in the order of [`QUANTITIES`].
pub fn limits(config: &DeckConfig) -> [f64; NUM_QUANTITIES] {
    [
        config.roll_limit_deg.to_radians(),
        config.pitch_limit_deg.to_radians(),
        config.vertical_displacement_limit_m,
        config.vertical_velocity_limit_mps,
    ]
}

/// Turns forecasts into decisions; holds its buffers, so deciding does not allocate.
#[derive(Debug, Clone)]
pub struct Decider {
    point: ShipPoint,
    limits: [f64; NUM_QUANTITIES],
    mot_s: f64,
    go_probability: f64,
    go_needs_verified: bool,
    rho: [f64; NUM_QUANTITIES],
    lattice: Lattice,
    tracks: Box<Tracks>,
    /// Steps before k at which some mean breaks its limit (prefix counts).
    breaks_before: [u32; MAX_STEPS + 1],
    /// Full error correlation per quantity over `full_steps` steps (0: none, the AR(1) chain
    /// with `rho` is used), and work buffers for its Cholesky factor.
    full: Vec<Vec<f64>>,
    full_steps: [usize; NUM_QUANTITIES],
    chol: Vec<f64>,
    y: Vec<f64>,
    /// Verified error paths, and per member the prefix counts of the loaded forecast's
    /// broken steps under them (used when `from_ensemble`).
    ensemble: ErrorEnsemble,
    fail_before: Vec<u16>,
    usable: Vec<bool>,
    /// How many members cover the loaded forecast.
    usable_members: usize,
    from_ensemble: bool,
    u: Box<[[f64; MAX_STEPS]; NUM_QUANTITIES]>,
    z: Box<[[f64; MAX_STEPS]; NUM_QUANTITIES]>,
    /// Verified statements per window length (steps), which correct the ensemble's new ones
    /// ([`recalibrate`]).
    records: Vec<(usize, StatementRecord)>,
    /// The last decision's window length and uncorrected probability now, if it came from
    /// the ensemble (what its outcome is recorded against).
    raw_now: Option<(usize, f64)>,
    /// Window lengths that have had an outcome in this run (never evicted for another).
    in_use: Vec<usize>,
    /// The recorded values at the loaded forecast's `time_s`, if it was loaded with them.
    origin: Option<[f64; 6]>,
    /// How long the recorded heave, roll and pitch have repeated their values ([`still`]).
    still: StillWatch,
    /// Per watched DOF, the verified statements as they were when its current stillness
    /// began: what a thaw goes back to (those of earlier runs included).
    records_before_still: [Option<Vec<(usize, StatementRecord)>>; WATCHED.len()],
    /// Record time of the last thaw: forecasts issued before it were waiting for their
    /// horizon while the sensor was still, so their errors and outcomes are not evidence
    /// ([`Self::takes_evidence_from`]). Minus infinity until a thaw.
    evidence_since_s: f64,
}

/// Verified calls in a set of statement records.
fn calls(records: &[(usize, StatementRecord)]) -> f64 {
    records.iter().map(|(_, r)| r.calls()).sum()
}

/// Window lengths whose statements are recorded (a deck decides for one MOT; replay scores two).
pub const MAX_RECORDS: usize = 8;

impl Decider {
    pub fn new(config: &DeckConfig) -> Self {
        let ensemble = ErrorEnsemble::default();
        Self {
            point: ShipPoint::new(config.point_m),
            limits: limits(config),
            mot_s: config.mot_s,
            go_probability: config.go_probability,
            go_needs_verified: config.go_needs_verified_errors,
            rho: config.error_correlation,
            lattice: Lattice::new(LATTICE_POINTS, MAX_STEPS),
            tracks: Box::default(),
            breaks_before: [0; MAX_STEPS + 1],
            full: vec![vec![0.0; MAX_STEPS * MAX_STEPS]; NUM_QUANTITIES],
            full_steps: [0; NUM_QUANTITIES],
            chol: vec![0.0; MAX_STEPS * MAX_STEPS],
            y: vec![0.0; MAX_STEPS],
            fail_before: vec![0; ensemble.capacity() * (MAX_STEPS + 1)],
            usable: vec![false; ensemble.capacity()],
            usable_members: 0,
            ensemble,
            from_ensemble: false,
            u: Box::new([[f64::NAN; MAX_STEPS]; NUM_QUANTITIES]),
            z: Box::new([[f64::NAN; MAX_STEPS]; NUM_QUANTITIES]),
            records: Vec::with_capacity(MAX_RECORDS),
            in_use: Vec::with_capacity(MAX_RECORDS),
            raw_now: None,
            origin: None,
            still: StillWatch::default(),
            records_before_still: Default::default(),
            evidence_since_s: f64::NEG_INFINITY,
        }
    }

    /// Add a verified forecast to the error ensemble: its standardised errors (u = (actual -
    /// mean) / sigma per quantity and step, as this decider's tracks define them) and its
    /// standardised means (z = mean / sigma).
    pub fn add_verified(
        &mut self,
        u: &[[f64; MAX_STEPS]; NUM_QUANTITIES],
        z: &[[f64; MAX_STEPS]; NUM_QUANTITIES],
        steps: usize,
    ) {
        self.ensemble.offer(u, z, steps);
    }

    /// Verify a forecast this decider loaded (`predicted`, a copy of [`Self::tracks`] then)
    /// against what happened (`actual`, filled by [`Self::fill_tracks`] from the recorded
    /// values at its steps): its errors join the ensemble. The live deck's path
    /// ([`outcomes`]); replay hands the same errors over through [`Self::add_verified`].
    /// Returns the steps of its standardised errors ([`Self::verified_errors`]).
    pub fn verify(&mut self, predicted: &Tracks, actual: &Tracks) -> usize {
        let steps = standardised_errors(predicted, actual, &mut self.u);
        standardised_means(predicted, &mut self.z);
        self.ensemble.offer(&self.u, &self.z, steps);
        steps
    }

    /// The standardised errors of the forecast [`Self::verify`] verified last.
    pub fn verified_errors(&self) -> &[[f64; MAX_STEPS]; NUM_QUANTITIES] {
        &self.u
    }

    /// The tracks of the recorded values in `actual.mean` (its sigma unused), as this
    /// decider's forecast tracks are made.
    /// The origin the loaded forecast was loaded with ([`Self::load_from`]).
    pub fn origin(&self) -> Option<[f64; 6]> {
        self.origin
    }

    pub fn fill_tracks(&self, actual: &Forecast, out: &mut Tracks) {
        out.fill(&self.point, actual, 0.0);
    }

    /// What happened over a forecast's horizon, as [`Self::fill_tracks`], with the recorded
    /// values at its `time_s` (`before`) and one step past its horizon (`after`), where known:
    /// `actual`, the tracks its errors are taken against (central at the first step, as the
    /// forecast's own tracks loaded with the same `before`), and `judged`, central at both
    /// ends, on which whether every limit held is judged ([`Tracks::central_ends`]).
    pub fn fill_happened(
        &self,
        recorded: &Forecast,
        before: Option<&[f64; 6]>,
        after: Option<&[f64; 6]>,
        actual: &mut Tracks,
        judged: &mut Tracks,
    ) {
        actual.fill(&self.point, recorded, 0.0);
        actual.central_ends(&self.point, before, None);
        judged.clone_from(actual);
        judged.central_ends(&self.point, None, after);
    }

    pub fn ensemble(&self) -> &ErrorEnsemble {
        &self.ensemble
    }

    pub fn limits(&self) -> &[f64; NUM_QUANTITIES] {
        &self.limits
    }

    pub fn error_correlation(&self) -> [f64; NUM_QUANTITIES] {
        self.rho
    }

    /// Use these step-to-step correlations (e.g. estimated from verified forecasts).
    pub fn set_error_correlation(&mut self, rho: [f64; NUM_QUANTITIES]) {
        self.rho = rho.map(|r| {
            if r.is_finite() {
                r.clamp(0.0, 1.0)
            } else {
                0.0
            }
        });
    }

    /// Use the full error correlations of `estimate` where it has them (else the AR(1) chain).
    pub fn set_error_matrices(&mut self, estimate: &ErrorCorrelation, steps: usize) {
        for q in 0..NUM_QUANTITIES {
            self.full_steps[q] = if estimate.matrix(q, steps, &mut self.full[q]) {
                steps
            } else {
                0
            };
        }
    }

    /// Steps in a window of this decider's MOT at step `dt_s`.
    pub fn window_steps(&self, dt_s: f64) -> usize {
        window_steps(self.mot_s, dt_s)
    }

    pub fn tracks(&self) -> &Tracks {
        &self.tracks
    }

    /// Load a forecast: its tracks and where their means break a limit.
    pub fn load(&mut self, forecast: &Forecast) {
        self.load_from(forecast, None);
    }

    /// [`Self::load`] with the recorded DOF values at the forecast's `time_s` (`origin`), when
    /// the caller has them: the deck velocity at the first step is then a central difference
    /// like every other step's, not the velocity half a step later ([`Tracks::central_ends`]).
    pub fn load_from(&mut self, forecast: &Forecast, origin: Option<&[f64; 6]>) {
        self.tracks.fill(&self.point, forecast, self.rho[2]);
        self.tracks.central_ends(&self.point, origin, None);
        self.origin = origin.copied();
        if let Some(values) = origin {
            self.watch_stillness(forecast.time_s, values);
        }
        let t = &self.tracks;
        for k in 0..t.steps {
            let breaks = (0..NUM_QUANTITIES)
                .any(|q| t.mean[q][k].is_nan() || t.mean[q][k].abs() > self.limits[q]);
            self.breaks_before[k + 1] = self.breaks_before[k] + u32::from(breaks);
        }
        self.from_ensemble = self.ensemble.ready();
        if self.from_ensemble {
            let usable = self.ensemble.failures(
                &t.mean,
                &t.sigma,
                &self.limits,
                t.steps,
                &mut self.fail_before,
                &mut self.usable,
            );
            // Only paths as long as the forecast count, and as many as make the ensemble ready:
            // after the horizon grew, a handful of long paths (or none, which would leave the
            // Gaussian model deciding) is no basis for a go.
            self.from_ensemble = self.ensemble.enough(usable);
            self.usable_members = usable;
        }
    }

    /// Whether the loaded means hold every limit over steps [start, start + len).
    pub fn mean_holds(&self, start: usize, len: usize) -> bool {
        let end = start + len;
        end <= self.tracks.steps && self.breaks_before[end] == self.breaks_before[start]
    }

    /// Probability that every limit holds over steps [start, start + len) of the loaded
    /// forecast: the ensemble's share corrected by the verified statements of that window
    /// length ([`recalibrate`]), or the Gaussian model's probability.
    pub fn window_probability(&mut self, start: usize, len: usize) -> f64 {
        let raw = self.raw_window_probability(start, len);
        self.corrected(len, raw)
    }

    /// `raw`, a probability of a window of `len` steps of the loaded forecast, corrected by
    /// the verified statements of that length (when it comes from the ensemble).
    pub fn corrected(&self, len: usize, raw: f64) -> f64 {
        self.corrected_for(len, raw, self.go_probability)
    }

    /// [`Self::corrected`] as a deck configured with go threshold `go_probability` would
    /// correct it (never raised to that threshold): replay's curve of thresholds.
    pub fn corrected_for(&self, len: usize, raw: f64, go_probability: f64) -> f64 {
        match self.record(len) {
            Some(r) if self.from_ensemble => r.correct(raw, go_probability),
            _ => raw,
        }
    }

    /// Whether the loaded forecast's probabilities come from verified error paths.
    pub fn uses_ensemble(&self) -> bool {
        self.from_ensemble
    }

    fn record(&self, len: usize) -> Option<&StatementRecord> {
        self.records.iter().find(|(n, _)| *n == len).map(|(_, r)| r)
    }

    /// A verified call: the window of `len` steps from the first was stated (uncorrected) to
    /// hold with `p_raw`, and did (`held`) or did not.
    ///
    /// A window length not yet recorded when [`MAX_RECORDS`] are (a statements file that
    /// runs with other MOTs filled) takes the place of the record with the fewest calls among
    /// those no outcome of this run has reached, with a warning: the lengths in use now must
    /// keep learning (a deck decides for one, replay scores two), and never evict each other.
    pub fn add_outcome(&mut self, len: usize, p_raw: f64, held: bool) {
        if !self.in_use.contains(&len) && self.in_use.len() < MAX_RECORDS {
            self.in_use.push(len);
        }
        if let Some((_, r)) = self.records.iter_mut().find(|(n, _)| *n == len) {
            r.add(p_raw, held);
        } else if self.records.len() < MAX_RECORDS {
            let mut r = StatementRecord::default();
            r.add(p_raw, held);
            self.records.push((len, r));
        } else if let Some((n, r)) = self
            .records
            .iter_mut()
            .filter(|(n, _)| !self.in_use.contains(n))
            .min_by(|(_, a), (_, b)| a.calls().total_cmp(&b.calls()))
        {
            tracing::warn!(
                "deck statements: {MAX_RECORDS} window lengths are recorded already; the \
                 window of {n} steps ({} verified calls from earlier runs) gives way to the \
                 window of {len} steps in use now",
                r.calls()
            );
            *n = len;
            r.clear();
            r.add(p_raw, held);
        }
        // Else every recorded length is in use this run: only more than MAX_RECORDS window
        // lengths deciding at once get here, which no station does.
    }

    /// The verified statements per window length (steps), as a statements file keeps them.
    pub fn statement_records(&self) -> impl Iterator<Item = (usize, &StatementRecord)> {
        self.records.iter().map(|(n, r)| (*n, r))
    }

    /// Verified statements recorded so far, over every window length.
    pub fn statement_calls(&self) -> f64 {
        calls(&self.records)
    }

    /// Start from the verified statements of an earlier run (a statements file's, checked),
    /// in place of those recorded so far. At most [`MAX_RECORDS`] window lengths are kept
    /// ([`statements_file::StatementsFile::records`] refuses a file with more, so none is
    /// dropped here from a checked file).
    pub fn adopt_statements(&mut self, records: Vec<(usize, StatementRecord)>) {
        self.records.clear();
        self.records.extend(records.into_iter().take(MAX_RECORDS));
    }

    /// The last decision's window length and uncorrected probability now, when it came from
    /// verified errors (the statement its outcome is recorded against).
    pub fn raw_now(&self) -> Option<(usize, f64)> {
        self.raw_now
    }

    /// Whether every limit held at the first `len` steps of `actual` (tracks of what
    /// happened, as [`Decider::fill_tracks`] makes them).
    pub fn window_held(&self, actual: &Tracks, len: usize) -> bool {
        len <= actual.steps && (0..len).all(|k| self.step_held(actual, k))
    }

    /// Whether every limit held at step `k` of `actual` (tracks of what happened).
    pub fn step_held(&self, actual: &Tracks, k: usize) -> bool {
        (0..NUM_QUANTITIES).all(|q| actual.mean[q][k].abs() <= self.limits[q])
    }

    /// [`Decider::window_probability`] before the correction by verified statements.
    pub fn raw_window_probability(&mut self, start: usize, len: usize) -> f64 {
        let t = &self.tracks;
        let end = (start + len).min(t.steps);
        if start >= end {
            return 0.0;
        }
        if self.from_ensemble {
            if let Some(p) = ensemble::share_within(&self.fail_before, &self.usable, start, end) {
                return p;
            }
        }
        let mut p = 1.0;
        for q in 0..NUM_QUANTITIES {
            let (mean, sigma) = (&t.mean[q][start..end], &t.sigma[q][start..end]);
            let m = self.full_steps[q];
            let full = (m == t.steps
                && cholesky_block(&self.full[q], m, start, end - start, &mut self.chol))
            .then(|| {
                correlated_within(
                    mean,
                    sigma,
                    self.limits[q],
                    &self.chol,
                    &self.lattice,
                    &mut self.y,
                )
            })
            .flatten();
            p *= full.unwrap_or_else(|| {
                chain_within(mean, sigma, self.limits[q], self.rho[q], &self.lattice)
            });
            if p == 0.0 {
                break;
            }
        }
        p
    }

    /// The deck DOF whose sensor repeats its value (`still.rs`), if any.
    pub fn frozen(&self) -> Option<Dof> {
        self.still.frozen()
    }

    /// Whether the loaded forecast's probabilities may say go: they come from verified
    /// errors, or the configuration lets the Gaussian model decide, and no sensor behind them
    /// is frozen.
    pub fn may_go(&self) -> bool {
        (self.from_ensemble || !self.go_needs_verified) && self.still.frozen().is_none()
    }

    /// Whether the errors and outcome of a forecast issued at record time `issued_s` may be
    /// verified into this decider (its ensemble and statements): not if it was issued before
    /// the last thaw. Such a forecast was decided while a sensor repeated its value, and its
    /// horizon straddles the thaw, so what it verifies is partly the stillness. The live
    /// deck's outcomes and replay's scorer ask before [`Self::verify`], [`Self::add_verified`]
    /// and [`Self::add_outcome`]. Review: forecasts waiting at a thaw still added their
    /// evidence after the thaw had dropped the rest.
    pub fn takes_evidence_from(&self, issued_s: f64) -> bool {
        // A non-finite time is the caller's to judge (it cannot be verified anyway).
        issued_s.is_nan() || issued_s >= self.evidence_since_s
    }

    /// Tell the watch of the recorded heave, roll and pitch that the record has these DOFs
    /// (replay knows; [`still::StillWatch::set_present`]).
    pub fn set_present_dofs(&mut self, dofs: &[Dof]) {
        self.still.set_present(dofs);
    }

    /// Look at the recorded values at `time_s` for sensors that repeat their value ([`still`]):
    /// keep the statements as they are when a stillness begins, and go back to them when it
    /// ends.
    fn watch_stillness(&mut self, time_s: f64, values: &[f64; 6]) {
        let frozen_before = self.still.frozen();
        let look = self.still.observe(time_s, values);
        if look.restarted {
            // The old run's clock says nothing about the new one's forecasts.
            self.evidence_since_s = f64::NEG_INFINITY;
            // A new run. One that starts while a sensor was frozen ends that stillness as a
            // thaw would (the watch finds the sensor again if it is still stuck); after it no
            // stillness of the old run is left to undo.
            if let Some(dof) = frozen_before {
                if let Some(i) = WATCHED.iter().position(|&d| d == dof) {
                    self.forget_stillness(i, time_s);
                }
            }
            self.records_before_still = Default::default();
        }
        for (i, found) in look.dofs.into_iter().enumerate() {
            match found {
                // Rare (a stillness starts), so the copy is no burden on deciding. A stillness
                // that begins during another one goes back as far as that one does: the
                // statements since it began are statements about nothing too.
                Stillness::Began => {
                    let earliest = self
                        .records_before_still
                        .iter()
                        .flatten()
                        .min_by(|a, b| calls(a).total_cmp(&calls(b)))
                        .cloned();
                    self.records_before_still[i] =
                        Some(earliest.unwrap_or_else(|| self.records.clone()));
                }
                Stillness::Resumed => self.forget_stillness(i, time_s),
                Stillness::Moving | Stillness::Still => {}
            }
        }
    }

    /// Watched DOF `i` moved again (or a new run began) after repeating its value for minutes:
    /// the verified errors describe a motion that is gone (errors of nothing) and are dropped,
    /// so go waits for errors verified on the motion as it is now; the statements go back to
    /// what they were when the stillness began, those verified during it being statements about
    /// nothing; and forecasts issued before now are no evidence when their horizon has passed.
    fn forget_stillness(&mut self, i: usize, time_s: f64) {
        tracing::warn!(
            "deck: {} moves again at t={time_s:.1}s after repeating its value for at least \
             {}s; the verified errors gathered so far, the statements verified since it \
             stopped and the decisions still waiting for their horizon are dropped, and go \
             waits for new ones",
            WATCHED[i].name(),
            still::STILL_AFTER_S
        );
        self.ensemble.clear();
        self.evidence_since_s = time_s;
        if let Some(records) = self.records_before_still[i].take() {
            self.records = records;
        }
        self.raw_now = None;
    }

    /// First step at which a mean breaks a limit.
    pub fn first_break(&self) -> Option<usize> {
        (0..self.tracks.steps).find(|&k| self.breaks_before[k + 1] > self.breaks_before[k])
    }

    /// The decision for a forecast.
    pub fn decide(&mut self, forecast: &Forecast) -> Decision {
        self.decide_from(forecast, None)
    }

    /// [`Self::decide`] on the forecast loaded with its `origin` ([`Self::load_from`]).
    pub fn decide_from(&mut self, forecast: &Forecast, origin: Option<&[f64; 6]>) -> Decision {
        self.load_from(forecast, origin);
        let dt = self.tracks.dt_s;
        let steps = self.tracks.steps;
        let n = self.window_steps(dt);
        let time = |k: usize| (k + 1) as f64 * dt;
        let mut decision = Decision {
            mot_s: self.mot_s,
            go_probability: self.go_probability,
            go: false,
            probability_now: None,
            next_window_s: None,
            next_window_probability: None,
            next_exceedance_s: self.first_break().map(time),
            error_correlation: self.rho,
            ensemble_members: if self.from_ensemble {
                self.usable_members
            } else {
                0
            },
            awaiting_verified_errors: false,
            frozen_dof: None,
        };
        self.raw_now = None;
        // Before verified errors back it (unless the configuration lets the Gaussian model
        // decide) no probability is stated: the model's, with the no-skill sigma of the first
        // minutes, was off by up to 68 points on replayed records (docs/decisions.md).
        if n > steps {
            return decision;
        }
        if let Some(dof) = self.still.frozen() {
            decision.frozen_dof = Some(dof);
            return decision;
        }
        if !self.may_go() {
            decision.awaiting_verified_errors = true;
            return decision;
        }
        let raw = self.raw_window_probability(0, n);
        if self.from_ensemble {
            self.raw_now = Some((n, raw));
        }
        let now = self.corrected(n, raw);
        decision.probability_now = Some(now);
        decision.go = now >= self.go_probability;
        if let Some((s, p)) = self.next_window(n, self.go_probability) {
            decision.next_window_s = Some(time(s));
            decision.next_window_probability = Some(p);
        }
        decision
    }

    /// First start whose window of `n` steps holds with at least `threshold`: only windows
    /// whose means hold every limit are candidates (one whose mean breaks a limit has a
    /// probability below a half).
    pub fn next_window(&mut self, n: usize, threshold: f64) -> Option<(usize, f64)> {
        let steps = self.tracks.steps;
        for s in 0..=steps.checked_sub(n)? {
            if self.mean_holds(s, n) {
                let p = self.window_probability(s, n);
                if p >= threshold {
                    return Some((s, p));
                }
            }
        }
        None
    }
}

#[cfg(test)]
mod tests;
