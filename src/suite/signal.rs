//! Test and excitation signals: smooth staircases (the inputs of the paper's
//! Figs. 3, 9 and 10 and of the identification in section 4.1).

use crate::realtime::limits;
use crate::realtime::ParameterError;

/// A staircase of plateaus joined by smooth (raised-cosine) transitions.
///
/// The signal starts at `start`, moves to `levels[0]` in `rise` seconds, holds
/// it for `plateau` seconds, moves to `levels[1]`, and so on.
#[derive(Debug, Clone, PartialEq)]
pub struct Staircase {
    pub start: f64,
    pub levels: Vec<f64>,
    pub rise: f64,
    pub plateau: f64,
}

impl Staircase {
    /// A staircase through the full loop `0 → +A → −A → 0` in `steps` equal
    /// steps per quarter: up from 0 to `A`, down to `−A`, back up to 0.
    pub fn full_loop(amplitude: f64, steps: usize, rise: f64, plateau: f64) -> Self {
        let steps = steps.max(1);
        let h = amplitude / steps as f64;
        let mut levels = Vec::with_capacity(4 * steps);
        levels.extend((1..=steps).map(|k| k as f64 * h));
        levels.extend((1..=2 * steps).map(|k| amplitude - k as f64 * h));
        levels.extend((1..=steps).map(|k| -amplitude + k as f64 * h));
        Self {
            start: 0.0,
            levels,
            rise,
            plateau,
        }
    }

    /// The identification input of the paper's section 4.1: `periods` full
    /// loops `0 → +A_p → −A_p → 0` of `steps` steps per quarter, the amplitude
    /// shrinking each period, `A_p = A (periods − p) / periods`, so that every
    /// play sees reversals at many levels.
    pub fn shrinking_loops(
        amplitude: f64,
        periods: usize,
        steps: usize,
        rise: f64,
        plateau: f64,
    ) -> Self {
        let periods = periods.max(1);
        let mut levels = Vec::new();
        for p in 0..periods {
            let a = amplitude * (periods - p) as f64 / periods as f64;
            levels.extend(Self::full_loop(a, steps, rise, plateau).levels);
        }
        Self {
            start: 0.0,
            levels,
            rise,
            plateau,
        }
    }

    /// Total duration (s).
    pub fn duration(&self) -> f64 {
        self.levels.len() as f64 * (self.rise + self.plateau)
    }

    /// The value at time `t` (s).
    pub fn value(&self, t: f64) -> f64 {
        let seg = self.rise + self.plateau;
        if t <= 0.0 || self.levels.is_empty() || seg <= 0.0 {
            return self.start;
        }
        let k = ((t / seg).floor() as usize).min(self.levels.len() - 1);
        let from = if k == 0 {
            self.start
        } else {
            self.levels[k - 1]
        };
        let to = self.levels[k];
        let tau = t - k as f64 * seg;
        if tau >= self.rise {
            to
        } else {
            let s = tau / self.rise;
            from + (to - from) * 0.5 * (1.0 - (std::f64::consts::PI * s).cos())
        }
    }

    /// Samples `t_k = k T_s` for `k = 0..=duration/T_s`.
    pub fn sample(&self, sample_time: f64) -> Vec<f64> {
        let n = (self.duration() / sample_time).round() as usize + 1;
        (0..n).map(|k| self.value(k as f64 * sample_time)).collect()
    }

    /// [`Self::sample`] for a staircase built from options: the number of
    /// samples is checked against [`limits::MAX_GENERATED_SAMPLES`] first.
    pub fn try_sample(&self, sample_time: f64) -> Result<Vec<f64>, ParameterError> {
        let n = limits::generated_samples(self.duration(), sample_time)?;
        Ok((0..n).map(|k| self.value(k as f64 * sample_time)).collect())
    }

    /// [`Self::shrinking_loops`] for counts from options: `periods` loops of
    /// `4 · steps` levels are refused beyond
    /// [`limits::MAX_GENERATED_SAMPLES`] levels before any is made, and
    /// the durations must be finite and `> 0`.
    pub fn try_shrinking_loops(
        amplitude: f64,
        periods: usize,
        steps: usize,
        rise: f64,
        plateau: f64,
    ) -> Result<Self, ParameterError> {
        for (field, value) in [("rise", rise), ("plateau", plateau)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(ParameterError::InvalidDuration { field, value });
            }
        }
        if !amplitude.is_finite() {
            return Err(ParameterError::NonFiniteValue {
                field: "amplitude",
                value: amplitude,
            });
        }
        let levels = periods
            .max(1)
            .saturating_mul(steps.max(1))
            .saturating_mul(4);
        limits::check(
            "levels (4 · steps · periods)",
            limits::MAX_GENERATED_SAMPLES,
            levels,
        )?;
        Ok(Self::shrinking_loops(
            amplitude, periods, steps, rise, plateau,
        ))
    }
}

/// Sample times `t_k = k T_s`.
pub fn time_axis(len: usize, sample_time: f64) -> Vec<f64> {
    (0..len).map(|k| k as f64 * sample_time).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shrinking_loops_shrink_each_period() {
        let s = Staircase::shrinking_loops(1000.0, 4, 3, 0.1, 0.2);
        assert_eq!(s.levels.len(), 4 * 12);
        let peak = |p: usize| {
            s.levels[p * 12..(p + 1) * 12]
                .iter()
                .fold(0.0f64, |m, v| m.max(*v))
        };
        assert_eq!(
            [peak(0), peak(1), peak(2), peak(3)],
            [1000.0, 750.0, 500.0, 250.0]
        );
        assert_eq!(*s.levels.last().unwrap(), 0.0);
    }

    #[test]
    fn staircase_reaches_its_levels_and_is_continuous() {
        let s = Staircase::full_loop(900.0, 3, 0.1, 0.4);
        assert_eq!(s.levels.len(), 12);
        assert_eq!(s.value(0.2), 300.0);
        assert_eq!(s.value(0.5 + 0.2), 600.0);
        assert_eq!(s.value(3.0 * 0.5 - 0.01), 900.0);
        let x = s.sample(1e-3);
        let max_jump = x
            .windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .fold(0.0, f64::max);
        // raised cosine: max slope π/2 · 300 / 0.1 per second
        assert!(max_jump <= std::f64::consts::FRAC_PI_2 * 300.0 / 0.1 * 1e-3 * 1.0001);
        assert_eq!(*x.last().unwrap(), 0.0);
    }
}
