//! Seeded generators of conformance cases: admissible random models, inputs
//! of several shapes, nested extrema for the branching rules.

use crate::operators::model::{
    CreepData, DynamicsData, HysteresisData, LowPassData, ModelFile, ResonanceData,
    SuperpositionData,
};
use crate::suite::conformance::Case;
use crate::suite::reference::NaiveModel;

/// SplitMix64: small, seeded, the same on every platform.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Uniform integer in `lo..=hi`.
    pub fn int(&mut self, lo: usize, hi: usize) -> usize {
        lo + (self.next_u64() % (hi - lo + 1) as u64) as usize
    }

    /// True with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
}

/// What kind of model a property needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelShape {
    /// Creep or not, virgin or not, at random.
    Any,
    /// With or without creep, always virgin (odd symmetry needs the zero state).
    Virgin,
    /// Hysteresis only, virgin (rate independence and the branching rules).
    HysteresisOnly,
}

/// A random admissible model: `1..=max_plays` plays with threshold increments
/// in `[5, 100]` V, partial sums in `[0.05, 1]` (single weights often
/// negative), with probability 0.7 a creep part (`1..=max_plays` thresholds,
/// partial sums in `[0, 0.1]`, 1 to 6 eigenvalues log-uniform in
/// `[0.01, 1000]` s⁻¹), and for [`ModelShape::Any`] with probability 0.3 an
/// output offset and with probability 0.5 a non-virgin state reached by a
/// random history; except for [`ModelShape::HysteresisOnly`] with
/// probability 0.4 a superposition operator, and for [`ModelShape::Any`]
/// with probability 0.3 a dead time of 1 to 3 samples.
pub fn random_model(rng: &mut Rng, max_plays: usize, shape: ModelShape) -> ModelFile {
    let sample_time = if rng.chance(0.5) {
        2e-4
    } else {
        10f64.powf(rng.uniform(-4.0, -2.0))
    };
    let plays = rng.int(1, max_plays.max(1));
    let thresholds = increasing(rng, plays);
    let weights = from_sums((0..plays).map(|_| rng.uniform(0.05, 1.0)).collect());
    let creep = (shape != ModelShape::HysteresisOnly && rng.chance(0.7)).then(|| {
        let n = rng.int(1, max_plays.max(1));
        let m = rng.int(1, 6);
        CreepData {
            thresholds: increasing(rng, n),
            weights: from_sums((0..n).map(|_| rng.uniform(0.0, 0.1)).collect()),
            eigenvalues: (0..m).map(|_| 10f64.powf(rng.uniform(-2.0, 3.0))).collect(),
            state: None,
        }
    });
    let file = ModelFile {
        sample_time,
        hysteresis: HysteresisData {
            thresholds,
            weights,
            state: None,
            rate_gain: None,
            last_input: None,
        },
        creep,
        superposition: None,
        dynamics: None,
        delay: None,
        delay_state: None,
        offset: None,
    };
    let mut file = file;
    // a sensor offset, as in a measurement (it breaks odd symmetry, so only
    // where a property does not need it)
    if shape == ModelShape::Any && rng.chance(0.3) {
        file.offset = Some(rng.uniform(-0.2, 0.2) * reach(&file));
    }
    let mut file = if shape == ModelShape::Any && rng.chance(0.5) {
        let reach = reach(&file);
        let len = rng.int(1, 60);
        let history = random_input(rng, len, 1.2 * reach);
        with_state_after(&file, &history)
    } else {
        file
    };
    // drawn last, so that the rest of a case is what it was without `S`
    if shape != ModelShape::HysteresisOnly && rng.chance(0.4) {
        file.superposition = Some(random_superposition(rng, reach(&file)));
    }
    // and the dead time after it (the branching rules and odd symmetry
    // take the output sample by sample, so only where a property does not)
    if shape == ModelShape::Any && rng.chance(0.3) {
        file.delay = Some(rng.int(1, 3));
    }
    file
}

