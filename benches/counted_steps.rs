//! 200 steps of a bank of the nominal model (`f64`), or of one
//! compensator of it (`Compensator<T, nominal::Capacity>`, as in the peers
//! bench), or 200 runs of `compensate_into` of that compensator: the
//! programs whose `counted_*` functions
//! `benches/peers/count_instructions.py` single-steps to count the
//! instructions of one step (of a run of `N` samples: the difference of
//! two lengths over theirs is the count per sample). Not a timing.
//!
//! `cargo bench --bench counted_steps -- bank CHANNELS` (default 64),
//! `… -- f64` or `… -- f32` (one compensator), `… -- run N` (runs of `N`
//! samples, `f64`)

mod common;

use common::{bank_rows, nominal_bank};
use mfcbeam::operators::bank::CompensatorBank;
use mfcbeam::realtime::{nominal, Compensated, Compensator, CompensatorSettings, Real};

/// One step of the bank, out of line and by a fixed name, so that a
/// debugger finds its start and its return.
#[no_mangle]
#[inline(never)]
pub extern "Rust" fn counted_bank_step(
    bank: &mut CompensatorBank<f64>,
    targets: &[f64],
    out: &mut [Compensated<f64>],
) {
    bank.compensate(targets, out).unwrap();
}

/// One step of a compensator of the nominal model, as
/// [`counted_bank_step`].
#[no_mangle]
#[inline(never)]
pub extern "Rust" fn counted_step_f64(
    c: &mut Compensator<f64, nominal::Capacity>,
    target: f64,
) -> Compensated<f64> {
    c.compensate(target)
}

/// [`counted_step_f64`] in `f32`.
#[no_mangle]
#[inline(never)]
pub extern "Rust" fn counted_step_f32(
    c: &mut Compensator<f32, nominal::Capacity>,
    target: f32,
) -> Compensated<f32> {
    c.compensate(target)
}

/// A run of `targets.len()` samples of a compensator of the nominal model
/// (`compensate_into`), as [`counted_bank_step`].
#[no_mangle]
#[inline(never)]
pub extern "Rust" fn counted_run_f64(
    c: &mut Compensator<f64, nominal::Capacity>,
    targets: &[f64],
    u: &mut [f64],
    saturated: &mut [bool],
    fault: &mut [bool],
) {
    c.compensate_into(targets, u, saturated, fault).unwrap();
}

/// 200 steps of one compensator through `step`; the sum of its outputs.
fn run_compensator<T: Real>(
    step: fn(&mut Compensator<T, nominal::Capacity>, T) -> Compensated<T>,
) -> f64 {
    let mut c = Compensator::<T, nominal::Capacity>::new(
        &nominal::PARAMETERS.validate().unwrap(),
        CompensatorSettings::with_limits(-1000.0, 1000.0),
    )
    .unwrap();
    let rows = bank_rows::<T>(1, 200);
    let mut sum = 0.0;
    for row in &rows {
        sum += step(&mut c, std::hint::black_box(row[0])).u.to_f64();
    }
    sum
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let what = args
        .iter()
        .find(|a| !a.starts_with('-') && a.parse::<usize>().is_err());
    let sum = match what.map(String::as_str) {
        Some("f64") => run_compensator::<f64>(counted_step_f64),
        Some("f32") => run_compensator::<f32>(counted_step_f32),
        Some("run") => {
            let n = args.iter().find_map(|a| a.parse().ok()).unwrap_or(1);
            let mut c = Compensator::<f64, nominal::Capacity>::new(
                &nominal::PARAMETERS.validate().unwrap(),
                CompensatorSettings::with_limits(-1000.0, 1000.0),
            )
            .unwrap();
            let rows = bank_rows::<f64>(1, 200 * n);
            let targets: Vec<f64> = rows.iter().map(|r| r[0]).collect();
            let (mut u, mut sat, mut fault) = (vec![0.0; n], vec![false; n], vec![false; n]);
            let mut sum = 0.0;
            for chunk in targets.chunks(n) {
                counted_run_f64(
                    &mut c,
                    std::hint::black_box(chunk),
                    &mut u,
                    &mut sat,
                    &mut fault,
                );
                sum += u[0];
            }
            sum
        }
        _ => {
            let channels = args.iter().find_map(|a| a.parse().ok()).unwrap_or(64);
            let rows = bank_rows::<f64>(channels, 200);
            let mut bank = nominal_bank::<f64>(channels);
            let mut out = vec![Compensated::<f64>::default(); channels];
            let mut sum = 0.0;
            for row in &rows {
                counted_bank_step(&mut bank, std::hint::black_box(row), &mut out);
                sum += out[0].u;
            }
            sum
        }
    };
    println!("{sum}");
}
