//! Fitting the linear dynamics `G` after `S[H + C]` (a low-pass, a
//! resonance): `y = G[S[H + C]] + offset` is linear in the weights for a
//! fixed `G` ([`identify_records`] with `settings.dynamics`), so the weights
//! are eliminated (variable projection) and the few parameters of `G` are
//! fitted to the output error by Levenberg–Marquardt steps on a forward-
//! difference Jacobian, in coordinates that keep them admissible:
//! `ln f_c`, `ln f_n` (below 0.49 of the sample rate) and `logit ζ`.
//!
//! The start: the static model's residual shows a resonance as ringing, so
//! `f_n` starts at the peak of its spectrum above the input's own band;
//! `ζ` at 0.05; `f_c` at the best of a few fractions of the sample rate.
//! Without noise the parameters come back to rounding (the output error is
//! then zero at the true `G`, where Gauss–Newton converges quadratically).
//! The standard errors follow from the Jacobian at the optimum; a part the
//! records do not determine (a singular or ill-conditioned Jacobian, or a
//! relative standard error above 1/2) is reported as an error, not guessed.
//!
//! Every trial of `G` is a whole fit of the weights, so the search shares
//! what `G` does not change: the play and creep columns of the regressor,
//! computed once per dead time and filtered by each trial's `G` (a linear
//! filter of each column). The trials of a grid, the columns of a
//! difference Jacobian, the two starts and the dead times are independent:
//! they run side by side as the call's [`Par`] allows, and the fitted model
//! is the same bits with any. A start at one dead time whose delay
//! fraction runs into its bound toward another dead time searched is left
//! to that search ([`fit_dynamics_and_delay`]): the model is the one the
//! best of the dead times searched alone gives.

use super::identify::{identify_records_with, FitRecord, Identification, SharedColumns};
use super::report::DynamicsReport;
use super::settings::{IdentificationError, IdentificationSettings};
use crate::operators::bank::Par;
use crate::realtime::{DynamicsParameters, Resonance};

/// Which parts of `G` to fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DynamicsParts {
    pub low_pass: bool,
    pub resonance: bool,
    /// A delay of a fraction of a sample on top of the dead time.
    pub delay_fraction: bool,
}

impl std::str::FromStr for DynamicsParts {
    type Err = String;

    /// `none`, or any of `low-pass`, `resonance`, `delay-fraction`,
    /// comma-separated.
    fn from_str(s: &str) -> Result<Self, String> {
        let mut parts = Self::default();
        for word in s.split(',').map(str::trim) {
            match word {
                "none" => {}
                "low-pass" => parts.low_pass = true,
                "resonance" => parts.resonance = true,
                "delay-fraction" => parts.delay_fraction = true,
                other => {
                    return Err(format!(
                        "'{other}' is none of none, low-pass, resonance, delay-fraction"
                    ))
                }
            }
        }
        Ok(parts)
    }
}

impl DynamicsParts {
    pub fn any(&self) -> bool {
        self.low_pass || self.resonance || self.delay_fraction
    }
}

/// The largest resonance frequency tried, as a fraction of the sample rate.
const MAX_RESONANCE: f64 = 0.49;
/// Levenberg–Marquardt steps at most.
const MAX_ITERATIONS: usize = 60;

/// A step that lowers the sum of squares by less than this fraction of the
/// residual variance `σ̂² = ss/N` ends the descent. Near the optimum a move
/// of `t` standard errors changes the sum by `t² σ̂²`, so such a step moves
/// the parameters by about a hundredth of their standard errors. Without
/// noise `σ̂²` shrinks with the error and the descent runs to rounding; a
/// delay fraction pressed against its bound (whose coordinate only grows)
/// stops here rather than at [`MAX_ITERATIONS`].
const STALL: f64 = 1e-4;

/// The largest delay fraction: the zero of `N` at `−τ/(1 − τ)` stays
/// inside `|z| ≤ 0.96`.
const MAX_FRACTION: f64 = 0.49;

