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

/// Rows of the regressor folded into the triangular factor at a time: the
/// chunk (`CHUNK × (p + 2)` doubles, about 1 MB at the paper's orders) stays
/// in cache, where the whole regressor (40 MB for 40 s) would not.
const CHUNK: usize = 4096;

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

/// `G` without its lag (`g N/A`: the lag is part of the alignment) applied
/// to every column of the rows, one state per column, at rest on a
/// record's first row.
struct RowFilter {
    filters: Vec<crate::realtime::Dynamics<f64>>,
}

impl RowFilter {
    fn new(dynamics: &crate::realtime::DynamicsParameters, sample_time: f64, cols: usize) -> Self {
        let g = crate::realtime::Dynamics::new(dynamics, sample_time)
            .expect("checked dynamics")
            .without_lag();
        Self {
            filters: vec![g; cols],
        }
    }

    fn restart(&mut self) {
        self.filters.iter_mut().for_each(|g| g.reset());
    }

    fn apply(&mut self, row: &mut [f64]) {
        for (x, g) in row.iter_mut().zip(&mut self.filters) {
            *x = g.step(*x);
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
#[allow(clippy::too_many_arguments)]
pub(crate) fn regressor_factor(
    u: &[f64],
    y: &[f64],
    segments: &[Segment],
    offsets: usize,
    r_h: &[f64],
    creep: Option<CreepOperator>,
    superposition: Option<(&[f64], f64)>,
    dynamics: Option<(&crate::realtime::DynamicsParameters, f64)>,
    zone: Option<&[f64]>,
) -> Mat<f64> {
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
    for segment in segments {
        x.fill(0.0);
        let mut creep = creep.clone();
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
            for (xi, &r) in x.iter_mut().zip(r_h) {
                *xi = play(v, r, *xi);
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
            row[q..q + nh].copy_from_slice(&x);
            row[q + nh..q + nh + nc].copy_from_slice(&creep_row);
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
            for (j, &value) in row.iter().enumerate() {
                stack[(cols + filled, j)] = value;
            }
            filled += 1;
            done += 1;
            if filled == CHUNK || done == total {
                fold_chunk(&mut stack, cols, filled, have_r);
                have_r = true;
                filled = 0;
            }
        }
    }
    Mat::from_fn(cols, cols, |i, j| if i <= j { stack[(i, j)] } else { 0.0 })
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
