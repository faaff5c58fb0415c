//! A bank of compensators (21): one per actuator of an array (a deformable
//! mirror has hundreds to thousands), stepped together.
//!
//! The channels are grouped in blocks of one cache line of lanes (8 in
//! `f64`, 16 in `f32`), and each block's whole state is contiguous, row by
//! row — the inverse plays (twice: the step reads one copy and writes the
//! other, so the plays before a clipped sample are still there for its
//! re-seat), the creep states, the last voltage, creep output and creep
//! input — so that a step streams through memory once and SIMD goes across
//! the channels of a block: no channel waits for another. The parameters
//! are laid out the same way, one block for a shared model or one per
//! block. Each lane does the arithmetic of
//! [`Compensator`](crate::realtime::Compensator) in the same order, on any
//! instruction set (`simd::block`), so channel `c` of a bank and a single
//! compensator of the same model give the same bits (`verification/bank.rs`).
//! The channels may share one model or each have their own; all have the
//! same orders.
//!
//! A planned signal of many frames goes in one call,
//! [`CompensatorBank::compensate_frames`]: the same bits, with a few
//! blocks stepped through a run of frames before the next, so that their
//! state stays in L1 (a step of the whole bank, frame by frame, streams
//! the state of a bank larger than L1 through L2 once a frame).
//!
//! Like a single compensator, each channel inverts its model's memory part:
//! a channel whose model has a dead time `d` ([`CompensatorBank::delays`])
//! takes the target wanted `d` samples later.
//!
//! A channel whose model has linear dynamics `G` runs on a single
//! [`Compensator`](crate::realtime::Compensator) of its model kept in the
//! bank (its lane's result is not used): the same bits, none of the
//! bank's speed, until the lanes carry `G`'s state.

use std::vec;
use std::vec::Vec;

use crate::operators::heap::Heap;
use crate::realtime::checks::check_length;
use crate::realtime::compensator::Compensated;
use crate::realtime::creep::creep_gain;
use crate::realtime::error::ParameterError;
use crate::realtime::inverse::inverse_parameters_into;
use crate::realtime::parameters::ModelParameters;
use crate::realtime::real::Real;
use crate::realtime::simd::block::{lanes, Row};
use crate::realtime::simd::Kernels;
use crate::realtime::superposition::Superposition;
use crate::realtime::CompensatorSettings;

pub(crate) mod frames;
#[cfg(all(shared_generics, not(test)))]
mod instances;
mod par;
mod step;
mod walk;

pub use par::Par;
use step::{step_blocks, Fixed};
use walk::Walk;

/// Where each row of a block lies: the state rows and the parameter rows.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Layout {
    /// Plays, creep thresholds, eigenvalues.
    n: usize,
    nc: usize,
    m: usize,
}

impl Layout {
    // state rows
    fn inv_x(self, half: usize, i: usize) -> usize {
        half * self.n + i
    }
    fn chi(self, i: usize, j: usize) -> usize {
        2 * self.n + i * self.m + j
    }
    fn last_u(self) -> usize {
        2 * self.n + self.nc * self.m
    }
    fn creep_out(self) -> usize {
        self.last_u() + 1
    }
    fn creep_last(self) -> usize {
        self.last_u() + 2
    }
    fn state_rows(self) -> usize {
        self.last_u() + 3
    }
    // parameter rows: H⁻¹'s r', w', H's r, w and partial sums s, the creep
    // thresholds and weights / m, the gains, the offset
    fn inv_r(self, i: usize) -> usize {
        i
    }
    fn inv_w(self, i: usize) -> usize {
        self.n + i
    }
    fn r(self, i: usize) -> usize {
        2 * self.n + i
    }
    fn w(self, i: usize) -> usize {
        3 * self.n + i
    }
    fn s(self, i: usize) -> usize {
        4 * self.n + i
    }
    fn creep_r(self, i: usize) -> usize {
        5 * self.n + i
    }
    fn creep_w(self, i: usize) -> usize {
        5 * self.n + self.nc + i
    }
    fn gain(self, j: usize) -> usize {
        5 * self.n + 2 * self.nc + j
    }
    fn offset(self) -> usize {
        5 * self.n + 2 * self.nc + self.m
    }
    fn parameter_rows(self) -> usize {
        self.offset() + 1
    }
}

