//! Exact second-order statistics of a simulated record, from the components actually drawn:
//! a channel sum_i |c_i| cos(w_e,i t + phi_i) has the (time-average) autocorrelation
//! R(tau) = sum_i |c_i|^2 cos(w_e,i tau) / 2, which is what the optimal linear predictor of the
//! record needs, and its variance is R(0).

use super::motion::{ShipMotion, CHANNELS, WAVE_CHANNEL};
use shipcast_wire::Dof;
use std::f64::consts::TAU;

/// A channel of the simulated record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channel {
    Motion(Dof),
    /// Wave elevation at the centre of gravity.
    Wave,
}

impl Channel {
    /// The six DOF then the wave.
    pub const ALL: [Channel; CHANNELS] = [
        Channel::Motion(Dof::Surge),
        Channel::Motion(Dof::Sway),
        Channel::Motion(Dof::Heave),
        Channel::Motion(Dof::Roll),
        Channel::Motion(Dof::Pitch),
        Channel::Motion(Dof::Yaw),
        Channel::Wave,
    ];

    pub fn index(self) -> usize {
        match self {
            Channel::Motion(d) => d.index(),
            Channel::Wave => WAVE_CHANNEL,
        }
    }

    /// Name with unit as in the motion CSV (`heave_m`, `wave_m`).
    pub fn column(self) -> &'static str {
        match self {
            Channel::Motion(d) => d.csv_column(),
            Channel::Wave => "wave_m",
        }
    }
}

impl ShipMotion {
    /// |c_i|^2 / 2 for each component of a channel: its share of the variance.
    fn energies(&self, channel: Channel) -> impl Iterator<Item = (f64, f64)> + '_ {
        let j = channel.index();
        self.coefficients
            .iter()
            .map(move |k| (k.omega_e, (k.re[j] * k.re[j] + k.im[j] * k.im[j]) / 2.0))
    }

    /// Exact variance of a channel (units squared).
    pub fn variance(&self, channel: Channel) -> f64 {
        self.energies(channel).map(|(_, e)| e).sum()
    }

    /// Exact autocorrelation R(k dt) of a DOF for k = 0..=max_lag.
    pub fn autocorrelation(&self, dof: Dof, dt: f64, max_lag: usize) -> Vec<f64> {
        self.channel_autocorrelation(Channel::Motion(dof), dt, max_lag)
    }

    /// Exact autocorrelation of any channel, for k = 0..=max_lag.
    pub fn channel_autocorrelation(&self, channel: Channel, dt: f64, max_lag: usize) -> Vec<f64> {
        let mut r = vec![0.0; max_lag + 1];
        for (we, e) in self.energies(channel) {
            // Phasor recurrence over the lags; lags are few enough (thousands) for no drift.
            let (s1, c1) = (we * dt).sin_cos();
            let (mut c, mut s) = (1.0, 0.0);
            for v in r.iter_mut() {
                *v += e * c;
                (c, s) = (c * c1 - s * s1, s * c1 + c * s1);
            }
        }
        r
    }

    /// Encounter-frequency spectrum of a channel as a histogram: bin `b` covers
    /// [b d_omega, (b+1) d_omega) and holds the variance density [unit^2 s / rad] there.
    pub fn encounter_spectrum(&self, channel: Channel, d_omega: f64, bins: usize) -> Vec<f64> {
        let mut out = vec![0.0; bins];
        if d_omega <= 0.0 {
            return out;
        }
        for (we, e) in self.energies(channel) {
            let b = (we / d_omega) as usize;
            if let Some(v) = out.get_mut(b) {
                *v += e / d_omega;
            }
        }
        out
    }

    /// Period [s] at the peak of a channel's encounter spectrum (0.02 rad/s bins, lightly
    /// smoothed so that one large random component does not decide it); None for a channel the
    /// sea does not excite (e.g. roll in long-crested head seas).
    pub fn peak_encounter_period(&self, channel: Channel) -> Option<f64> {
        const D_OMEGA: f64 = 0.02;
        // Rounding (sin(pi) = 1.2e-16) leaves a trace of energy in channels the sea does not
        // excite; far below any real response per metre of wave, whatever the unit.
        if self.variance(channel) <= 1e-20 * self.variance(Channel::Wave) {
            return None;
        }
        let hist = self.encounter_spectrum(channel, D_OMEGA, 400);
        let smooth = |i: usize| {
            let lo = i.saturating_sub(2);
            let hi = (i + 3).min(hist.len());
            hist[lo..hi].iter().sum::<f64>()
        };
        // Bin 0 would be an infinite period: waves that keep pace with the ship.
        let best = (1..hist.len()).max_by(|&a, &b| smooth(a).total_cmp(&smooth(b)))?;
        Some(TAU / ((best as f64 + 0.5) * D_OMEGA))
    }
}