/// The model of a case: in the fixed mode the fixed model, else a random
/// one of `shape` ([`random_model`]).
pub fn case_model(
    rng: &mut Rng,
    settings: &super::ConformanceSettings,
    shape: ModelShape,
) -> ModelFile {
    match &settings.fixed_model {
        Some(m) => m.clone(),
        None => {
            let mut file = random_model(rng, settings.max_plays, shape);
            // drawn last, so that without dynamics a case is what it was
            if settings.dynamics && shape == ModelShape::Any && rng.chance(0.3) {
                file.dynamics = Some(random_dynamics(rng, file.sample_time));
            }
            file
        }
    }
}

/// Random dynamics: a low-pass, a resonance or both, their frequencies
/// log-uniform in `[0.05, 0.4]` of the sample rate, the damping
/// log-uniform in `[0.02, 0.7]` (lighter damping is allowed, but its
/// rounding bounds grow as `1/ζ²`, too loose to test anything in `f32`),
/// and with probability 1/2 a delay fraction uniform in `(−0.45, 0.45)`.
pub fn random_dynamics(rng: &mut Rng, sample_time: f64) -> DynamicsData {
    let fs = 1.0 / sample_time;
    let frequency = |rng: &mut Rng| fs * 10f64.powf(rng.uniform(0.05f64.log10(), 0.4f64.log10()));
    let which = rng.int(0, 2);
    let fraction = rng.chance(0.5).then(|| rng.uniform(-0.45, 0.45));
    DynamicsData {
        delay_fraction: fraction,
        low_pass: (which != 1).then(|| LowPassData {
            frequency: frequency(rng),
        }),
        resonance: (which != 0).then(|| ResonanceData {
            frequency: frequency(rng),
            damping: 10f64.powf(rng.uniform(0.02f64.log10(), 0.7f64.log10())),
        }),
        state: None,
    }
}

/// Case `i` of a property on general models; the first one (`i = 0`) with a
/// superposition operator, an offset and a dead time where the draw left
/// them out, and an input long enough for the dead time to show. A run of a
/// few cases then covers each part, not by luck (a part in 30 % of the
/// draws is absent from both of two cases half the time).
pub fn with_every_part(
    rng: &mut Rng,
    s: &super::ConformanceSettings,
    i: usize,
    mut case: super::Case,
) -> super::Case {
    if i > 0 {
        return case;
    }
    let file = &mut case.model;
    if s.dynamics && file.dynamics.is_none() {
        file.dynamics = Some(random_dynamics(rng, file.sample_time));
    }
    if file.offset.is_none() {
        file.offset = Some(rng.uniform(-0.2, 0.2) * reach(file));
    }
    if file.superposition.is_none() {
        file.superposition = Some(random_superposition(rng, reach(file)));
    }
    if file.delay.is_none() {
        file.delay = Some(rng.int(1, 3));
    }
    if case.input.len() < 8 {
        let reach = reach(&case.model);
        case.input = random_input(rng, 8, 1.2 * reach);
    }
    case
}

/// The model's dead time `d` (samples): the identity through a compensator
/// holds from sample `d` on.
pub fn delay_of(file: &ModelFile) -> usize {
    let lag = file.dynamics.as_ref().map_or(0, |g| g.parameters().lag());
    file.delay.unwrap_or(0) + lag
}

