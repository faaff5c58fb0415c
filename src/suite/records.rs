//! Synthetic lab records at several excitation rates, from an actuator whose
//! behaviour changes with the rate the way a piezo stage's does: play
//! thresholds that grow with the input rate (Al Janaideh–Krejčí,
//! `r_i + β|u_k − u_{k−1}|/T_s`), an asymmetric superposition operator,
//! creep, a lightly damped resonance and a sensor low-pass after them, a
//! history before each record (the state at its start is unknown), a
//! sensor offset per record and white measurement noise. Each record is
//! the lab protocol: a hold at `−A`, then raised-cosine cycles of rising
//! amplitude from `−A` up to `+A`; or a hold at another level (near 0 V,
//! say), which leaves the history's memory in the plays, and a tracking
//! run from there.
//!
//! The truth is not the identified model class when `β > 0` (no
//! compensator inverts it exactly): what an identification of these
//! records reaches shows what the model class carries from rate to rate.

use crate::operators::creep::CreepOperator;
use crate::operators::heap::Heap;
use crate::operators::model::{
    CreepData, DynamicsData, HysteresisData, ModelFile, SuperpositionData,
};
use crate::operators::nominal::nominal_model_file;
use crate::operators::rate_dependent::RateDependentHysteresis;
use crate::operators::traits::Snapshot;
use crate::realtime::{Dynamics, DynamicsParameters, Resonance, Superposition};
use crate::suite::conformance::Rng;

/// The actuator and the protocol of [`generate`].
#[derive(Debug, Clone, PartialEq)]
pub struct RecordSettings {
    /// Sample time (s), default 1e-4 (10 kHz).
    pub sample_time: f64,
    /// Rates of the records (Hz), default 20, 40, 100.
    pub rates: Vec<f64>,
    /// Drive amplitude `A` (V), default 90.
    pub amplitude: f64,
    /// The hold before the drive (s), default 1.5.
    pub hold: f64,
    /// The hold's level (V), default `−A` (saturation: the history is
    /// wiped out). Another level keeps the history's memory; a tracking
    /// run starts from it, the cycles from `−A`.
    pub hold_level: Option<f64>,
    /// Raised-cosine cycles per record, default 50.
    pub cycles: usize,
    /// `β` (s) of the rate-dependent thresholds, default 2e-5 (below
    /// `T_s`, so that each play stays monotone in its input).
    pub rate_gain: f64,
    /// The stage's resonance, default 740 Hz with damping 0.014.
    pub resonance: Option<Resonance>,
    /// The sensor's first-order low-pass (Hz), default 2 kHz.
    pub sensor_low_pass: Option<f64>,
    /// Noise (standard deviation) as a fraction of the output range,
    /// default 5e-4.
    pub noise: f64,
    /// Offsets drawn uniformly within this fraction of the output range,
    /// default 5e-3.
    pub offset_spread: f64,
    /// Seconds of random drive before each record, default 0.5.
    pub history: f64,
    pub seed: u64,
    /// The drive after the hold: raised cosines (default) or a tracking
    /// run.
    pub drive: Drive,
    /// The tracking run's levels lie within this fraction of `±A`
    /// (default 0.8); a smaller run than the history leaves the larger
    /// plays' memory in place.
    pub tracking_range: f64,
}

/// What follows the hold of a record.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Drive {
    /// `cycles` raised cosines of rising amplitude at the record's rate.
    #[default]
    Cycles,
    /// 2 s of a tracking task: random levels every `1/rate` s followed by a
    /// first-order lag, the voltage jagged with steps of ±A/6 every 5 ms
    /// (what a digital controller's output looks like).
    Tracking,
}

