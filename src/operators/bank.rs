//! A bank of compensators (21): one per actuator of an array (a deformable
//! mirror has hundreds to thousands), stepped together.
//!
//! Every state and parameter is stored structure-of-arrays, element-major
//! and channel-minor (`x[i · C + c]`, creep `χ[(i · m + j) · C + c]`), and a
//! step runs each element over a
//! block of channels (4 in `f64`, 8 in `f32`: one AVX register), so SIMD goes
//! across channels and no channel waits for another. Each channel does the
//! arithmetic of [`Compensator`](crate::realtime::Compensator) in
//! the same order, so channel `c` of a bank and a single compensator of the
//! same model give the same bits (`verification/bank.rs`). The channels may
//! share one model or each have their own; all have the same orders.
//!
//! Like a single compensator, each channel inverts its model's memory part:
//! a channel whose model has a dead time `d` ([`CompensatorBank::delays`])
//! takes the target wanted `d` samples later.

use std::vec;
use std::vec::Vec;

use crate::operators::heap::Heap;
use crate::realtime::compensator::Compensated;
use crate::realtime::creep::creep_gain;
use crate::realtime::error::ParameterError;
use crate::realtime::hysteresis::reduce;
use crate::realtime::inverse::inverse_parameters_into;
use crate::realtime::parameters::{check_length, ModelParameters};
use crate::realtime::play::{clamp, play};
use crate::realtime::real::Real;
use crate::realtime::simd::{self, Kernels};
use crate::realtime::superposition::Superposition;
use crate::realtime::CompensatorSettings;

/// Channels are padded to a multiple of this (the widest block).
const PAD: usize = 8;

/// Parameters of every channel, element-major: `p[e · stride + c]`; with one
/// shared model `stride` is one block and every block reads offset 0.
#[derive(Debug, Clone, PartialEq)]
struct Parameters<T: Real> {
    inv_r: Vec<T>,
    inv_w: Vec<T>,
    r: Vec<T>,
    w: Vec<T>,
    s: Vec<T>,
    creep_r: Vec<T>,
    creep_w: Vec<T>,
    gains: Vec<T>,
    offset: Vec<T>,
    /// `S⁻¹` of each lane's model, if it has `S`.
    inverse_superposition: Vec<Option<Superposition<T, Heap>>>,
    stride: usize,
    shared: bool,
}

/// `N` compensators `W⁻¹` stepped together, in `T` (`f32` or `f64`).
#[derive(Debug, Clone, PartialEq)]
pub struct CompensatorBank<T: Real> {
    channels: usize,
    /// `channels` rounded up to a multiple of [`PAD`]: the state stride.
    padded: usize,
    plays: usize,
    creep_thresholds: usize,
    eigenvalues: usize,
    p: Parameters<T>,
    lower: T,
    upper: T,
    inv_x: Vec<T>,
    /// The inverse plays before the step (a saturated lane starts from them).
    scratch: Vec<T>,
    last_u: Vec<T>,
    chi: Vec<T>,
    creep_out: Vec<T>,
    creep_last: Vec<T>,
    io: Io<T>,
    /// Each channel's dead time (samples), for its caller's preview.
    delays: Vec<usize>,
}

impl<T: Real> CompensatorBank<T> {
    /// `channels` compensators of one model, virgin, with output limits
    /// `settings`.
    pub fn uniform(
        model: &ModelParameters<'_>,
        channels: usize,
        settings: CompensatorSettings,
    ) -> Result<Self, ParameterError> {
        Self::build(core::slice::from_ref(model), channels, true, settings)
    }

