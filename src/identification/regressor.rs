//! Stage 1 of an identification: the regressor `[1 | Φ | ς]` of (25) — play
//! outputs (20), log(t)-creep outputs (15) and the measurement — streamed
//! through a tall-skinny QR, so only its small triangular factor is ever
//! stored. With a superposition operator (Kuhnen's error model) the
//! measurement enters through the dead zones of `S⁻¹` as well:
//! `[1 | Φ | −d_{r'}(ς − c) | ς − c]`.

use faer::reborrow::ReborrowMut;
use faer::Mat;

use crate::operators::creep::CreepOperator;
use crate::operators::play::play;
use crate::realtime::dynamics::{INPUTS, MAX_ORDER};
use crate::realtime::simd::Kernels;

/// Rows of the regressor folded into the triangular factor at a time: the
/// chunk (`CHUNK × (p + 2)` doubles, about 1 MB at the paper's orders) stays
/// in cache, where the whole regressor (40 MB for 40 s) would not.
const CHUNK: usize = 4096;

/// The widening `g |u_k − u_{k−1}|` of the play thresholds at sample `k`
/// of `segment` (rate-dependent thresholds; none at its first sample,
/// where the operators start, as a model started there has none).
#[inline]
fn widening(u: &[f64], segment: &Segment, k: usize, gain: f64) -> f64 {
    if gain == 0.0 || k == segment.whole.start {
        0.0
    } else {
        gain * (u[k] - u[k - 1]).abs()
    }
}

/// The upper-triangular factor `R` of `[1 | Φ | ς]` on the samples `rows`
/// (the `1` column only with `offset`): play outputs, log(t)-creep outputs
/// (before the update with `v_k`: the one-sample delay of (20)) and the
/// measurement. The operators run from the first sample; only the rows in
/// `rows` enter. The regressor is never stored whole: chunks of [`CHUNK`]
/// rows are stacked under the factor so far and factored again (a streaming
/// "tall-skinny" QR), which gives the factor of the whole (up to the signs
/// of its rows) with the same backward stability.
///
/// `superposition = (kinks, c)`: the columns `−d_{r'}(ς_k − c)` of `S⁻¹`'s
/// dead zones at `kinks` (relative to `c`), and `ς − c` as the right-hand
/// side (the weight of `S⁻¹`'s linear term fixed at 1).
/// One record of a regression: its samples in the concatenated signals
/// (the operators start from the virgin state at `whole.start`), the rows
/// that enter (`fitted`, inside `whole`), and its offset column.
#[derive(Debug, Clone)]
pub(crate) struct Segment {
    pub whole: std::ops::Range<usize>,
    pub fitted: std::ops::Range<usize>,
    pub offset_column: usize,
}

/// The operators' state at a record's first sample, for the model's
/// thresholds: the plays' `x_i` and the creep's `χ_ij` (threshold-major,
/// `i · m + j`). A regression takes those of its own operators (the first
/// of each). Finite, and as long as the model's operators (checked where
/// it is made).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct OperatorState {
    pub plays: Vec<f64>,
    pub creep: Vec<f64>,
}

/// The most memory [`OperatorColumns`] takes (256 MiB, about 1.4 million
/// samples at the paper's orders): a longer search streams its rows as a
/// single fit does, in every trial.
const MAX_SHARED_BYTES: usize = 1 << 28;

/// The play and creep columns of the regressor (before `G`) at every
/// sample of the concatenated records, each record from the virgin state:
/// what every trial of `G` at one alignment shares
/// ([`super::dynamics`]), computed once. Row-major, `nh + nc` values a
/// sample (13 MB for 70 000 samples at the paper's orders): only a search
/// over `G` keeps it, a single fit streams its rows.
pub(crate) struct OperatorColumns {
    /// The thresholds (and their rate gain `g`) and eigenvalues the
    /// columns belong to.
    r_h: Vec<f64>,
    gain: f64,
    r_c: Vec<f64>,
    eigenvalues: Vec<f64>,
    /// Samples of the concatenated input the columns were computed on.
    samples: usize,
    values: Vec<f64>,
}

