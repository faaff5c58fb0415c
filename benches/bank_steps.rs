//! 200 steps of a bank of the nominal model, `f64`: the program whose
//! `counted_step` `benches/peers/count_instructions.py` single-steps to
//! count the instructions of one bank step. Not a timing.
//!
//! `cargo bench --bench bank_steps -- CHANNELS` (default 64)

mod common;

use common::{bank_rows, nominal_bank};
use mfcbeam::operators::bank::CompensatorBank;
use mfcbeam::realtime::Compensated;

/// One step of the bank, out of line and by a fixed name, so that a
/// debugger finds its start and its return.
#[no_mangle]
#[inline(never)]
pub extern "Rust" fn counted_step(
    bank: &mut CompensatorBank<f64>,
    targets: &[f64],
    out: &mut [Compensated<f64>],
) {
    bank.compensate(targets, out).unwrap();
}

fn main() {
    let channels = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(64);
    let rows = bank_rows::<f64>(channels, 200);
    let mut bank = nominal_bank::<f64>(channels);
    let mut out = vec![Compensated::<f64>::default(); channels];
    let mut sum = 0.0;
    for row in &rows {
        counted_step(&mut bank, std::hint::black_box(row), &mut out);
        sum += out[0].u;
    }
    println!("{sum}");
}