/// The parameters of `G` from the coordinates `x` (module docs): `ln f_c`,
/// `ln f_n`, `logit ζ`, `artanh(τ/0.49)`, those of the parts fitted.
fn parameters(parts: DynamicsParts, x: &[f64], fs: f64) -> DynamicsParameters {
    let mut i = 0;
    let low_pass = parts.low_pass.then(|| {
        i += 1;
        x[i - 1].exp()
    });
    let resonance = parts.resonance.then(|| {
        let (f, z) = (x[i], x[i + 1]);
        i += 2;
        Resonance {
            frequency: f.exp().min(MAX_RESONANCE * fs),
            damping: 1.0 / (1.0 + (-z).exp()),
        }
    });
    let delay_fraction = if parts.delay_fraction {
        MAX_FRACTION * x[i].tanh()
    } else {
        0.0
    };
    DynamicsParameters {
        low_pass,
        resonance,
        delay_fraction,
    }
}

/// The coordinates of a low-pass, a resonance and a delay fraction.
fn coordinates(lp: Option<f64>, res: Option<(f64, f64)>, fraction: Option<f64>) -> Vec<f64> {
    let mut x = Vec::new();
    if let Some(f) = lp {
        x.push(f.ln());
    }
    if let Some((f, zeta)) = res {
        x.push(f.ln());
        x.push((zeta / (1.0 - zeta)).ln());
    }
    if let Some(t) = fraction {
        x.push((t / MAX_FRACTION).atanh());
    }
    x
}

/// A search over `G` at one dead time: the records, and the operators'
/// columns every trial shares (`G` filters them, it does not change them).
struct Search<'a> {
    records: &'a [FitRecord<'a>],
    sample_time: f64,
    settings: &'a IdentificationSettings,
    parts: DynamicsParts,
    columns: SharedColumns,
    par: Par,
    /// Whether the dead times one less and one more are searched too.
    neighbours: Neighbours,
}

/// Which neighbouring dead times another search covers.
#[derive(Debug, Clone, Copy, Default)]
struct Neighbours {
    fewer: bool,
    more: bool,
}

/// Whether the delay fraction `t` is pressed against its bound.
fn pinned_fraction(t: f64) -> bool {
    t.abs() > 0.98 * MAX_FRACTION
}

impl Search<'_> {
    /// Whether the coordinates `x` press the delay fraction against the
    /// bound toward a dead time another search covers: the total delay
    /// `d + τ` this start is heading for lies in that search's range, so
    /// it is left to that one.
    fn left_to_neighbour(&self, x: &[f64]) -> bool {
        if !self.parts.delay_fraction {
            return false;
        }
        let t = parameters(self.parts, x, 1.0 / self.sample_time).delay_fraction;
        pinned_fraction(t)
            && if t > 0.0 {
                self.neighbours.more
            } else {
                self.neighbours.fewer
            }
    }

    /// The model fitted with `G` and its output errors on every record's
    /// fitted samples (each with its own offset), one after another.
    fn residual(
        &self,
        g: Option<DynamicsParameters>,
    ) -> Result<(Identification, Vec<f64>), IdentificationError> {
        let s = IdentificationSettings {
            dynamics: g,
            ..self.settings.clone()
        };
        let columns = g.is_some().then_some(&self.columns);
        let (id, fits) = identify_records_with(self.records, self.sample_time, &s, columns, None)?;
        let mut r = Vec::new();
        for (index, (rec, fit)) in self.records.iter().zip(&fits).enumerate() {
            let fitted = match id.report.records.get(index) {
                Some(f) => f.fitted.clone(),
                None => id.report.fitted.clone(),
            };
            r.extend(fitted.map(|k| fit[k] - rec.y[k]));
        }
        Ok((id, r))
    }

    /// The output errors at the coordinates `x`.
    fn residual_at(&self, x: &[f64]) -> Result<Vec<f64>, IdentificationError> {
        let fs = 1.0 / self.sample_time;
        Ok(self.residual(Some(parameters(self.parts, x, fs)))?.1)
    }
}

fn sum_squares(r: &[f64]) -> f64 {
    r.iter().map(|e| e * e).sum()
}