impl OperatorColumns {
    /// The columns of `u` split into `segments` (their `whole` ranges):
    /// the plays at `r_h`, and the log(t)-creep operators of `creep` before
    /// the update with each sample (the one-sample delay of (20)).
    pub(crate) fn new(
        u: &[f64],
        segments: &[Segment],
        r_h: &[f64],
        gain: f64,
        creep: Option<&CreepOperator>,
    ) -> Self {
        let nh = r_h.len();
        let nc = creep.map_or(0, |c| c.thresholds().len());
        let width = nh + nc;
        let mut values = vec![0.0; u.len() * width];
        let mut x = vec![0.0; nh];
        for segment in segments {
            x.fill(0.0);
            let mut creep = creep.cloned();
            for k in segment.whole.clone() {
                let row = &mut values[k * width..(k + 1) * width];
                let widening = widening(u, segment, k, gain);
                for (xi, &r) in x.iter_mut().zip(r_h) {
                    *xi = play(u[k], r + widening, *xi);
                }
                row[..nh].copy_from_slice(&x);
                if let Some(c) = &mut creep {
                    c.log_creep_outputs_into(&mut row[nh..]);
                    c.advance(u[k]);
                }
            }
        }
        Self {
            r_h: r_h.to_vec(),
            gain,
            r_c: creep.map_or_else(Vec::new, |c| c.thresholds().to_vec()),
            eigenvalues: creep.map_or_else(Vec::new, |c| c.eigenvalues().to_vec()),
            samples: u.len(),
            values,
        }
    }

    /// Whether the columns of `samples` samples and `width` operators fit
    /// in [`MAX_SHARED_BYTES`].
    pub(crate) fn affordable(samples: usize, width: usize) -> bool {
        samples
            .checked_mul(width)
            .and_then(|n| n.checked_mul(std::mem::size_of::<f64>()))
            .is_some_and(|bytes| bytes <= MAX_SHARED_BYTES)
    }

    /// Whether these are the columns of a regression with these operators
    /// on `samples` samples.
    fn matches(
        &self,
        samples: usize,
        r_h: &[f64],
        gain: f64,
        creep: Option<&CreepOperator>,
    ) -> bool {
        self.samples == samples
            && self.r_h == r_h
            && self.gain == gain
            && creep.map_or(self.r_c.is_empty(), |c| {
                self.r_c == c.thresholds() && self.eigenvalues == c.eigenvalues()
            })
    }

    fn row(&self, k: usize) -> &[f64] {
        let width = self.r_h.len() + self.r_c.len();
        &self.values[k * width..(k + 1) * width]
    }
}

/// `G` without its lag (`g N/A`: the lag is part of the alignment) applied
/// to every column of the rows, one state per column, at rest on a
/// record's first row. The columns share `G`'s coefficients, so their
/// states are kept column by column in arrays and a row is one vectorised
/// pass: the same operations, in the same order, as
/// [`Dynamics::step`](crate::realtime::Dynamics::step) on each column.
struct RowFilter {
    c: [f64; MAX_ORDER],
    order: usize,
    gain: f64,
    b: [f64; INPUTS],
    /// `y_{k−1−i}` of every column in `y[i]`, and `w_{k−1}`.
    y: [Vec<f64>; MAX_ORDER],
    w: Vec<f64>,
    started: bool,
    /// The vector width its loop is compiled for (the same bits on any:
    /// each element's operations in the same order, none fused).
    kernels: Kernels,
}

impl RowFilter {
    fn new(dynamics: &crate::realtime::DynamicsParameters, sample_time: f64, cols: usize) -> Self {
        let g = crate::realtime::Dynamics::<f64>::new(dynamics, sample_time)
            .expect("checked dynamics")
            .without_lag();
        let (c_used, gain, b) = g.coefficients();
        let mut c = [0.0; MAX_ORDER];
        c[..c_used.len()].copy_from_slice(c_used);
        Self {
            c,
            order: c_used.len(),
            gain,
            b,
            y: std::array::from_fn(|_| vec![0.0; cols]),
            w: vec![0.0; cols],
            started: false,
            kernels: Kernels::detect(),
        }
    }

    fn restart(&mut self) {
        self.started = false;
    }

    fn apply(&mut self, row: &mut [f64]) {
        if !self.started {
            // at rest at the first row, which passes unchanged
            for y in &mut self.y {
                y.copy_from_slice(row);
            }
            self.w.copy_from_slice(row);
            self.started = true;
            return;
        }
        // functions of their own, not `Kernels::run`: its closure, this
        // loop with its four orders, was left out of line and compiled for
        // SSE2 alone
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        {
            #[target_feature(enable = "avx2,fma,avx512f")]
            unsafe fn avx512(f: &mut RowFilter, row: &mut [f64]) {
                f.apply_any(row)
            }
            #[target_feature(enable = "avx2,fma")]
            unsafe fn avx2(f: &mut RowFilter, row: &mut [f64]) {
                f.apply_any(row)
            }
            if self.kernels.is_avx512() {
                // SAFETY: `kernels` is AVX-512 only where the CPU has
                // AVX-512F, AVX2 and FMA.
                return unsafe { avx512(self, row) };
            }
            if self.kernels.is_avx2() {
                // SAFETY: `kernels` is AVX2 only where the CPU has AVX2 and
                // FMA.
                return unsafe { avx2(self, row) };
            }
        }
        self.apply_any(row)
    }

