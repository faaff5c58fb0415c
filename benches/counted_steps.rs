//! 200 steps of a bank of the nominal model (`f64`), or of one
//! compensator of it (`Compensator<T, nominal::Capacity>`, as in the peers
//! bench): the programs whose `counted_*` functions
//! `benches/peers/count_instructions.py` single-steps to count the
//! instructions of one step. Not a timing.
//!
//! `cargo bench --bench counted_steps -- bank CHANNELS` (default 64),
//! `… -- f64` or `… -- f32` (one compensator)

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

/// 200 steps of one compensator through `step`; the sum of its outputs.
fn run_compensator<T: Real>(
    step: fn(&mut Compensator<T, nominal::Capacity>, T) -> Compensated<T>,
) -> f64 {
    let mut c = Compensator::<T, nominal::Capacity>::new(
        &nominal::PARAMETERS,
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