impl Default for RecordSettings {
    fn default() -> Self {
        Self {
            sample_time: 1e-4,
            rates: vec![20.0, 40.0, 100.0],
            amplitude: 90.0,
            hold: 1.5,
            hold_level: None,
            cycles: 50,
            rate_gain: 2e-5,
            resonance: Some(Resonance {
                frequency: 740.0,
                damping: 0.014,
            }),
            sensor_low_pass: Some(2000.0),
            noise: 5e-4,
            offset_spread: 5e-3,
            history: 0.5,
            seed: 20_131,
            drive: Drive::Cycles,
            tracking_range: 0.8,
        }
    }
}

impl RecordSettings {
    /// The actuator of these settings as a model file, virgin.
    pub fn actuator_model(&self) -> ModelFile {
        Actuator::new(self)
            .model_file(self.sample_time)
            .without_state()
    }
}

/// One generated record.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticRecord {
    /// Its rate (Hz).
    pub rate: f64,
    pub u: Vec<f64>,
    pub y: Vec<f64>,
    /// The sensor offset added.
    pub offset: f64,
    /// The actuator at the record's first sample as a model file, in its
    /// state then (offset and noise not included).
    pub start: ModelFile,
}

/// The record protocol at `rate`: the hold at `−A`, then `cycles` raised
/// cosines `−A + A a(t) (1 − cos 2πft)` with `a` rising from 0.1 to 1, or a
/// tracking run ([`Drive::Tracking`], its levels drawn from `rng`).
pub fn protocol(settings: &RecordSettings, rate: f64, rng: &mut Rng) -> Vec<f64> {
    let ts = settings.sample_time;
    let a = settings.amplitude;
    let hold = (settings.hold / ts).round() as usize;
    let level = settings.hold_level.unwrap_or(-a);
    if settings.drive == Drive::Tracking {
        let run = (2.0 / ts).round() as usize;
        let (every, jag) = (
            ((1.0 / rate) / ts).round().max(1.0) as usize,
            (0.005 / ts).round().max(1.0) as usize,
        );
        let (mut target, mut v) = (level, level);
        let lag = 1.0 - (-ts * std::f64::consts::TAU * 3.0 * rate).exp();
        return (0..hold + run)
            .map(|k| {
                if k < hold {
                    return level;
                }
                if (k - hold).is_multiple_of(every) {
                    target = rng.uniform(-settings.tracking_range * a, settings.tracking_range * a);
                }
                v += lag * (target - v);
                let step = if ((k - hold) / jag).is_multiple_of(2) {
                    a / 6.0
                } else {
                    -a / 6.0
                };
                (v + step).clamp(-a, a)
            })
            .collect();
    }
    let cycling = (settings.cycles as f64 / rate / ts).round() as usize;
    (0..hold + cycling)
        .map(|k| {
            if k < hold {
                return level;
            }
            let t = (k - hold) as f64 * ts;
            let rise = 0.1 + 0.9 * (k - hold) as f64 / cycling.max(1) as f64;
            -a + a * rise * (1.0 - (std::f64::consts::TAU * rate * t).cos())
        })
        .collect()
}

/// The actuator of [`generate`], stepped one sample at a time.
struct Actuator {
    hysteresis: RateDependentHysteresis,
    /// `β` (s), as given: the model file's.
    rate_gain: f64,
    creep: CreepOperator,
    superposition: Superposition<f64, Heap>,
    dynamics: Option<Dynamics<f64>>,
}