/// The frequency (Hz) of the largest peak of `|Σ e_k e^{−iωk}|` over a
/// logarithmic grid from 20 times the lowest frequency the record resolves
/// to [`MAX_RESONANCE`] of the sample rate.
fn spectral_peak(e: &[f64], fs: f64) -> f64 {
    let n = e.len().max(2) as f64;
    let (lo, hi) = ((20.0 * fs / n).min(0.1 * fs), MAX_RESONANCE * fs);
    let steps = 240;
    let mut best = (0.0, 0.25 * fs);
    for i in 0..=steps {
        let f = lo * (hi / lo).powf(i as f64 / steps as f64);
        let w = std::f64::consts::TAU * f / fs;
        // Goertzel's recursion
        let c = 2.0 * w.cos();
        let (mut s1, mut s2) = (0.0, 0.0);
        for &x in e {
            let s0 = x + c * s1 - s2;
            s2 = s1;
            s1 = s0;
        }
        let power = s1 * s1 + s2 * s2 - c * s1 * s2;
        if power > best.0 {
            best = (power, f);
        }
    }
    best.1
}

/// Solve the small symmetric system `a x = b` (Gaussian elimination with
/// partial pivoting); `None` when singular.
fn solve_small(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for k in 0..n {
        let p = (k..n).max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))?;
        if a[p][k] == 0.0 || !a[p][k].is_finite() {
            return None;
        }
        a.swap(k, p);
        b.swap(k, p);
        let pivot = a[k].clone();
        for i in k + 1..n {
            let f = a[i][k] / pivot[k];
            for (x, p) in a[i][k..].iter_mut().zip(&pivot[k..]) {
                *x -= f * p;
            }
            b[i] -= f * b[k];
        }
    }
    let mut x = vec![0.0; n];
    for i in (0..n).rev() {
        let s: f64 = (i + 1..n).map(|j| a[i][j] * x[j]).sum();
        x[i] = (b[i] - s) / a[i][i];
    }
    Some(x)
}

/// The end of a Levenberg–Marquardt run.
struct Refined {
    ss: f64,
    x: Vec<f64>,
    jtj: Vec<Vec<f64>>,
    iterations: usize,
}

/// Levenberg–Marquardt steps on a forward-difference Jacobian from `x`
/// (its columns are independent trials, run as `search.par` allows).
/// `None` when the steps press the delay fraction against its bound
/// toward a dead time another search covers
/// ([`Search::left_to_neighbour`]): there the coordinate's derivative
/// vanishes and the steps only crawl along the bound.
fn refine(search: &Search<'_>, mut x: Vec<f64>) -> Result<Option<Refined>, IdentificationError> {
    let k = x.len();
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let mut jtj = vec![vec![0.0; k]; k];
    let mut r = search.residual_at(&x)?;
    let mut ss = sum_squares(&r);
    while iterations < MAX_ITERATIONS {
        iterations += 1;
        // forward differences in the coordinates
        let h = 1e-6;
        let shifted: Vec<Vec<f64>> = (0..k)
            .map(|i| {
                let mut xh = x.clone();
                xh[i] += h;
                xh
            })
            .collect();
        // a coordinate whose shift leaves `G` as it is (a delay fraction
        // at its bound, where tanh is flat to rounding) has a zero column:
        // the trial would give `r` again
        let fs = 1.0 / search.sample_time;
        let g = parameters(search.parts, &x, fs);
        let moved: Vec<bool> = shifted
            .iter()
            .map(|xh| parameters(search.parts, xh, fs) != g)
            .collect();
        let trials: Vec<&Vec<f64>> = shifted
            .iter()
            .zip(&moved)
            .filter_map(|(xh, &m)| m.then_some(xh))
            .collect();
        let mut found = search
            .par
            .map(&trials, |xh| search.residual_at(xh))
            .into_iter();
        let mut columns = Vec::with_capacity(k);
        for &m in &moved {
            columns.push(match m.then(|| found.next()).flatten() {
                Some(rh) => rh?
                    .iter()
                    .zip(&r)
                    .map(|(a, b)| (a - b) / h)
                    .collect::<Vec<f64>>(),
                None => vec![0.0; r.len()],
            });
        }
        for i in 0..k {
            for j in 0..k {
                jtj[i][j] = columns[i].iter().zip(&columns[j]).map(|(a, b)| a * b).sum();
            }
        }
        let jtr: Vec<f64> = columns
            .iter()
            .map(|c| c.iter().zip(&r).map(|(a, b)| a * b).sum())
            .collect();
        let mut improved = false;
        for _ in 0..12 {
            let mut a = jtj.clone();
            for (i, row) in a.iter_mut().enumerate() {
                row[i] += lambda * jtj[i][i].max(f64::MIN_POSITIVE);
            }
            let Some(step) = solve_small(a, jtr.clone()) else {
                lambda *= 10.0;
                continue;
            };
            let trial: Vec<f64> = x.iter().zip(&step).map(|(a, b)| a - b).collect();
            if let Ok(rt) = search.residual_at(&trial) {
                let st = sum_squares(&rt);
                if st < ss {
                    let small = step.iter().all(|d| d.abs() < 1e-12)
                        || (ss - st) <= 1e-15 * ss
                        || (ss - st) <= STALL * st / rt.len().max(1) as f64;
                    (x, r, ss) = (trial, rt, st);
                    lambda = (lambda / 3.0).max(1e-12);
                    improved = !small;
                    break;
                }
            }
            lambda *= 4.0;
        }
        if search.left_to_neighbour(&x) {
            return Ok(None);
        }
        if !improved {
            break;
        }
    }
    Ok(Some(Refined {
        ss,
        x,
        jtj,
        iterations,
    }))
}

