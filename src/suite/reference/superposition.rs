//! The superposition operator `S` as its sum of dead zones, and its inverse
//! by locating the segment of the piecewise-linear `S` that holds the value.

/// The superposition operator `S[z] = Σ w_i d_{r_i}(z)`, textbook form.
#[derive(Debug, Clone, PartialEq)]
pub struct NaiveSuperposition {
    /// Thresholds `r_i`, increasing, one of them 0.
    pub r: Vec<f64>,
    /// Weights `w_i`.
    pub w: Vec<f64>,
    /// `S(r_i)`, and the slopes below the first and above the last threshold.
    at_thresholds: Vec<f64>,
    outer_slopes: (f64, f64),
}

impl NaiveSuperposition {
    /// From checked parameters.
    pub fn new(r: Vec<f64>, w: Vec<f64>) -> Self {
        let mut s = Self {
            r,
            w,
            at_thresholds: Vec::new(),
            outer_slopes: (0.0, 0.0),
        };
        s.at_thresholds = s.r.iter().map(|&r| s.evaluate(r)).collect();
        // difference quotients over a step as wide as the thresholds' span,
        // so that the rounding of S(r) is small against the difference
        let (first, last) = (s.r[0], s.r[s.r.len() - 1]);
        let step = (last - first).max(1.0);
        s.outer_slopes = (
            (s.evaluate(first) - s.evaluate(first - step)) / step,
            (s.evaluate(last + step) - s.evaluate(last)) / step,
        );
        s
    }

    /// `S[z]`: each dead zone, weighted, summed in order.
    pub fn evaluate(&self, z: f64) -> f64 {
        let mut y = 0.0;
        for (&r, &w) in self.r.iter().zip(&self.w) {
            let d = if r > 0.0 {
                f64::max(z - r, 0.0)
            } else if r < 0.0 {
                f64::min(z - r, 0.0)
            } else {
                z
            };
            y += w * d;
        }
        y
    }

    /// `S⁻¹[y]`: the segment of `S` whose values hold `y`, and the straight
    /// line through its ends.
    pub fn invert(&self, y: f64) -> f64 {
        let (r, s) = (&self.r, &self.at_thresholds);
        let n = r.len();
        if y <= s[0] {
            return r[0] + (y - s[0]) / self.outer_slopes.0;
        }
        if y >= s[n - 1] {
            return r[n - 1] + (y - s[n - 1]) / self.outer_slopes.1;
        }
        let k = (0..n - 1).rfind(|&k| s[k] <= y).unwrap_or(0);
        r[k] + (y - s[k]) * (r[k + 1] - r[k]) / (s[k + 1] - s[k])
    }
}