impl Actuator {
    /// The nominal model's loops scaled from ±1000 V to ±`A`, its creep,
    /// an asymmetric `S`, and the dynamics of `settings`.
    fn new(settings: &RecordSettings) -> Self {
        let nominal = nominal_model_file();
        let scale = settings.amplitude / 1000.0;
        let r: Vec<f64> = nominal
            .hysteresis
            .thresholds
            .iter()
            .map(|r| r * scale)
            .collect();
        let c = nominal.creep.as_ref().expect("the nominal model has creep");
        let creep = CreepOperator::new(
            c.thresholds.iter().map(|r| r * scale).collect::<Vec<f64>>(),
            c.weights.clone(),
            c.eigenvalues.clone(),
            settings.sample_time,
        )
        .expect("the nominal creep is valid");
        let a = settings.amplitude;
        let superposition = Superposition::new(
            [-0.5 * a, -0.2 * a, 0.0, 0.15 * a, 0.4 * a],
            [0.25, -0.25, 1.0, -0.2, -0.15],
        )
        .expect("a valid S");
        let g = DynamicsParameters {
            low_pass: settings.sensor_low_pass,
            resonance: settings.resonance,
            delay_fraction: 0.0,
        };
        let dynamics = (!g.is_identity())
            .then(|| Dynamics::new(&g, settings.sample_time).expect("valid dynamics"));
        Self {
            hysteresis: RateDependentHysteresis::forward_only(
                r,
                nominal.hysteresis.weights.clone(),
                settings.rate_gain / settings.sample_time,
            ),
            rate_gain: settings.rate_gain,
            creep,
            superposition,
            dynamics,
        }
    }

    fn step(&mut self, u: f64) -> f64 {
        let h = self.hysteresis.step(u);
        let w = self.superposition.apply(h + self.creep.step(u));
        match &mut self.dynamics {
            Some(g) => g.step(w),
            None => w,
        }
    }

    /// The actuator as a model file, in its state.
    fn model_file(&self, sample_time: f64) -> ModelFile {
        ModelFile {
            sample_time,
            hysteresis: HysteresisData {
                thresholds: self.hysteresis.thresholds().to_vec(),
                weights: self.hysteresis.weights().to_vec(),
                state: Some(self.hysteresis.play_states().to_vec()),
                rate_gain: (self.rate_gain != 0.0).then_some(self.rate_gain),
                last_input: self
                    .hysteresis
                    .last_input()
                    .filter(|_| self.rate_gain != 0.0),
            },
            creep: Some(CreepData {
                thresholds: self.creep.thresholds().to_vec(),
                weights: self.creep.weights().to_vec(),
                eigenvalues: self.creep.eigenvalues().to_vec(),
                state: Some(Snapshot::state(&self.creep)),
            }),
            superposition: Some(SuperpositionData {
                thresholds: self.superposition.thresholds().to_vec(),
                weights: self.superposition.weights().to_vec(),
            }),
            dynamics: self.dynamics.as_ref().map(|g| {
                let mut state = vec![0.0; g.state_len()];
                DynamicsData {
                    state: g.state_into(&mut state).map(|()| state),
                    ..DynamicsData::of(g.parameters())
                }
            }),
            delay: None,
            delay_state: None,
            offset: None,
        }
    }
}

/// The records of `settings` (module docs), each after its own history.
pub fn generate(settings: &RecordSettings) -> Vec<SyntheticRecord> {
    let mut rng = Rng::new(settings.seed);
    let mut actuator = Actuator::new(settings);
    let ts = settings.sample_time;
    let a = settings.amplitude;
    let range = 2.0 * a;
    let mut records = Vec::with_capacity(settings.rates.len());
    for &rate in &settings.rates {
        // a history: random levels held and ramped, within ±A
        let history = (settings.history / ts).round() as usize;
        let mut level = 0.0;
        for k in 0..history {
            if k.is_multiple_of(500) {
                level = rng.uniform(-a, a);
            }
            actuator.step(level);
        }
        let u = protocol(settings, rate, &mut rng);
        let start = actuator.model_file(ts);
        let offset = rng.uniform(-1.0, 1.0) * settings.offset_spread * range;
        let y = u
            .iter()
            .map(|&v| actuator.step(v) + offset + settings.noise * range * gaussian(&mut rng))
            .collect();
        records.push(SyntheticRecord {
            rate,
            u,
            y,
            offset,
            start,
        });
    }
    records
}

/// A standard normal draw (Box–Muller).
fn gaussian(rng: &mut Rng) -> f64 {
    let u1 = rng.uniform(f64::MIN_POSITIVE, 1.0);
    let u2 = rng.uniform(0.0, 1.0);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}
