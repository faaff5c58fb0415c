//! The model `W = S[H + C]` (6) with its dynamics and dead time, textbook
//! form.

use std::collections::VecDeque;

use super::{
    naive_parts, naive_superposition, NaiveCreep, NaiveDynamics, NaiveHysteresis,
    NaiveSuperposition,
};
use crate::error::ModelError;
use crate::operators::model::ModelFile;
use crate::operators::traits::{ActuatorModel, Operator};

/// The model `W = S[H + C]` (6), textbook form.
#[derive(Debug, Clone, PartialEq)]
pub struct NaiveModel {
    /// `H`.
    pub hysteresis: NaiveHysteresis,
    /// `C`, if the model has creep.
    pub creep: Option<NaiveCreep>,
    /// `S`, if the model has one.
    pub superposition: Option<NaiveSuperposition>,
    /// `G`, if the model has dynamics.
    pub dynamics: Option<NaiveDynamics>,
    /// Output offset.
    pub offset: f64,
    /// The dead time `d` (samples).
    pub delay: usize,
    /// The values of `S[H + C]` still to come out, oldest first (`d` of
    /// them once started; empty before the first sample).
    pub pending: VecDeque<f64>,
}

impl NaiveModel {
    /// From a model file (validated), starting from its `state`.
    pub fn from_file(file: &ModelFile) -> Result<Self, ModelError> {
        let (hysteresis, creep) = naive_parts(file)?;
        Ok(Self {
            hysteresis,
            creep,
            superposition: naive_superposition(file),
            dynamics: NaiveDynamics::of(file),
            offset: file.offset.unwrap_or(0.0),
            delay: file.delay.unwrap_or(0),
            pending: file.delay_state.clone().unwrap_or_default().into(),
        })
    }

    /// `y_k = z_{max(k−d, 0)}`: before the first output leaves, the queue
    /// holds `d` copies of the first `z` (the record at rest before it).
    fn delayed(&mut self, z: f64) -> f64 {
        if self.delay == 0 {
            return z;
        }
        if self.pending.is_empty() {
            self.pending.extend(std::iter::repeat_n(z, self.delay));
        }
        self.pending.push_back(z);
        self.pending.pop_front().expect("d ≥ 1 values queued")
    }
}

impl Operator for NaiveModel {
    fn step(&mut self, v: f64) -> f64 {
        // a non-finite input: the previous input held
        let v = if v.is_finite() {
            v
        } else {
            self.hysteresis.x[0]
        };
        let h = self.hysteresis.step(v);
        let w = match &mut self.creep {
            Some(c) => {
                let out = c.output();
                c.advance(v);
                h + out
            }
            None => h,
        };
        let w = match &self.superposition {
            Some(s) => s.evaluate(w),
            None => w,
        };
        let w = match &mut self.dynamics {
            Some(g) => g.step(w),
            None => w,
        };
        self.delayed(w) + self.offset
    }

    fn reset(&mut self) {
        self.pending.clear();
        if let Some(g) = &mut self.dynamics {
            g.reset();
        }
        self.hysteresis.reset();
        if let Some(c) = &mut self.creep {
            c.reset();
        }
    }
}

impl ActuatorModel for NaiveModel {}