/// A random admissible superposition operator for `H + C` of reach about
/// `scale`: 0 to 3 dead zones per side, thresholds in `(0, 0.8 scale)`,
/// slopes in `[0.2, 2]`; with probability 0.3 odd (mirrored sides).
pub fn random_superposition(rng: &mut Rng, scale: f64) -> SuperpositionData {
    let side = |rng: &mut Rng, n: usize, w0: f64| -> (Vec<f64>, Vec<f64>) {
        let mut r: Vec<f64> = (0..n).map(|_| rng.uniform(0.02, 0.8) * scale).collect();
        r.sort_by(f64::total_cmp);
        r.dedup();
        let mut slope = w0;
        let w = r
            .iter()
            .map(|_| {
                let next = rng.uniform(0.2, 2.0);
                let w = next - slope;
                slope = next;
                w
            })
            .collect();
        (r, w)
    };
    let w0 = rng.uniform(0.2, 2.0);
    let n = rng.int(0, 3);
    let positive = side(rng, n, w0);
    let negative = if rng.chance(0.3) {
        positive.clone()
    } else {
        let n = rng.int(0, 3);
        side(rng, n, w0)
    };
    let mut thresholds: Vec<f64> = negative.0.iter().rev().map(|r| -r).collect();
    let mut weights: Vec<f64> = negative.1.iter().rev().copied().collect();
    thresholds.push(0.0);
    weights.push(w0);
    thresholds.extend(&positive.0);
    weights.extend(&positive.1);
    SuperpositionData {
        thresholds,
        weights,
    }
}

/// A model that is a random `S` alone (`H` one play of threshold 0 and
/// weight 1, the identity; no creep), at a scale between 1 and 1000, and an
/// input sweeping up and down across all of its thresholds (no limits).
pub fn superposition_model(rng: &mut Rng, samples: usize) -> Case {
    let scale = 10f64.powf(rng.uniform(0.0, 3.0));
    let file = ModelFile {
        sample_time: 2e-4,
        hysteresis: HysteresisData {
            thresholds: vec![0.0],
            weights: vec![1.0],
            state: None,
            rate_gain: None,
            last_input: None,
        },
        creep: None,
        superposition: Some(random_superposition(rng, scale)),
        dynamics: None,
        delay: None,
        delay_state: None,
        offset: rng.chance(0.5).then(|| rng.uniform(-0.2, 0.2) * scale),
    };
    let input = random_input(rng, samples.max(2), 1.2 * scale);
    Case {
        model: file,
        input,
        limits: None,
    }
}

/// Whether `S` is odd (`S[−z] = −S[z]`): mirrored thresholds and weights,
/// or absent.
pub fn superposition_is_odd(file: &ModelFile) -> bool {
    let Some(s) = &file.superposition else {
        return true;
    };
    let n = s.thresholds.len();
    (0..n).all(|i| {
        s.thresholds[i] == -s.thresholds[n - 1 - i] && s.weights[i] == s.weights[n - 1 - i]
    })
}

fn increasing(rng: &mut Rng, n: usize) -> Vec<f64> {
    let mut r = vec![0.0];
    for _ in 1..n {
        let last = *r.last().unwrap();
        r.push(last + rng.uniform(5.0, 100.0));
    }
    r
}

/// Weights whose partial sums are `sums`.
fn from_sums(sums: Vec<f64>) -> Vec<f64> {
    let mut prev = 0.0;
    sums.into_iter()
        .map(|s| {
            let w = s - prev;
            prev = s;
            w
        })
        .collect()
}

/// The largest threshold of the model (at least 1).
pub fn reach(file: &ModelFile) -> f64 {
    let rh = file.hysteresis.thresholds.last().copied().unwrap_or(0.0);
    let rc = file
        .creep
        .as_ref()
        .and_then(|c| c.thresholds.last().copied())
        .unwrap_or(0.0);
    rh.max(rc).max(1.0)
}

/// The model file with the state the reference model has after `history`
/// (from the file's own state): the state semantics of the model file.
pub fn with_state_after(file: &ModelFile, history: &[f64]) -> ModelFile {
    use crate::operators::traits::Operator;
    let mut m = NaiveModel::from_file(file).expect("generated models are valid");
    m.run(history);
    let mut out = file.clone();
    out.hysteresis.state = Some(m.hysteresis.x.clone());
    if let (Some(c), Some(mc)) = (&mut out.creep, &m.creep) {
        c.state = Some(mc.chi.clone());
    }
    if !m.pending.is_empty() {
        out.delay_state = Some(m.pending.iter().copied().collect());
    }
    if let (Some(g), Some(mg)) = (&mut out.dynamics, &m.dynamics) {
        let state = mg.state();
        g.state = (!state.is_empty()).then_some(state);
    }
    out
}