    #[inline(always)]
    fn apply_any(&mut self, row: &mut [f64]) {
        match self.order {
            0 => self.apply_order::<0>(row),
            1 => self.apply_order::<1>(row),
            2 => self.apply_order::<2>(row),
            _ => self.apply_order::<3>(row),
        }
    }

    #[inline(always)]
    fn apply_order<const N: usize>(&mut self, row: &mut [f64]) {
        let [y0, y1, y2] = &mut self.y;
        let n = row.len();
        let (y0, y1, y2, w) = (&mut y0[..n], &mut y1[..n], &mut y2[..n], &mut self.w[..n]);
        let (c, gain, b) = (self.c, self.gain, self.b);
        for j in 0..n {
            let x = b[0] * row[j] + b[1] * w[j];
            let mut past = 0.0;
            if N > 0 {
                past += c[0] * y0[j];
            }
            if N > 1 {
                past += c[1] * y1[j];
            }
            if N > 2 {
                past += c[2] * y2[j];
            }
            let out = gain * x - past;
            if N > 2 {
                y2[j] = y1[j];
            }
            if N > 1 {
                y1[j] = y0[j];
            }
            if N > 0 {
                y0[j] = out;
            }
            w[j] = row[j];
            row[j] = out;
        }
    }
}

/// The upper-triangular factor `R` of `[1 | Φ | ς]` over several records
/// (`segments`), each from the virgin state, with `offsets` offset columns
/// (0: none; one per segment's `offset_column`): play outputs, log(t)-creep
/// outputs (before the update with `v_k`: the one-sample delay of (20)) and
/// the measurement. The regressor is never stored whole: chunks of
/// [`CHUNK`] rows are stacked under the factor so far and factored again (a
/// streaming "tall-skinny" QR), which gives the factor of the whole (up to
/// the signs of its rows) with the same backward stability.
///
/// `superposition = (kinks, c)`: the columns `−d_{r'}(ς_k − c)` of `S⁻¹`'s
/// dead zones at `kinks` (relative to `c`), and `ς − c` as the right-hand
/// side (the weight of `S⁻¹`'s linear term fixed at 1).
///
/// `zone`: the argument of the dead zones where it is not `ς` (with
/// dynamics, the model's noise-free prediction as an instrument).
///
/// `dynamics`: `y` is then `G⁻¹` of the measurement, and every column
/// (the right-hand side too, which gives back the measurement) passes
/// through `G` before it enters: the fit is the output error of
/// `y = G[S[H + C]]` for a fixed `G`, linear in the weights.
///
/// `states`: each segment's operators start there instead of the virgin
/// state (then `columns`, computed from the virgin state, must be `None`).
#[allow(clippy::too_many_arguments)]
pub(crate) fn regressor_factor(
    u: &[f64],
    y: &[f64],
    segments: &[Segment],
    offsets: usize,
    r_h: &[f64],
    gain: f64,
    creep: Option<CreepOperator>,
    superposition: Option<(&[f64], f64)>,
    dynamics: Option<(&crate::realtime::DynamicsParameters, f64)>,
    zone: Option<&[f64]>,
    columns: Option<&OperatorColumns>,
    states: Option<&[OperatorState]>,
) -> Result<Mat<f64>, crate::realtime::ParameterError> {
    let nh = r_h.len();
    let nc = creep.as_ref().map_or(0, |c| c.thresholds().len());
    let (kinks, centre) = superposition.unwrap_or((&[], 0.0));
    let p = nh + nc + kinks.len();
    let q = offsets;
    let cols = q + p + 1;
    // the factor so far in the first `cols` rows, the new chunk below it
    let mut stack = Mat::<f64>::zeros(cols + CHUNK, cols);
    let mut filled = 0; // chunk rows filled
    let mut have_r = false;
    let mut x = vec![0.0; nh];
    let mut creep_row = vec![0.0; nc];
    let mut row = vec![0.0; cols];
    let mut filter = dynamics.map(|(g, ts)| RowFilter::new(g, ts, cols));
    let total: usize = segments.iter().map(|s| s.fitted.len()).sum();
    let mut done = 0;
    // the operators' columns from the cache when they are its own
    let columns =
        columns.filter(|c| states.is_none() && c.matches(u.len(), r_h, gain, creep.as_ref()));
    for (index, segment) in segments.iter().enumerate() {
        let state = states.and_then(|s| s.get(index));
        match state {
            Some(s) => x.copy_from_slice(&s.plays[..nh]),
            None => x.fill(0.0),
        }
        let mut creep = if columns.is_some() {
            None
        } else {
            creep.clone()
        };
        if let (Some(c), Some(s)) = (&mut creep, state) {
            let values = c.thresholds().len() * c.eigenvalues().len();
            c.set_state_flat(&s.creep[..values])?;
        }
        if let Some(f) = &mut filter {
            f.restart();
        }
        // with G every row from the record's start enters the filter
        let first = if filter.is_some() {
            segment.whole.start
        } else {
            segment.fitted.start
        };
        for k in segment.whole.start..segment.fitted.end {
            let v = u[k];
            if columns.is_none() {
                let widening = widening(u, segment, k, gain);
                for (xi, &r) in x.iter_mut().zip(r_h) {
                    *xi = play(v, r + widening, *xi);
                }
            }
            let keep = k >= segment.fitted.start;
            if let Some(c) = &mut creep {
                if k >= first {
                    c.log_creep_outputs_into(&mut creep_row);
                }
                c.advance(v);
            }
            if k < first {
                continue;
            }
            row.fill(0.0);
            if q > 0 {
                row[segment.offset_column] = 1.0;
            }
            match columns {
                Some(c) => row[q..q + nh + nc].copy_from_slice(c.row(k)),
                None => {
                    row[q..q + nh].copy_from_slice(&x);
                    row[q + nh..q + nh + nc].copy_from_slice(&creep_row);
                }
            }
            match superposition {
                None => row[q + p] = y[k],
                Some(_) => {
                    let z = y[k] - centre;
                    let a = zone.map_or(z, |w| w[k] - centre);
                    for (j, &r) in kinks.iter().enumerate() {
                        let d = if r > 0.0 {
                            (a - r).max(0.0)
                        } else {
                            (a - r).min(0.0)
                        };
                        row[q + nh + nc + j] = -d;
                    }
                    row[q + p] = z;
                }
            }
            if let Some(f) = &mut filter {
                f.apply(&mut row);
            }
            if !keep {
                continue;
            }
            stack
                .as_mut()
                .row_mut(cols + filled)
                .copy_from(faer::RowRef::from_slice(&row));
            filled += 1;
            done += 1;
            if filled == CHUNK || done == total {
                fold_chunk(&mut stack, cols, filled, have_r);
                have_r = true;
                filled = 0;
            }
        }
    }
    Ok(Mat::from_fn(cols, cols, |i, j| {
        if i <= j {
            stack[(i, j)]
        } else {
            0.0
        }
    }))
}

