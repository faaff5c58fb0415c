//! The time axis of a measurement: its sample time and jitter.
//!
//! The creep discretization (20) assumes a constant sample time `T_s`. A
//! logger's clock jitters, so a recorded time column gives `T_s` as its mean
//! step and is accepted only while every step stays within [`MAX_JITTER`] of
//! that mean.

/// The largest accepted jitter of a time column: 1 % of the mean step.
pub const MAX_JITTER: f64 = 0.01;

/// How closely a time column's mean step must agree with a given sample time.
pub const SAMPLE_TIME_AGREEMENT: f64 = 1e-3;

/// The sample time and jitter of a time column.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeAxis {
    /// The mean step (s).
    pub sample_time: f64,
    /// The largest relative deviation of a step from the mean.
    pub jitter: f64,
}

/// A time column that cannot serve as a time axis, at sample `index`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
#[error("t[{index}]: {message}")]
pub struct TimeAxisError {
    pub index: usize,
    pub message: String,
}

impl TimeAxis {
    /// The time axis of timestamps `t` (s): strictly increasing, the sample
    /// time as the mean step `(t_last − t_first)/(N − 1)`, and the jitter,
    /// the largest relative deviation of a step from it, at most
    /// [`MAX_JITTER`].
    pub fn of(t: &[f64]) -> Result<Self, TimeAxisError> {
        let bad = |index, message| Err(TimeAxisError { index, message });
        if let Some(k) = t.iter().position(|v| !v.is_finite()) {
            return bad(k, format!("{} is not a finite number", t[k]));
        }
        if t.len() < 2 {
            return bad(
                0,
                "at least two samples are needed for a sample time".into(),
            );
        }
        if let Some(k) = (1..t.len()).find(|&k| t[k] <= t[k - 1]) {
            return bad(
                k,
                format!(
                    "time does not increase ({:?} s after {:?} s)",
                    t[k],
                    t[k - 1]
                ),
            );
        }
        let mean = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
        let (mut jitter, mut worst) = (0.0f64, 1);
        for k in 1..t.len() {
            let j = ((t[k] - t[k - 1]) - mean).abs() / mean;
            if j > jitter {
                jitter = j;
                worst = k;
            }
        }
        if jitter > MAX_JITTER {
            return bad(
                worst,
                format!(
                    "time step {:?} s deviates {:.2} % from the mean step {mean:?} s (at most {} % of jitter is accepted)",
                    t[worst] - t[worst - 1],
                    100.0 * jitter,
                    100.0 * MAX_JITTER
                ),
            );
        }
        Ok(Self {
            sample_time: mean,
            jitter,
        })
    }

    /// The mean step must equal the sample time `ts` to
    /// [`SAMPLE_TIME_AGREEMENT`] relative; the error says by how much it
    /// does not.
    pub fn check_sample_time(&self, ts: f64) -> Result<(), String> {
        if (self.sample_time - ts).abs() > SAMPLE_TIME_AGREEMENT * ts {
            return Err(format!(
                "the mean time step {:?} s differs from the sample time {ts:?} s by more than {} relative",
                self.sample_time, SAMPLE_TIME_AGREEMENT
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sample_time_is_the_mean_step_and_the_jitter_the_worst_step() {
        // steps 1.0, 1.005, 0.995, 1.0: mean exactly 1, worst deviation 0.005
        let axis = TimeAxis::of(&[0.0, 1.0, 2.005, 3.0, 4.0]).unwrap();
        assert_eq!(axis.sample_time, 1.0);
        // 2.005 − 1.0 rounds: within a few ulps of 2.005
        assert!((axis.jitter - 0.005).abs() < 8.0 * f64::EPSILON);
        assert!(axis.check_sample_time(1.0 + 0.9e-3).is_ok());
        let e = axis.check_sample_time(1.0 + 1.1e-3).unwrap_err();
        assert!(e.contains("differs from the sample time"), "{e}");
    }

    #[test]
    fn a_bad_time_column_names_its_sample() {
        let cases: [(&[f64], usize, &str); 5] = [
            (&[0.0], 0, "at least two samples"),
            (&[0.0, 1.0, 1.0, 2.0], 2, "time does not increase"),
            (&[0.0, 1.0, f64::NAN], 2, "not a finite number"),
            (&[0.0, f64::INFINITY, 2.0], 1, "not a finite number"),
            (&[0.0, 1.0, 2.02, 3.0, 4.0], 2, "deviates 2.00 %"),
        ];
        for (t, index, text) in cases {
            let e = TimeAxis::of(t).unwrap_err();
            assert_eq!(e.index, index, "{t:?}: {e}");
            assert!(e.to_string().starts_with(&format!("t[{index}]: ")), "{e}");
            assert!(e.to_string().contains(text), "{t:?}: {e}");
        }
    }
}