    /// One compensator per model in `models` (all of the same orders),
    /// virgin, with output limits `settings`.
    pub fn new(
        models: &[ModelParameters<'_>],
        settings: CompensatorSettings,
    ) -> Result<Self, ParameterError> {
        Self::build(models, models.len(), false, settings)
    }

    fn build(
        models: &[ModelParameters<'_>],
        channels: usize,
        shared: bool,
        settings: CompensatorSettings,
    ) -> Result<Self, ParameterError> {
        settings.validate()?;
        let (lower, upper) = (settings.lower_limit, settings.upper_limit);
        if channels == 0 {
            return Err(ParameterError::Empty {
                field: "bank.channels",
            });
        }
        let first = &models[0];
        let n = first.hysteresis.thresholds.len();
        let (nc, m) = first
            .creep
            .as_ref()
            .map_or((0, 0), |c| (c.thresholds.len(), c.eigenvalues.len()));
        for (channel, model) in models.iter().enumerate() {
            model.validate()?;
            let (mc, mm) = model
                .creep
                .as_ref()
                .map_or((0, 0), |c| (c.thresholds.len(), c.eigenvalues.len()));
            let mismatch = |field| ParameterError::ChannelMismatch { field, channel };
            if model.hysteresis.thresholds.len() != n {
                return Err(mismatch("hysteresis.thresholds"));
            }
            if mc != nc {
                return Err(mismatch("creep.thresholds"));
            }
            if mm != m {
                return Err(mismatch("creep.eigenvalues"));
            }
            if model.sample_time != first.sample_time {
                return Err(mismatch("sample_time"));
            }
        }
        let padded = channels.div_ceil(PAD) * PAD;
        let stride = if shared { PAD } else { padded };
        let param = |len: usize| vec![T::ZERO; len * stride];
        let mut p = Parameters {
            inv_r: param(n),
            inv_w: param(n),
            r: param(n),
            w: param(n),
            s: param(n),
            creep_r: param(nc),
            creep_w: param(nc),
            gains: param(m),
            offset: param(1),
            inverse_superposition: vec![None; stride],
            stride,
            shared,
        };
        let mut inv_r = vec![0.0; n];
        let mut inv_w = vec![0.0; n];
        for c in 0..stride {
            // padding lanes repeat the first model: finite, never read out
            let model = models.get(c).unwrap_or(first);
            let h = &model.hysteresis;
            inverse_parameters_into(h.thresholds, h.weights, &mut inv_r, &mut inv_w);
            let mut s = 0.0;
            for i in 0..n {
                s += h.weights[i];
                p.inv_r[i * stride + c] = T::from_f64(inv_r[i]);
                p.inv_w[i * stride + c] = T::from_f64(inv_w[i]);
                p.r[i * stride + c] = T::from_f64(h.thresholds[i]);
                p.w[i * stride + c] = T::from_f64(h.weights[i]);
                p.s[i * stride + c] = T::from_f64(s);
            }
            if let Some(cp) = &model.creep {
                for i in 0..nc {
                    p.creep_r[i * stride + c] = T::from_f64(cp.thresholds[i]);
                    p.creep_w[i * stride + c] = T::from_f64(cp.weights[i] / m as f64);
                }
                for (j, &a) in cp.eigenvalues.iter().enumerate() {
                    p.gains[j * stride + c] = T::from_f64(creep_gain(a, model.sample_time));
                }
            }
            p.offset[c] = T::from_f64(model.offset);
            if let Some(sp) = &model.superposition {
                p.inverse_superposition[c] = Some(Superposition::inverse_of(sp)?);
            }
        }
        let delays = (0..channels)
            .map(|c| models[if shared { 0 } else { c }].delay)
            .collect();
        Ok(Self {
            delays,
            channels,
            padded,
            plays: n,
            creep_thresholds: nc,
            eigenvalues: m,
            p,
            lower: T::from_f64_up(lower),
            upper: T::from_f64_down(upper),
            inv_x: vec![T::ZERO; n * padded],
            scratch: vec![T::ZERO; n * padded],
            last_u: vec![T::ZERO; padded],
            chi: vec![T::ZERO; nc * m * padded],
            creep_out: vec![T::ZERO; padded],
            creep_last: vec![T::ZERO; padded],
            io: Io {
                targets: vec![T::ZERO; padded],
                u: vec![T::ZERO; padded],
                saturated: vec![false; padded],
                fault: vec![false; padded],
            },
        })
    }

    /// The number of channels.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Each channel's dead time `d` (samples): its target at a step is the
    /// one wanted `d` samples later.
    pub fn delays(&self) -> &[usize] {
        &self.delays
    }

    /// One sample of every channel: `out[c]` is the voltage for
    /// `targets[c]`, with its flags as [`Compensated`] has them.
    /// Allocation-free; both slices must have [`Self::channels`] entries.
    pub fn compensate(
        &mut self,
        targets: &[T],
        out: &mut [Compensated<T>],
    ) -> Result<(), ParameterError> {
        self.run(targets, out, true)
    }

    /// [`CompensatorBank::compensate`] with the portable kernels only, no
    /// run-time dispatch (the same bits; for tests).
    #[doc(hidden)]
    pub fn compensate_portable(
        &mut self,
        targets: &[T],
        out: &mut [Compensated<T>],
    ) -> Result<(), ParameterError> {
        self.run(targets, out, false)
    }

    fn run(
        &mut self,
        targets: &[T],
        out: &mut [Compensated<T>],
        simd: bool,
    ) -> Result<(), ParameterError> {
        check_length("bank.targets", self.channels, targets.len())?;
        check_length("bank.out", self.channels, out.len())?;
        self.io.targets[..self.channels].copy_from_slice(targets);
        if simd {
            // the kernels chosen once per step, not per row
            Kernels::detect().run(|k| self.step_all(k));
        } else {
            self.step_all(Kernels::Portable);
        }
        for (c, o) in out.iter_mut().enumerate() {
            *o = Compensated {
                u: self.io.u[c],
                saturated: self.io.saturated[c],
                fault: self.io.fault[c],
            };
        }
        Ok(())
    }

    /// Back to the virgin state.
    pub fn reset(&mut self) {
        for v in [
            &mut self.inv_x,
            &mut self.last_u,
            &mut self.chi,
            &mut self.creep_out,
            &mut self.creep_last,
        ] {
            v.fill(T::ZERO);
        }
    }

    #[inline(always)]
    fn step_all(&mut self, k: Kernels) {
        if core::mem::size_of::<T>() == 4 {
            for c0 in (0..self.padded).step_by(8) {
                self.step_block::<8>(c0, k);
            }
        } else {
            for c0 in (0..self.padded).step_by(4) {
                self.step_block::<4>(c0, k);
            }
        }
    }

    /// Channels `c0..c0 + W`: what `Compensator::compensate` does, lane
    /// by lane, in its order of operations.
    #[inline(always)]
    fn step_block<const W: usize>(&mut self, c0: usize, k: Kernels) {
        let (n, nc, m) = (self.plays, self.creep_thresholds, self.eigenvalues);
        let cs = self.padded;
        let p = &self.p;
        let (ps, pb) = (p.stride, if p.shared { 0 } else { c0 });
        let lane = |v: &[T], e: usize| -> [T; W] { lane(v, e * ps + pb) };

        let mut fault = [false; W];
        let mut y = [T::ZERO; W];
        let offset = lane(&p.offset, 0);
        for l in 0..W {
            let t = self.io.targets[c0 + l];
            fault[l] = !t.is_finite();
            let target = match &p.inverse_superposition[pb + l] {
                Some(s) => s.apply(t - offset[l]),
                None => t - offset[l],
            };
            let y_l = target - self.creep_out[c0 + l];
            // hysteresis::step holds a non-finite input out
            y[l] = if y_l.is_finite() {
                y_l
            } else {
                self.inv_x[c0 + l]
            };
        }

        // H⁻¹: the plays of (22) and Σ w'_i x'_i
        for i in 0..n {
            let at = i * cs + c0;
            self.scratch[at..at + W].copy_from_slice(&self.inv_x[at..at + W]);
        }
        let inv_x = &mut self.inv_x;
        let v = sum_by_fours(n, |i, sum| {
            let x = block(inv_x, i * cs + c0);
            inverse_play(k, x, lane(&p.inv_r, i), lane(&p.inv_w, i), &y, &fault, sum);
        });

        // clip; a faulted lane holds its last voltage (x_0 of H)
        let mut u = [T::ZERO; W];
        let mut saturated = [false; W];
        for l in 0..W {
            let (u_l, s_l) = if v[l] < self.lower {
                (self.lower, true)
            } else if v[l] > self.upper {
                (self.upper, true)
            } else {
                (v[l], false)
            };
            u[l] = if fault[l] { self.last_u[c0 + l] } else { u_l };
            saturated[l] = s_l && !fault[l];
            self.last_u[c0 + l] = u[l];
        }
        if saturated.iter().any(|&s| s) {
            self.reseat(c0, &saturated, &u);
        }

        // creep (20), as creep::advance sums it
        let p = &self.p;
        let mut uc = [T::ZERO; W];
        for l in 0..W {
            uc[l] = if u[l].is_finite() {
                u[l]
            } else {
                self.creep_last[c0 + l]
            };
            self.creep_last[c0 + l] = uc[l];
        }
        let chi = &mut self.chi;
        let creep = sum_by_fours(nc, |i, acc| {
            let (r, w) = (lane(&p.creep_r, i), lane(&p.creep_w, i));
            let at = (i * m * cs + c0, cs);
            creep_row(k, chi, at, &p.gains, (ps, pb, m), &uc, r, w, acc);
        });
        self.creep_out[c0..c0 + W].copy_from_slice(&creep);
        self.io.u[c0..c0 + W].copy_from_slice(&u);
        self.io.saturated[c0..c0 + W].copy_from_slice(&saturated);
        self.io.fault[c0..c0 + W].copy_from_slice(&fault);
    }

    /// The saturated lanes as the single compensator re-seats: the plays of
    /// `H` from the inverse plays before the step, advanced with `u`, and the
    /// inverse plays from them (22).
    #[cold]
    #[inline(never)]
    fn reseat<const W: usize>(&mut self, c0: usize, saturated: &[bool; W], u: &[T; W]) {
        let (n, cs, ps) = (self.plays, self.padded, self.p.stride);
        for (l, _) in saturated.iter().enumerate().filter(|(_, &s)| s) {
            let c = c0 + l;
            let pc = if self.p.shared { l } else { c };
            let at = |j: usize| j * cs + c;
            let par = |v: &[T], j: usize| v[j * ps + pc];
            // forward_state_in_place, strided
            let mut next_inv = self.scratch[at(n - 1)];
            self.scratch[at(n - 1)] = next_inv / par(&self.p.s, n - 1);
            for j in (0..n - 1).rev() {
                let inv = self.scratch[at(j)];
                self.scratch[at(j)] =
                    self.scratch[at(j + 1)] + (inv - next_inv) / par(&self.p.s, j);
                next_inv = inv;
            }
            for j in 0..n {
                self.scratch[at(j)] = play(u[l], par(&self.p.r, j), self.scratch[at(j)]);
            }
            // inverse_state_into, strided
            let mut tail = T::ZERO;
            for j in (0..n).rev() {
                let x = self.scratch[at(j)];
                self.inv_x[at(j)] = par(&self.p.s, j) * x + tail;
                tail += par(&self.p.w, j) * x;
            }
        }
    }
}

/// Per-step inputs and outputs, padded.
#[derive(Debug, Clone, PartialEq)]
struct Io<T> {
    targets: Vec<T>,
    u: Vec<T>,
    saturated: Vec<bool>,
    fault: Vec<bool>,
}

/// `Σ_i f(i)` over `i < count` as `hysteresis::step` and `creep::advance`
/// sum: `f` adds term `i` into the partial sum `i mod 4` (whole blocks of
/// four first, so that a constant index keeps the partial sums in
/// registers), then the four partial sums are reduced.
#[inline(always)]
fn sum_by_fours<T: Real, const W: usize>(
    count: usize,
    mut f: impl FnMut(usize, &mut [T; W]),
) -> [T; W] {
    let mut sums = [[T::ZERO; W]; 4];
    let full = count - count % 4;
    for i0 in (0..full).step_by(4) {
        for (q, sum) in sums.iter_mut().enumerate() {
            f(i0 + q, sum);
        }
    }
    for i in full..count {
        f(i, &mut sums[i - full]);
    }
    let mut total = [T::ZERO; W];
    for l in 0..W {
        total[l] = reduce([sums[0][l], sums[1][l], sums[2][l], sums[3][l]]);
    }
    total
}

#[inline(always)]
fn lane<T: Real, const W: usize>(v: &[T], at: usize) -> [T; W] {
    v[at..at + W].try_into().unwrap()
}

#[inline(always)]
fn block<T: Real, const W: usize>(v: &mut [T], at: usize) -> &mut [T; W] {
    (&mut v[at..at + W]).try_into().unwrap()
}

/// One play of `H⁻¹` (22) over `W` channels; a faulted lane keeps its state.
/// On `k`'s kernels: 256-bit registers for `f64 × 4` and `f32 × 8` with
/// AVX2, the same operations lane by lane, so the same bits.
#[inline(always)]
fn inverse_play<T: Real, const W: usize>(
    k: Kernels,
    x: &mut [T; W],
    r: [T; W],
    w: [T; W],
    y: &[T; W],
    fault: &[bool; W],
    sum: &mut [T; W],
) {
    #[cfg(target_arch = "x86_64")]
    if let Some(lanes) = simd::lanes::<T, W>(k) {
        let mask: [T; W] = fault.map(|f| if f { T::NEG_INFINITY } else { T::ZERO });
        lanes.inverse_play(x, &r, &w, y, &mask, sum);
        return;
    }
    for l in 0..W {
        let new = clamp(x[l], y[l] - r[l], y[l] + r[l]);
        sum[l] += w[l] * new;
        x[l] = if fault[l] { x[l] } else { new };
    }
}

/// The `m` creep operators of one threshold over `W` channels (20), summed
/// as `creep::advance` sums them; `at = (first element, stride per
/// eigenvalue)`, `params = (stride, offset, m)` of the parameter arrays; on
/// `k`'s kernels, as [`inverse_play`].
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn creep_row<T: Real, const W: usize>(
    k: Kernels,
    chi: &mut [T],
    at: (usize, usize),
    gains: &[T],
    params: (usize, usize, usize),
    u: &[T; W],
    r: [T; W],
    w: [T; W],
    acc: &mut [T; W],
) {
    #[cfg(target_arch = "x86_64")]
    if let Some(lanes) = simd::lanes::<T, W>(k) {
        lanes.creep_row(chi, at, gains, params, u, &r, &w, acc);
        return;
    }
    let (e0, step) = at;
    let (ps, pb, m) = params;
    let mut lower = [T::ZERO; W];
    let mut upper = [T::ZERO; W];
    for l in 0..W {
        lower[l] = u[l] - r[l];
        upper[l] = u[l] + r[l];
    }
    let mut rows = [T::ZERO; W];
    for j in 0..m {
        let g: [T; W] = lane(gains, j * ps + pb);
        let x = block::<T, W>(chi, e0 + j * step);
        for l in 0..W {
            x[l] = x[l] + g[l] * (clamp(x[l], lower[l], upper[l]) - x[l]);
        }
        for l in 0..W {
            rows[l] += x[l];
        }
    }
    for l in 0..W {
        acc[l] += w[l] * rows[l];
    }
}
