//! How `CompensatorBank::compensate_frames` should walk its frames on the
//! CPU at hand: tiles of blocks (by their state's bytes) stepped through
//! runs of frames, with and without the next tile's targets and outputs
//! prefetched, against one `compensate` a frame, for planned signals in
//! cache (64 frames) and far beyond L2 (2048 frames of 1024 channels: 48
//! MB in `f64`). Each way's M channel-steps/s, the median of 21 rounds
//! that take the ways in turn (10–90 %), and the default's row marked:
//! where another is faster beyond the rounds' spread, the default
//! (`FrameTiling::default`) is worth changing for this CPU.
//!
//! `cargo bench --features internals --bench frame_tiling`

#[path = "common/mod.rs"]
mod common;

use std::hint::black_box;
use std::time::Instant;

use common::{bank_rows, nominal_bank};
use mfcbeam::internals::FrameTiling;
use mfcbeam::internals::{cpu_description, Kernels};
use mfcbeam::realtime::{Compensated, Real};

/// A frame a call (`None`), or `compensate_frames` tiled so.
type Way = Option<FrameTiling>;

fn ways() -> Vec<Way> {
    let mut ways = vec![None, Some(FrameTiling::default())];
    for tile_kib in [12, 24, 48] {
        for run_frames in [4, 16, 64] {
            for prefetch in [false, true] {
                let tiling = FrameTiling {
                    tile_bytes: tile_kib << 10,
                    run_frames,
                    prefetch,
                };
                if !ways.contains(&Some(tiling)) {
                    ways.push(Some(tiling));
                }
            }
        }
    }
    ways
}

fn describe(way: Way) -> String {
    match way {
        None => "a frame a call (compensate)".to_string(),
        Some(t) => format!(
            "tiles of {:>2} KiB, runs of {:>2} frames, {}{}",
            t.tile_bytes >> 10,
            t.run_frames,
            if t.prefetch {
                "prefetched"
            } else {
                "not prefetched"
            },
            if t == FrameTiling::default() {
                " (the default)"
            } else {
                ""
            }
        ),
    }
}

fn table<T: Real>(channels: usize, frames: usize) {
    let rows = bank_rows::<T>(channels, frames);
    let targets: Vec<T> = rows.iter().flatten().copied().collect();
    let mut bank = nominal_bank::<T>(channels);
    let mut out = vec![Compensated::<T>::default(); channels * frames];
    let (k, ways) = (Kernels::detect(), ways());
    // about 2 ms a way and round
    let calls = (250_000 / (channels * frames)).max(1);
    let mut rates: Vec<Vec<f64>> = vec![Vec::new(); ways.len()];
    for round in 0..22 {
        for (way, rates) in ways.iter().zip(&mut rates) {
            let t0 = Instant::now();
            for _ in 0..calls {
                match way {
                    None => {
                        for (row, out) in rows.iter().zip(out.chunks_mut(channels)) {
                            bank.compensate(black_box(row), out).unwrap();
                        }
                    }
                    Some(t) => bank
                        .compensate_frames_using(k, *t, black_box(&targets), &mut out)
                        .unwrap(),
                }
            }
            black_box(&out);
            let ns = t0.elapsed().as_nanos() as f64;
            // the first round warms the caches and the clock
            if round > 0 {
                rates.push((calls * frames * channels) as f64 / ns * 1e3);
            }
        }
    }
    println!(
        "\n{}, {channels} channels, {frames} frames a call, {} kernels:",
        T::NAME,
        k.name()
    );
    for (way, rates) in ways.iter().zip(&mut rates) {
        rates.sort_by(f64::total_cmp);
        println!(
            "  {:<62} {:>7.1} M channel-steps/s ({:.1}-{:.1})",
            describe(*way),
            rates[10],
            rates[2],
            rates[18]
        );
    }
}

fn main() {
    println!("{}", cpu_description());
    for (channels, frames) in [(1024, 64), (1024, 2048), (256, 64)] {
        table::<f64>(channels, frames);
        table::<f32>(channels, frames);
    }
}