/// The length of a random input: with probability 0.2 one to three samples
/// (first-sample conventions and loop bounds are where implementations
/// differ, so short inputs are drawn on purpose, not left to shrinking),
/// else 4 to `max_samples`.
pub fn input_length(rng: &mut Rng, max_samples: usize) -> usize {
    if rng.chance(0.2) {
        rng.int(1, 3)
    } else {
        rng.int(4, max_samples.max(4))
    }
}

/// A random input of `len` samples within `±amplitude`, made of segments:
/// ramps to random levels, holds, steps and noise around a level.
pub fn random_input(rng: &mut Rng, len: usize, amplitude: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(len);
    let mut v = 0.0;
    while out.len() < len {
        let seg = rng.int(1, 40).min(len - out.len());
        match rng.int(0, 3) {
            0 => {
                let to = rng.uniform(-amplitude, amplitude);
                for j in 1..=seg {
                    out.push(v + (to - v) * j as f64 / seg as f64);
                }
                v = to;
            }
            1 => out.extend(std::iter::repeat_n(v, seg)),
            2 => {
                v = rng.uniform(-amplitude, amplitude);
                out.extend(std::iter::repeat_n(v, seg));
            }
            _ => {
                let width = 0.05 * amplitude;
                for _ in 0..seg {
                    out.push((v + rng.uniform(-width, width)).clamp(-amplitude, amplitude));
                }
            }
        }
    }
    out
}

/// Nested extrema `e_0 > 0 > e_1`, each next one strictly between the two
/// before it, followed by one more fraction in `(0, 1)` (where the property
/// reverses).
pub fn nested_extrema(rng: &mut Rng, amplitude: f64) -> Vec<f64> {
    let mut e = vec![
        rng.uniform(0.3, 1.0) * amplitude,
        -rng.uniform(0.3, 1.0) * amplitude,
    ];
    for _ in 0..rng.int(1, 6) {
        let n = e.len();
        let f = rng.uniform(0.05, 0.95);
        e.push(e[n - 1] + f * (e[n - 2] - e[n - 1]));
    }
    e.push(rng.uniform(0.05, 0.95));
    e
}

/// Whether `e` (without its last entry, the fraction) is a nested sequence
/// of extrema and the fraction lies in `(0, 1)`.
pub fn valid_extrema(e: &[f64]) -> bool {
    if e.len() < 3 {
        return false;
    }
    let (ext, f) = (&e[..e.len() - 1], e[e.len() - 1]);
    if !(f > 0.0 && f < 1.0 && ext.iter().all(|x| x.is_finite())) {
        return false;
    }
    if ext[0] <= 0.0 || ext[1] >= 0.0 {
        return false;
    }
    (2..ext.len()).all(|k| {
        let (a, b) = (ext[k - 2], ext[k - 1]);
        let (lo, hi) = if a < b { (a, b) } else { (b, a) };
        ext[k] > lo && ext[k] < hi
    })
}

/// Samples from `from` (exclusive) to `to` (inclusive, exactly) in `sub` steps.
pub fn segment(from: f64, to: f64, sub: usize) -> Vec<f64> {
    (1..=sub)
        .map(|j| {
            if j == sub {
                to
            } else {
                from + (to - from) * j as f64 / sub as f64
            }
        })
        .collect()
}

/// A path from 0 through `points`, `sub` samples per leg.
pub fn path(points: &[f64], sub: usize) -> Vec<f64> {
    let mut out = vec![0.0];
    let mut last = 0.0;
    for &p in points {
        out.extend(segment(last, p, sub));
        last = p;
    }
    out
}

/// `k` linearly interpolated samples inserted between consecutive samples.
pub fn refine(v: &[f64], k: usize) -> Vec<f64> {
    let mut out = vec![v[0]];
    for w in v.windows(2) {
        for j in 1..=k {
            out.push(w[0] + (w[1] - w[0]) * j as f64 / (k + 1) as f64);
        }
        out.push(w[1]);
    }
    out
}
