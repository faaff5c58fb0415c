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
pub(crate) fn regressor_factor(
    u: &[f64],
    y: &[f64],
    rows: std::ops::Range<usize>,
    offset: bool,
    r_h: &[f64],
    mut creep: Option<CreepOperator>,
    superposition: Option<(&[f64], f64)>,
) -> Mat<f64> {
    let nh = r_h.len();
    let nc = creep.as_ref().map_or(0, |c| c.thresholds().len());
    let (kinks, centre) = superposition.unwrap_or((&[], 0.0));
    let p = nh + nc + kinks.len();
    let q = usize::from(offset);
    let cols = q + p + 1;
    // the factor so far in the first `cols` rows, the new chunk below it
    let mut stack = Mat::<f64>::zeros(cols + CHUNK, cols);
    let mut filled = 0; // chunk rows filled
    let mut have_r = false;
    let mut x = vec![0.0; nh];
    let mut creep_row = vec![0.0; nc];
    for k in 0..rows.end {
        let v = u[k];
        for (xi, &r) in x.iter_mut().zip(r_h) {
            *xi = play(v, r, *xi);
        }
        let keep = k >= rows.start;
        if let Some(c) = &mut creep {
            if keep {
                c.log_creep_outputs_into(&mut creep_row);
            }
            c.advance(v);
        }
        if !keep {
            continue;
        }
        let row = cols + filled;
        if offset {
            stack[(row, 0)] = 1.0;
        }
        for (j, &xj) in x.iter().enumerate() {
            stack[(row, q + j)] = xj;
        }
        for (j, &cj) in creep_row.iter().enumerate() {
            stack[(row, q + nh + j)] = cj;
        }
        match superposition {
            None => stack[(row, q + p)] = y[k],
            Some(_) => {
                let z = y[k] - centre;
                for (j, &r) in kinks.iter().enumerate() {
                    let d = if r > 0.0 {
                        (z - r).max(0.0)
                    } else {
                        (z - r).min(0.0)
                    };
                    stack[(row, q + nh + nc + j)] = -d;
                }
                stack[(row, q + p)] = z;
            }
        }
        filled += 1;
        if filled == CHUNK || k + 1 == rows.end {
            fold_chunk(&mut stack, cols, filled, have_r);
            have_r = true;
            filled = 0;
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