/// The first of `candidates` with the least sum of squares (trials run as
/// `search.par` allows; the choice does not depend on it).
fn best_of(
    search: &Search<'_>,
    best: &mut Option<(f64, Vec<f64>)>,
    candidates: Vec<Vec<f64>>,
) -> Result<(), IdentificationError> {
    let sums = search.par.map(&candidates, |x| {
        search.residual_at(x).map(|r| sum_squares(&r))
    });
    for (x, ss) in candidates.into_iter().zip(sums) {
        let ss = ss?;
        if best.as_ref().is_none_or(|b| ss < b.0) {
            *best = Some((ss, x));
        }
    }
    Ok(())
}

/// Fit the weights and the `parts` of `G` to the records (module docs), at
/// the dead time `settings.delay`; `settings.dynamics` is ignored.
pub fn fit_dynamics(
    records: &[FitRecord<'_>],
    sample_time: f64,
    settings: &IdentificationSettings,
    parts: DynamicsParts,
    par: Par,
) -> Result<Identification, IdentificationError> {
    let id = fit_dynamics_beside(
        records,
        sample_time,
        settings,
        parts,
        par,
        Neighbours::default(),
    )?;
    Ok(id.expect("without neighbours no start is left to one"))
}

/// [`fit_dynamics`] beside the searches at the `neighbours`' dead times:
/// `None` when every start leaves its delay fraction to one of them.
fn fit_dynamics_beside(
    records: &[FitRecord<'_>],
    sample_time: f64,
    settings: &IdentificationSettings,
    parts: DynamicsParts,
    par: Par,
    neighbours: Neighbours,
) -> Result<Option<Identification>, IdentificationError> {
    let search = Search {
        records,
        sample_time,
        settings,
        parts,
        columns: SharedColumns::new(),
        par,
        neighbours,
    };
    let (static_id, e0) = search.residual(None)?;
    if !parts.any() {
        return Ok(Some(static_id));
    }
    let fs = 1.0 / sample_time;
    let rms_static = (sum_squares(&e0) / e0.len().max(1) as f64).sqrt();
    // the start: the best of a grid (the output error is far from convex
    // in G, and on slow records nearly flat), the resonance first with a
    // mild low-pass, then the low-pass with the best resonance
    let f_peak = spectral_peak(&e0, fs);
    let n = records.iter().map(|r| r.u.len()).max().unwrap_or(2) as f64;
    let (f_lo, f_hi) = ((20.0 * fs / n).max(0.02 * fs), 0.45 * fs);
    let mut resonances: Vec<(f64, f64)> = Vec::new();
    if parts.resonance {
        for i in 0..12 {
            let f = f_lo * (f_hi / f_lo).powf(i as f64 / 11.0);
            for zeta in [0.01, 0.05, 0.2] {
                resonances.push((f, zeta));
            }
        }
        resonances.push((f_peak.clamp(f_lo, f_hi), 0.05));
    }
    let mut best: Option<(f64, Vec<f64>)> = None;
    let low_passes = [0.03, 0.1, 0.3, 1.0].map(|f| f * fs);
    let fraction = parts.delay_fraction.then_some(0.0);
    if parts.resonance {
        let lp = parts.low_pass.then_some(0.3 * fs);
        let grid = resonances
            .iter()
            .map(|&res| coordinates(lp, Some(res), fraction))
            .collect();
        best_of(&search, &mut best, grid)?;
    }
    // the best so far as (low-pass, resonance, fraction)
    let so_far = |best: &Option<(f64, Vec<f64>)>| {
        best.as_ref().map_or((None, None, fraction), |(_, x)| {
            let g = parameters(parts, x, fs);
            (
                g.low_pass,
                g.resonance.map(|r| (r.frequency, r.damping)),
                parts.delay_fraction.then_some(g.delay_fraction),
            )
        })
    };
    if parts.low_pass {
        let (_, res, fraction) = so_far(&best);
        let grid = low_passes
            .iter()
            .map(|&lp| coordinates(Some(lp), res, fraction))
            .collect();
        best_of(&search, &mut best, grid)?;
    }
    if parts.delay_fraction {
        let (lp, res, _) = so_far(&best);
        let grid = [-0.3, 0.0, 0.3]
            .iter()
            .map(|&t| coordinates(lp, res, Some(t)))
            .collect();
        best_of(&search, &mut best, grid)?;
    }
    // Levenberg–Marquardt from the best grid point and from the residual's
    // spectral peak (where a resonance rings), the better kept
    let mut starts = vec![best.expect("at least one candidate").1];
    if parts.resonance {
        let g = parameters(parts, &starts[0], fs);
        starts.push(coordinates(
            g.low_pass,
            Some((f_peak.clamp(f_lo, f_hi), 0.05)),
            parts.delay_fraction.then_some(g.delay_fraction),
        ));
    }
    let mut refined: Option<Refined> = None;
    for r in par.map(&starts, |x0| refine(&search, x0.clone())) {
        let Some(r) = r? else { continue };
        if refined.as_ref().is_none_or(|b| r.ss < b.ss) {
            refined = Some(r);
        }
    }
    let Some(Refined {
        x, jtj, iterations, ..
    }) = refined
    else {
        return Ok(None);
    };
    let k = x.len();
    let g = parameters(parts, &x, fs);
    let (mut id, r) = search.residual(Some(g))?;
    if sum_squares(&r) >= sum_squares(&e0) {
        return Err(IdentificationError::InvalidSetting {
            field: "dynamics",
            reason: format!(
                "the records show no such dynamics: the best fit with them ({:.4e} rms) is no better than without ({rms_static:.4e}); leave them out or give records whose input excites them (other rates, faster steps)",
                (sum_squares(&r) / r.len().max(1) as f64).sqrt()
            ),
        });
    }
    // standard errors: σ̂² (JᵀJ)⁻¹ in the coordinates, then in the units
    let dof = (r.len().saturating_sub(id.report.unknowns + k)).max(1) as f64;
    let sigma2 = sum_squares(&r) / dof;
    let mut se = [None; 4];
    // a delay fraction pinned at its bound says the whole samples are off
    // by one (the next dead time is tried): it is left out of the
    // covariance, which it would make singular, as a fixed value
    let pinned = |i: usize| parts.delay_fraction && i == k - 1 && pinned_fraction(g.delay_fraction);
    let free: Vec<usize> = (0..k).filter(|&i| !pinned(i)).collect();
    let reduced: Vec<Vec<f64>> = free
        .iter()
        .map(|&i| free.iter().map(|&j| jtj[i][j]).collect())
        .collect();
    let mut covariance = vec![None; k];
    for (a, &i) in free.iter().enumerate() {
        let mut unit = vec![0.0; free.len()];
        unit[a] = 1.0;
        covariance[i] = solve_small(reduced.clone(), unit).map(|c| c[a]);
    }
    let scale = |i: usize, derivative: f64| {
        covariance[i].map(|c| (sigma2 * c).max(0.0).sqrt() * derivative)
    };
    let mut i = 0;
    if let Some(f) = g.low_pass {
        se[0] = scale(0, f);
        i = 1;
    }
    if let Some(res) = g.resonance {
        se[1] = scale(i, res.frequency);
        se[2] = scale(i + 1, res.damping * (1.0 - res.damping));
        i += 2;
    }
    if parts.delay_fraction {
        let t = g.delay_fraction / MAX_FRACTION;
        se[3] = scale(i, MAX_FRACTION * (1.0 - t * t));
    }
    // a part the records do not determine
    let diag_max = (0..k).map(|i| jtj[i][i]).fold(0.0f64, f64::max);
    let names = [
        "low-pass frequency",
        "resonance frequency",
        "resonance damping",
        "delay fraction",
    ];
    let values = [
        g.low_pass,
        g.resonance.map(|r| r.frequency),
        g.resonance.map(|r| r.damping),
        parts.delay_fraction.then_some(g.delay_fraction),
    ];
    let mut column = 0;
    for (j, name) in names.iter().enumerate() {
        let Some(value) = values[j] else { continue };
        let flat = jtj[column][column] <= 1e-14 * diag_max || diag_max == 0.0;
        let at_bound = pinned(column);
        column += 1;
        if at_bound {
            continue;
        }
        // a frequency or damping to half its value; a fraction of a
        // sample to a quarter of a sample
        let allowed = if j == 3 { 0.25 } else { 0.5 * value };
        let loose = se[j].is_none_or(|s| s.is_nan() || s > allowed);
        if flat || loose {
            return Err(IdentificationError::InvalidSetting {
                field: "dynamics",
                reason: format!(
                    "the {name} is not determined by these records ({}): give records whose input excites it (other rates, faster steps), or leave that part out",
                    match se[j] {
                        Some(s) if !flat => format!("{value:.4e} ± {s:.2e}"),
                        _ => "the output error does not change with it".into(),
                    }
                ),
            });
        }
    }
    id.report.dynamics = Some(DynamicsReport {
        parameters: g,
        standard_errors: se,
        iterations,
        rms_static,
        rms: (sum_squares(&r) / r.len().max(1) as f64).sqrt(),
    });
    Ok(Some(id))
}

/// [`fit_dynamics`] at the dead time `settings.delay`, one sample less
/// (two with a resonance: `G` adds a lag of its own, which whole samples of
/// dead time may have stood for) and, with a delay fraction, one more,
/// keeping the best: on the validation records' pooled rms
/// (zeroed where they say) when there are any, else on the fitted records'
/// output error.
pub fn fit_dynamics_and_delay(
    records: &[FitRecord<'_>],
    sample_time: f64,
    settings: &IdentificationSettings,
    parts: DynamicsParts,
    validation: &[super::Record<'_>],
    par: Par,
) -> Result<Identification, IdentificationError> {
    let d0 = settings.delay;
    let mut best: Option<(f64, Identification)> = None;
    let mut last_error = None;
    // a resonance brings one sample of lag of its own; a delay fraction
    // may call for one sample more
    let fewer = 1 + usize::from(parts.resonance);
    let more = usize::from(parts.delay_fraction);
    let (lowest, highest) = (d0.saturating_sub(fewer), d0 + more);
    let delays: Vec<usize> = (lowest..=highest).rev().collect();
    let at = |d: usize, neighbours: Neighbours| {
        let s = IdentificationSettings {
            delay: d,
            ..settings.clone()
        };
        fit_dynamics_beside(records, sample_time, &s, parts, par, neighbours)
    };
    // each dead time a search of its own, the searches side by side; a
    // start whose delay fraction runs into the next dead time is left to
    // that one's search
    let mut fits = par.map(&delays, |&d| {
        at(
            d,
            Neighbours {
                fewer: d > lowest,
                more: d < highest,
            },
        )
    });
    if fits.iter().all(|f| !matches!(f, Ok(Some(_)))) {
        // the searches they were left to found nothing either: those
        // dead times on their own
        fits = par.map(&delays, |&d| at(d, Neighbours::default()));
    }
    for fit in fits {
        // the dead time one less may leave a part undetermined where the
        // first did not: only an error when no dead time fits
        let fit = match fit {
            Ok(Some(fit)) => fit,
            Ok(None) => continue,
            Err(e) => {
                last_error.get_or_insert(e);
                continue;
            }
        };
        let score = if validation.is_empty() {
            fit.report
                .dynamics
                .as_ref()
                .map_or(f64::INFINITY, |g| g.rms)
        } else {
            super::delay::validation_rms(&fit.model, validation)?
        };
        if best.as_ref().is_none_or(|b| score < b.0) {
            best = Some((score, fit));
        }
    }
    match (best, last_error) {
        (Some((_, id)), _) => Ok(id),
        (None, Some(e)) => Err(e),
        (None, None) => unreachable!("d0 itself is always tried"),
    }
}