/// Factor the stack `[R; chunk]` (the first `filled` chunk rows) in place and
/// leave the new triangular factor in the first `cols` rows.
fn fold_chunk(stack: &mut Mat<f64>, cols: usize, filled: usize, have_r: bool) {
    let first = if have_r { 0 } else { cols };
    let mut part = stack.as_mut().subrows_mut(first, cols + filled - first);
    thin_r_in_place(part.rb_mut());
    let r = Mat::from_fn(cols, cols, |i, j| {
        if i <= j && i < part.nrows() {
            part[(i, j)]
        } else {
            0.0
        }
    });
    for j in 0..cols {
        for i in 0..cols {
            stack[(i, j)] = r[(i, j)];
        }
    }
}

/// An in-place blocked Householder QR (faer); `R` is left in the upper
/// triangle.
fn thin_r_in_place(mut a: faer::MatMut<'_, f64>) {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::qr::no_pivoting::factor;
    let (nrows, ncols) = (a.nrows(), a.ncols());
    let size = nrows.min(ncols);
    let block = factor::recommended_block_size::<f64>(nrows, ncols);
    let mut coeff = Mat::<f64>::zeros(block, size);
    let par = faer::Par::Seq;
    let mut buf = MemBuffer::new(factor::qr_in_place_scratch::<f64>(
        nrows,
        ncols,
        block,
        par,
        Default::default(),
    ));
    factor::qr_in_place(
        a.rb_mut(),
        coeff.as_mut(),
        par,
        MemStack::new(&mut buf),
        Default::default(),
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::realtime::{Dynamics, DynamicsParameters, Resonance};

    fn g() -> DynamicsParameters {
        DynamicsParameters {
            low_pass: Some(1500.0),
            resonance: Some(Resonance {
                frequency: 740.0,
                damping: 0.014,
            }),
            delay_fraction: 0.3,
        }
    }

    /// A row-major signal of `cols` columns, each its own jagged wave.
    fn rows(n: usize, cols: usize) -> Vec<Vec<f64>> {
        (0..n)
            .map(|k| {
                (0..cols)
                    .map(|j| ((k * (j + 3)) % 17) as f64 - 8.0 + (k as f64 * 0.01).sin() * j as f64)
                    .collect()
            })
            .collect()
    }

    /// On every kernel set this CPU has, with rows of a few lanes and of
    /// several vectors.
    #[test]
    fn the_row_filter_is_g_on_each_column_bit_for_bit() {
        let ts = 1e-4;
        for (parameters, kernels, cols) in [
            g(),
            DynamicsParameters {
                low_pass: Some(900.0),
                resonance: None,
                delay_fraction: -0.2,
            },
            DynamicsParameters {
                low_pass: None,
                resonance: None,
                delay_fraction: 0.4,
            },
        ]
        .into_iter()
        .flat_map(|p| Kernels::all().map(move |k| (p, k)))
        .flat_map(|(p, k)| [7, 35].map(|cols| (p, k, cols)))
        {
            let mut filter = RowFilter::new(&parameters, ts, cols);
            filter.kernels = kernels;
            let one = Dynamics::<f64>::new(&parameters, ts).unwrap().without_lag();
            let mut each = vec![one; cols];
            for record in 0..2 {
                filter.restart();
                each.iter_mut().for_each(|g| g.reset());
                for mut row in rows(300 + record, cols) {
                    let expected: Vec<f64> =
                        row.iter().zip(&mut each).map(|(&x, g)| g.step(x)).collect();
                    filter.apply(&mut row);
                    assert!(row
                        .iter()
                        .zip(&expected)
                        .all(|(a, b)| a.to_bits() == b.to_bits()));
                }
            }
        }
    }

    #[test]
    fn the_shared_columns_give_the_streamed_factor_bit_for_bit() {
        let ts = 1e-4;
        let u: Vec<f64> = (0..3000)
            .map(|k| 600.0 * (k as f64 * 0.004).sin() * (1.0 + (k as f64 * 0.0007).cos()))
            .collect();
        let y: Vec<f64> = u.iter().map(|v| 0.8 * v + 3.0).collect();
        let segments = [
            Segment {
                whole: 0..1800,
                fitted: 100..1800,
                offset_column: 0,
            },
            Segment {
                whole: 1800..3000,
                fitted: 1900..3000,
                offset_column: 1,
            },
        ];
        let r_h = [0.0, 200.0, 400.0, 700.0];
        let creep = CreepOperator::new([0.0, 300.0], vec![0.0; 2], vec![1.0, 10.0], ts).unwrap();
        assert!(OperatorColumns::affordable(u.len(), 6));
        assert!(!OperatorColumns::affordable(1 << 28, 24));
        assert!(!OperatorColumns::affordable(usize::MAX, 2));
        // rate-independent and rate-dependent thresholds
        for gain in [0.0, 0.3] {
            let columns = OperatorColumns::new(&u, &segments, &r_h, gain, Some(&creep));
            assert!(columns.matches(u.len(), &r_h, gain, Some(&creep)));
            assert!(!columns.matches(u.len(), &r_h, gain + 0.1, Some(&creep)));
            let factor = |cached: Option<&OperatorColumns>| {
                regressor_factor(
                    &u,
                    &y,
                    &segments,
                    2,
                    &r_h,
                    gain,
                    Some(creep.clone()),
                    Some((&[300.0, -300.0][..], 10.0)),
                    Some((&g(), ts)),
                    None,
                    cached,
                    None,
                )
                .unwrap()
            };
            let (streamed, shared) = (factor(None), factor(Some(&columns)));
            for i in 0..streamed.nrows() {
                for j in 0..streamed.ncols() {
                    assert_eq!(streamed[(i, j)].to_bits(), shared[(i, j)].to_bits());
                }
            }
        }
    }
}