/// `N` compensators `W⁻¹` stepped together, in `T` (`f32` or `f64`).
#[derive(Debug, Clone, PartialEq)]
pub struct CompensatorBank<T: Real> {
    channels: usize,
    blocks: usize,
    layout: Layout,
    /// Every block's state rows, block after block.
    state: Vec<Row>,
    /// The parameter rows of one block (a shared model) or of each block.
    parameters: Vec<Row>,
    shared: bool,
    lower: T,
    upper: T,
    /// Which copy of the inverse plays is current (0 or 1).
    parity: usize,
    /// `S⁻¹` of each channel's model (of the one, shared), if it has `S`.
    inverse_superposition: Vec<Option<Superposition<T, Heap>>>,
    /// Whether a lane of the block has `S` (the block then applies `S⁻¹`
    /// lane by lane).
    superposed: Vec<bool>,
    /// Whether any block has `S`: if none does and the model is shared
    /// (the common case), a step tests neither per block.
    any_superposed: bool,
    /// Each channel's preview (dead time and the lag of its dynamics).
    delays: Vec<usize>,
    /// The channels whose model has dynamics, each with its own
    /// compensator.
    dynamic: Vec<(usize, crate::realtime::Compensator<T, Heap>)>,
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
        // each model checked once, here; what is built from them is not
        let checked = models
            .iter()
            .map(ModelParameters::validate)
            .collect::<Result<Vec<_>, _>>()?;
        for (channel, model) in models.iter().enumerate() {
            refuse_rate_gain(model)?;
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
        let layout = Layout { n, nc, m };
        let width = lanes::<T>();
        let blocks = channels.div_ceil(width);
        let parameter_blocks = if shared { 1 } else { blocks };
        let mut parameters = vec![Row::default(); parameter_blocks * layout.parameter_rows()];
        let mut inverse_superposition = Vec::with_capacity(models.len());
        for model in models {
            inverse_superposition.push(
                model
                    .superposition
                    .as_ref()
                    .map(Superposition::inverse_built)
                    .transpose()?,
            );
        }
        let (mut inv_r, mut inv_w) = (vec![0.0; n], vec![0.0; n]);
        for b in 0..parameter_blocks {
            let rows = &mut parameters[b * layout.parameter_rows()..][..layout.parameter_rows()];
            for l in 0..width {
                // a shared model fills every lane; padding lanes repeat the
                // first model: finite, never read out
                let c = if shared { 0 } else { b * width + l };
                let model = models.get(c).unwrap_or(first);
                let mut put = |row: usize, x: f64| rows[row].lanes_mut::<T>()[l] = T::from_f64(x);
                let h = &model.hysteresis;
                inverse_parameters_into(h.thresholds, h.weights, &mut inv_r, &mut inv_w);
                let mut s = 0.0;
                for i in 0..n {
                    s += h.weights[i];
                    put(layout.inv_r(i), inv_r[i]);
                    put(layout.inv_w(i), inv_w[i]);
                    put(layout.r(i), h.thresholds[i]);
                    put(layout.w(i), h.weights[i]);
                    put(layout.s(i), s);
                }
                if let Some(cp) = &model.creep {
                    for i in 0..nc {
                        put(layout.creep_r(i), cp.thresholds[i]);
                        put(layout.creep_w(i), cp.weights[i] / m as f64);
                    }
                    for (j, &a) in cp.eigenvalues.iter().enumerate() {
                        put(layout.gain(j), creep_gain(a, model.sample_time));
                    }
                }
                put(layout.offset(), model.offset);
            }
        }
        let superposed = (0..blocks)
            .map(|b| {
                (0..width).any(|l| {
                    let c = if shared { 0 } else { b * width + l };
                    inverse_superposition.get(c).is_some_and(Option::is_some)
                })
            })
            .collect::<Vec<_>>();
        let any_superposed = superposed.contains(&true);
        let model_of = |c: usize| &checked[if shared { 0 } else { c }];
        let delays = (0..channels)
            .map(|c| {
                let m = model_of(c);
                m.delay + m.dynamics.as_ref().map_or(0, |g| g.lag())
            })
            .collect();
        let mut dynamic = Vec::new();
        for c in 0..channels {
            if model_of(c).dynamics.is_some() {
                dynamic.push((c, crate::realtime::Compensator::new(model_of(c), settings)?));
            }
        }
        Ok(Self {
            channels,
            blocks,
            layout,
            state: vec![Row::default(); blocks * layout.state_rows()],
            parameters,
            shared,
            lower: T::from_f64_up(lower),
            upper: T::from_f64_down(upper),
            parity: 0,
            inverse_superposition,
            superposed,
            any_superposed,
            delays,
            dynamic,
        })
    }

