//! The compensator step against the hand-written C peers, in interleaved
//! batches in one process, so that all see the same machine: the C of
//! `benches/peers/compensator.c` built as a library (`-O3 -march=native
//! -ffast-math -DPEER_LIB -shared`) and loaded from `MFCBEAM_C_PEER`, and
//! the same built `-DBRANCH_FREE` (the strongest peer: no target test, no
//! forward plays, no re-seat) from `MFCBEAM_C_PEER_BRANCH_FREE`;
//! `benches/peers/run.sh` builds and passes both.
//!
//! Each round times one batch of 100 000 consecutive steps of every
//! implementation (in a rotating order) on the same 4096 targets (W of the
//! benches' random walk, cycled as `step/compensator_step` cycles them).
//! Reported: the median per-step time over the rounds, and the median over
//! rounds of each implementation's time divided by the C peer's in the same
//! round.

#[cfg(target_os = "linux")]
fn main() {
    use std::ffi::{c_void, CString};
    use std::hint::black_box;
    use std::time::Instant;

    use mfcbeam::prelude::*;
    use mfcbeam::realtime::{nominal, Compensator, CompensatorSettings};

    type New = unsafe extern "C" fn() -> *mut c_void;
    type Targets = unsafe extern "C" fn(*mut f64);
    type Run = unsafe extern "C" fn(*mut c_void, *const f64, *mut u32, i64) -> f64;

    const LEN: usize = 4096;
    const STEPS: usize = 100_000;
    const ROUNDS: usize = 61;

    let (Ok(path), Ok(path_bf)) = (
        std::env::var("MFCBEAM_C_PEER"),
        std::env::var("MFCBEAM_C_PEER_BRANCH_FREE"),
    ) else {
        eprintln!(
            "MFCBEAM_C_PEER and MFCBEAM_C_PEER_BRANCH_FREE are not set: run benches/peers/run.sh"
        );
        return;
    };
    // SAFETY: the libraries are benches/peers/compensator.c built with
    // -DPEER_LIB (and -DBRANCH_FREE); the symbols have the signatures
    // declared above. Loaded RTLD_LOCAL, so each keeps its own symbols.
    let load = |path: &str| unsafe {
        let lib = libc::dlopen(
            CString::new(path).unwrap().as_ptr(),
            libc::RTLD_NOW | libc::RTLD_LOCAL,
        );
        assert!(!lib.is_null(), "cannot load {path}");
        let sym = |name: &str| {
            let s = libc::dlsym(lib, CString::new(name).unwrap().as_ptr());
            assert!(!s.is_null(), "{path}: no symbol {name}");
            s
        };
        (
            std::mem::transmute::<*mut c_void, New>(sym("peer_new")),
            std::mem::transmute::<*mut c_void, Run>(sym("peer_run")),
            std::mem::transmute::<*mut c_void, Targets>(sym("peer_targets")),
        )
    };
    let (new, run, peer_targets) = load(&path);
    let (new_bf, run_bf, _) = load(&path_bf);

    let targets = nominal_model().run(&common::test_input(LEN));
    let mut c_targets = vec![0.0; LEN];
    // SAFETY: LEN doubles of room.
    unsafe { peer_targets(c_targets.as_mut_ptr()) };
    let worst = targets
        .iter()
        .zip(&c_targets)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(worst < 1e-9, "the C peer's targets differ by {worst}");

    // SAFETY: peer_new returns its static, initialised compensator.
    let peer = unsafe { new() };
    let mut peer_k = 0u32;
    // SAFETY: as above, the branch-free library's own static.
    let peer_bf = unsafe { new_bf() };
    let mut peer_bf_k = 0u32;
    let model = nominal_model();
    let mut heap = model.compensator(CompensatorSettings::default()).unwrap();
    let mut fixed64 = Compensator::<f64, nominal::Capacity>::new(
        &nominal::PARAMETERS,
        CompensatorSettings::with_limits(-1000.0, 1000.0),
    )
    .unwrap();
    let mut fixed32 = Compensator::<f32, nominal::Capacity>::new(
        &nominal::PARAMETERS,
        CompensatorSettings::with_limits(-1000.0, 1000.0),
    )
    .unwrap();
    let targets32: Vec<f32> = targets.iter().map(|&t| t as f32).collect();
    let mut ks = [0usize; 3];

    let names = [
        "C peer (-O3 -march=native -ffast-math)",
        "branch-free C peer (the same, -DBRANCH_FREE)",
        "Compensator (heap, f64)",
        "Compensator<f64, nominal::Capacity>",
        "Compensator<f32, nominal::Capacity>",
    ];
    let mut times = vec![Vec::with_capacity(ROUNDS); names.len()];
    let mut time = |which: usize, ks: &mut [usize; 3]| -> f64 {
        let t0 = Instant::now();
        match which {
            // SAFETY: the peer's pointer and LEN targets, as peer_run expects.
            0 => {
                black_box(unsafe { run(peer, c_targets.as_ptr(), &mut peer_k, STEPS as i64) });
            }
            // SAFETY: as above, for the branch-free library.
            1 => {
                black_box(unsafe {
                    run_bf(peer_bf, c_targets.as_ptr(), &mut peer_bf_k, STEPS as i64)
                });
            }
            2 => {
                let mut s = 0.0;
                for _ in 0..STEPS {
                    ks[0] = (ks[0] + 1) & (LEN - 1);
                    s += heap.compensate(black_box(targets[ks[0]])).u;
                }
                black_box(s);
            }
            3 => {
                let mut s = 0.0;
                for _ in 0..STEPS {
                    ks[1] = (ks[1] + 1) & (LEN - 1);
                    s += fixed64.compensate(black_box(targets[ks[1]])).u;
                }
                black_box(s);
            }
            _ => {
                let mut s = 0.0;
                for _ in 0..STEPS {
                    ks[2] = (ks[2] + 1) & (LEN - 1);
                    s += fixed32.compensate(black_box(targets32[ks[2]])).u;
                }
                black_box(s);
            }
        }
        t0.elapsed().as_nanos() as f64 / STEPS as f64
    };
    for which in 0..names.len() {
        time(which, &mut ks); // warm up
    }
    for round in 0..ROUNDS {
        for i in 0..names.len() {
            let which = (round + i) % names.len();
            let t = time(which, &mut ks);
            times[which].push(t);
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let ratios_to = |peer: usize| -> Vec<Vec<f64>> {
        times
            .iter()
            .map(|t| t.iter().zip(&times[peer]).map(|(a, c)| a / c).collect())
            .collect()
    };
    let (ratios, ratios_bf) = (ratios_to(0), ratios_to(1));
    println!(
        "{ROUNDS} rounds of {STEPS} steps each, interleaved; kernels: {:?}",
        mfcbeam::realtime::simd::Kernels::detect()
    );
    println!("CPU: {}", cpu_name());
    println!(
        "{:<46} {:>10} {:>10} {:>18}",
        "implementation", "median ns", "time / C", "time / branch-free"
    );
    for (i, name) in names.iter().enumerate() {
        let t = median(&mut times[i].clone());
        let r = median(&mut ratios[i].clone());
        let r_bf = median(&mut ratios_bf[i].clone());
        println!("{name:<46} {t:>10.1} {r:>10.3} {r_bf:>18.3}");
    }
    // f32 against f64, the same rounds
    let f32_vs_f64: Vec<f64> = times[4].iter().zip(&times[3]).map(|(a, b)| a / b).collect();
    println!(
        "Compensator<f32> / Compensator<f64> (nominal::Capacity): {:.3}",
        median(&mut f32_vs_f64.clone())
    );
}

/// The CPU's model name (Linux).
#[cfg(target_os = "linux")]
fn cpu_name() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|s| s.trim().to_string())
        })
        .unwrap_or_else(|| "?".into())
}

#[cfg(not(target_os = "linux"))]
fn main() {
    eprintln!("benches/peers.rs loads the C peer with dlopen: Linux only");
}

mod common;