    /// The number of channels.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Each channel's preview (samples): its dead time `d` and the lag of
    /// its dynamics; its target at a step is the one wanted that many
    /// samples later.
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
        self.compensate_on_kernels(Kernels::detect(), targets, out)
    }

    /// [`CompensatorBank::compensate`] with the portable kernels only, no
    /// run-time dispatch (the same bits; for tests).
    #[cfg(feature = "internals")]
    pub fn compensate_portable(
        &mut self,
        targets: &[T],
        out: &mut [Compensated<T>],
    ) -> Result<(), ParameterError> {
        self.compensate_on_kernels(Kernels::Portable, targets, out)
    }

    /// [`CompensatorBank::compensate`] on the kernels `k` (any of
    /// `Kernels::all`: the same bits on each; for tests and benches).
    #[cfg(feature = "internals")]
    pub fn compensate_using(
        &mut self,
        k: Kernels,
        targets: &[T],
        out: &mut [Compensated<T>],
    ) -> Result<(), ParameterError> {
        self.compensate_on_kernels(k, targets, out)
    }

    /// [`CompensatorBank::compensate`] on the kernels `k`.
    fn compensate_on_kernels(
        &mut self,
        k: Kernels,
        targets: &[T],
        out: &mut [Compensated<T>],
    ) -> Result<(), ParameterError> {
        check_length("bank.targets", self.channels, targets.len())?;
        check_length("bank.out", self.channels, out.len())?;
        let walk = Walk::of_step(self.parity);
        let (fixed, state) = self.split();
        step_blocks(k, &fixed, 0, state, targets, out, walk);
        self.parity ^= 1;
        self.dynamic_channels(targets, out);
        Ok(())
    }

    /// The channels with dynamics, on their own compensators.
    fn dynamic_channels(&mut self, targets: &[T], out: &mut [Compensated<T>]) {
        for (c, comp) in &mut self.dynamic {
            out[*c] = comp.compensate(targets[*c]);
        }
    }

    /// [`CompensatorBank::compensate`] with the threading `par`: the same
    /// bits on any. [`Par::Seq`] is `compensate`; [`Par::Rayon`]`(n)` splits
    /// the blocks into `n` even parts (at most one per block) and steps
    /// them by fork-join in the current rayon pool. Whether a split pays
    /// depends on the bank's size, the cores and what else runs on them:
    /// the caller decides, from `cargo bench --features internals --bench bank_limit` on its
    /// machine (the guide's library chapter).
    pub fn compensate_on(
        &mut self,
        par: Par,
        targets: &[T],
        out: &mut [Compensated<T>],
    ) -> Result<(), ParameterError> {
        match par.parts().min(self.blocks) {
            0 | 1 => self.compensate(targets, out),
            #[cfg(feature = "rayon")]
            parts => {
                check_length("bank.targets", self.channels, targets.len())?;
                check_length("bank.out", self.channels, out.len())?;
                let k = Kernels::detect();
                let blocks = self.blocks;
                let (fixed, state) = self.split();
                par::fork(
                    &|part, first, state, targets, out| {
                        step_blocks(k, &fixed, first, state, targets, out, Walk::of_part(part));
                    },
                    par::Division {
                        parts,
                        blocks,
                        rows: fixed.layout.state_rows(),
                        lanes: lanes::<T>(),
                    },
                    state,
                    targets,
                    out,
                );
                self.parity ^= 1;
                self.dynamic_channels(targets, out);
                Ok(())
            }
            // without rayon every `Par` is sequential
            #[cfg(not(feature = "rayon"))]
            _ => self.compensate(targets, out),
        }
    }

    /// What a step reads, and the state it writes.
    fn split(&mut self) -> (Fixed<'_, T>, &mut [Row]) {
        (
            Fixed {
                layout: self.layout,
                parameters: &self.parameters,
                shared: self.shared,
                lower: self.lower,
                upper: self.upper,
                parity: self.parity,
                inverse_superposition: &self.inverse_superposition,
                superposed: &self.superposed,
                any_superposed: self.any_superposed,
            },
            &mut self.state,
        )
    }

    /// Back to the virgin state.
    pub fn reset(&mut self) {
        self.state.fill(Row::default());
        self.parity = 0;
        for (_, comp) in &mut self.dynamic {
            comp.reset();
        }
    }
}

/// The bank's kernels invert `H` by the rules (22), which hold for
/// rate-independent thresholds only.
fn refuse_rate_gain(parameters: &ModelParameters<'_>) -> Result<(), ParameterError> {
    if parameters.rate_gain != 0.0 {
        return Err(ParameterError::Unsupported {
            field: "hysteresis.rate_gain",
            reason: "the compensator bank does not invert rate-dependent thresholds; use one compensator per channel",
        });
    }
    Ok(())
}
