//! The compensator step against the hand-written C peers, in interleaved
//! batches in one process, so that all see the same machine: the C of
//! `benches/peers/compensator.c` built as a library (`-O3 -march=native
//! -ffast-math -DPEER_LIB -shared`) and loaded from `MFCBEAM_C_PEER`, the
//! same built `-DBRANCH_FREE` (scalar, no target test, no forward plays, no
//! re-seat) from `MFCBEAM_C_PEER_BRANCH_FREE`, and the strongest, built
//! `-DSTRONG` (AVX2 intrinsics with FMA, a running creep sum, the chain cut
//! to its minimum) from `MFCBEAM_C_PEER_STRONG`, the strongest built with
//! `-DNO_FMA` (each FMA a multiply and an add, as mfcbeam computes) from
//! `MFCBEAM_C_PEER_STRONG_NO_FMA`, mfcbeam's own order of operations in
//! intrinsics (`-DSAME_ORDER`, the same bits) from
//! `MFCBEAM_C_PEER_SAME_ORDER`, and the strongest written in `f32`
//! (`-DSTRONG_F32`: eight lanes per register) from
//! `MFCBEAM_C_PEER_STRONG_F32`, and the strongest kept out of line, one
//! call per sample (`-DONE_CALL`), from `MFCBEAM_C_PEER_STRONG_CALL`;
//! `benches/peers/run.sh` builds and passes all seven. `MFCBEAM_C_API`
//! names mfcbeam's own C library (`libmfcbeam.so` of `capi/`), timed as a C
//! program calls it: a heap handle, one `mfcbeam_compensator_compensate` per sample and
//! runs of `mfcbeam_compensator_compensate_into`; and a compensator in storage the
//! caller owns (`mfcbeam_compensator_f64_init_json`, the microcontroller's
//! way), `f64` and `f32`, one call per sample and runs.
//!
//! Each round times one batch of 100 000 consecutive steps of every
//! implementation (in a rotating order) on the same 4096 targets (W of the
//! benches' random walk, cycled as `step/compensator_step` cycles them).
//! mfcbeam is timed two ways: one `compensate` call per sample, and runs of
//! `compensate_into` (one loop in the kernels' function). The C's
//! `peer_run` is a loop over its step, which the compiler inlines; like
//! against like, a run is compared with that loop and one call per sample
//! with the strongest C's step called once per sample (`-DONE_CALL`).
//! Reported: the CPU and the kernel set, the median per-step time over the
//! rounds with the 10th–90th percentile spread, and the median (and spread)
//! over rounds of each implementation's time divided by the strongest C
//! peer's in the same round, the like-against-like ratios, and what `f32`
//! buys (`f32` over `f64` time, the C against the C, mfcbeam against
//! mfcbeam); last a `summary:` line that `run.sh` collects from three
//! processes.

#[cfg(target_os = "linux")]
fn main() {
    use std::ffi::{c_char, c_int, c_void, CString};
    use std::hint::black_box;
    use std::time::Instant;

    use mfcbeam::prelude::*;
    use mfcbeam::realtime::{nominal, Compensator, CompensatorSettings};

    type New = unsafe extern "C" fn() -> *mut c_void;
    type Targets = unsafe extern "C" fn(*mut f64);
    type Run = unsafe extern "C" fn(*mut c_void, *const f64, *mut u32, i64) -> f64;
    type FromJson =
        unsafe extern "C" fn(*const c_char, f64, f64, *mut c_char, usize) -> *mut c_void;
    type ApiStep = unsafe extern "C" fn(*mut c_void, f64, *mut c_int) -> f64;
    type ApiRun =
        unsafe extern "C" fn(*mut c_void, *const f64, *mut f64, *mut c_int, usize) -> c_int;
    type InitJson =
        unsafe extern "C" fn(*mut c_void, *const c_char, f64, f64, *mut c_char, usize) -> c_int;
    type OwnedStep32 = unsafe extern "C" fn(*mut c_void, f32, *mut c_int) -> f32;
    type OwnedRun32 =
        unsafe extern "C" fn(*mut c_void, *const f32, *mut f32, *mut c_int, usize) -> c_int;

    const LEN: usize = 4096;
    const STEPS: usize = 100_000;
    const ROUNDS: usize = 61;

    let vars = [
        "MFCBEAM_C_PEER",
        "MFCBEAM_C_PEER_BRANCH_FREE",
        "MFCBEAM_C_PEER_STRONG",
        "MFCBEAM_C_PEER_STRONG_NO_FMA",
        "MFCBEAM_C_PEER_SAME_ORDER",
        "MFCBEAM_C_PEER_STRONG_F32",
        "MFCBEAM_C_PEER_STRONG_CALL",
        "MFCBEAM_C_API",
    ];
    let Ok(paths) = vars
        .iter()
        .map(std::env::var)
        .collect::<Result<Vec<_>, _>>()
    else {
        eprintln!("{} are not set: run benches/peers/run.sh", vars.join(", "));
        return;
    };
    // SAFETY: the libraries are benches/peers/compensator.c built with
    // -DPEER_LIB (and one of the variants); the symbols have the
    // signatures declared above.
    let load = |path: &str| unsafe {
        let [new, run, targets] = common::c_symbols(path, ["peer_new", "peer_run", "peer_targets"]);
        (
            std::mem::transmute::<*mut c_void, New>(new),
            std::mem::transmute::<*mut c_void, Run>(run),
            std::mem::transmute::<*mut c_void, Targets>(targets),
        )
    };
    let (api_path, paths) = paths.split_last().unwrap();
    let peers: Vec<_> = paths.iter().map(|p| load(p)).collect();
    // SAFETY: libmfcbeam.so of capi/; the symbols as include/mfcbeam.h
    // declares them.
    let (api_step, api_run, api) = unsafe {
        let [from_json, step, run] = common::c_symbols(
            api_path,
            [
                "mfcbeam_compensator_from_json",
                "mfcbeam_compensator_compensate",
                "mfcbeam_compensator_compensate_into",
            ],
        );
        let json = CString::new(include_str!("../golden/nominal_model.json")).unwrap();
        let mut err = [0 as c_char; 256];
        let from_json = std::mem::transmute::<*mut c_void, FromJson>(from_json);
        let handle = from_json(json.as_ptr(), -1000.0, 1000.0, err.as_mut_ptr(), err.len());
        assert!(!handle.is_null(), "{api_path}: the nominal model refused");
        (
            std::mem::transmute::<*mut c_void, ApiStep>(step),
            std::mem::transmute::<*mut c_void, ApiRun>(run),
            handle,
        )
    };
    // caller-owned storage: the header's word counts, the nominal model
    // written into it by the JSON init
    let words = |name: &str| -> usize {
        let define = format!("#define {name} ");
        include_str!("../include/mfcbeam.h")
            .lines()
            .find_map(|l| l.strip_prefix(define.as_str()))
            .and_then(|n| n.trim().parse().ok())
            .unwrap_or_else(|| panic!("include/mfcbeam.h defines no {name}"))
    };
    let mut owned64_words = vec![0u64; words("MFCBEAM_COMPENSATOR_F64_WORDS")];
    let mut owned32_words = vec![0u64; words("MFCBEAM_COMPENSATOR_F32_WORDS")];
    // SAFETY: libmfcbeam.so of capi/; the symbols as include/mfcbeam.h
    // declares them, the storage of the header's size.
    let (owned_step64, owned_run64, owned_step32, owned_run32) = unsafe {
        let [init64, step64, run64, init32, step32, run32] = common::c_symbols(
            api_path,
            [
                "mfcbeam_compensator_f64_init_json",
                "mfcbeam_compensator_f64_compensate",
                "mfcbeam_compensator_f64_compensate_into",
                "mfcbeam_compensator_f32_init_json",
                "mfcbeam_compensator_f32_compensate",
                "mfcbeam_compensator_f32_compensate_into",
            ],
        );
        let json = CString::new(include_str!("../golden/nominal_model.json")).unwrap();
        let mut err = [0 as c_char; 256];
        for (init, storage) in [
            (init64, owned64_words.as_mut_ptr()),
            (init32, owned32_words.as_mut_ptr()),
        ] {
            let init = std::mem::transmute::<*mut c_void, InitJson>(init);
            let rc = init(
                storage.cast(),
                json.as_ptr(),
                -1000.0,
                1000.0,
                err.as_mut_ptr(),
                err.len(),
            );
            assert_eq!(
                rc, 0,
                "{api_path}: the nominal model refused in owned storage"
            );
        }
        (
            std::mem::transmute::<*mut c_void, ApiStep>(step64),
            std::mem::transmute::<*mut c_void, ApiRun>(run64),
            std::mem::transmute::<*mut c_void, OwnedStep32>(step32),
            std::mem::transmute::<*mut c_void, OwnedRun32>(run32),
        )
    };
    let (owned64, owned32): (*mut c_void, *mut c_void) = (
        owned64_words.as_mut_ptr().cast(),
        owned32_words.as_mut_ptr().cast(),
    );
    let mut api_flags = vec![0 as c_int; LEN];
    let peer_targets = peers[0].2;

    let targets = nominal_model().run(&common::test_input(LEN));
    let mut c_targets = vec![0.0; LEN];
    // SAFETY: LEN doubles of room.
    unsafe { peer_targets(c_targets.as_mut_ptr()) };
    let worst = targets
        .iter()
        .zip(&c_targets)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(worst < 1e-9, "the C peer's targets differ by {worst}");

    // SAFETY: peer_new returns the library's static, initialised
    // compensator (each library its own).
    let c_states: Vec<*mut c_void> = peers.iter().map(|p| unsafe { (p.0)() }).collect();
    let mut c_ks = vec![0u32; peers.len()];
    let model = nominal_model();
    let mut heap = model.compensator(CompensatorSettings::default()).unwrap();
    let mut fixed64 = Compensator::<f64, nominal::Capacity>::new(
        &nominal::PARAMETERS.validate().unwrap(),
        CompensatorSettings::with_limits(-1000.0, 1000.0),
    )
    .unwrap();
    let mut fixed32 = Compensator::<f32, nominal::Capacity>::new(
        &nominal::PARAMETERS.validate().unwrap(),
        CompensatorSettings::with_limits(-1000.0, 1000.0),
    )
    .unwrap();
    let targets32: Vec<f32> = targets.iter().map(|&t| t as f32).collect();
    let mut ks = [0usize; 11];
    let mut into64 = fixed64.clone();
    let mut into32 = fixed32.clone();
    let (mut u64s, mut u32s) = (vec![0.0f64; LEN], vec![0.0f32; LEN]);
    let (mut sat, mut fault) = (vec![false; LEN], vec![false; LEN]);

    let names = [
        "C peer (-O3 -march=native -ffast-math)",
        "branch-free C peer (the same, -DBRANCH_FREE)",
        "strongest C peer (AVX2 + FMA, -DSTRONG)",
        "strongest C peer without FMA (-DNO_FMA)",
        "mfcbeam's order in C (-DSAME_ORDER)",
        "strongest C peer in f32 (-DSTRONG_F32)",
        "strongest C, one call per step (-DONE_CALL)",
        "Compensator (heap, f64)",
        "Compensator<f64, nominal::Capacity>",
        "Compensator<f32, nominal::Capacity>",
        "the same f64, a run (compensate_into)",
        "the same f32, a run (compensate_into)",
        "C API f64, one call per sample (heap handle)",
        "C API f64, a run (mfcbeam_compensator_compensate_into)",
        "C API f64, caller-owned storage, one call per sample",
        "C API f64, caller-owned storage, a run",
        "C API f32, caller-owned storage, one call per sample",
        "C API f32, caller-owned storage, a run",
    ];
    // rows of `names`: the C peers first, in `vars`' order, then mfcbeam's
    // in Rust, then through its C library; named where they are timed and
    // compared
    const STRONGEST: usize = 2;
    const STRONGEST_F32: usize = 5;
    const STRONGEST_CALL: usize = 6;
    const HEAP_F64: usize = 7;
    const INLINE_F64: usize = 8;
    const INLINE_F32: usize = 9;
    const INTO_F64: usize = 10;
    const INTO_F32: usize = 11;
    const API_CALL: usize = 12;
    const API_RUN: usize = 13;
    const OWNED_CALL_F64: usize = 14;
    const OWNED_RUN_F64: usize = 15;
    const OWNED_CALL_F32: usize = 16;
    const OWNED_RUN_F32: usize = 17;
    assert_eq!(peers.len(), HEAP_F64);
    assert_eq!(names.len(), OWNED_RUN_F32 + 1);
    let mut times = vec![Vec::with_capacity(ROUNDS); names.len()];
    // STEPS targets from `k` on, cycling through the LEN of them, as
    // peer_run takes them: whole runs of `compensate_into`
    macro_rules! run_into {
        ($c:expr, $targets:expr, $u:expr, $k:expr) => {{
            let mut left = STEPS;
            while left > 0 {
                let n = (LEN - $k).min(left);
                let range = $k..$k + n;
                black_box($c.compensate_into(
                    black_box(&$targets[range.clone()]),
                    &mut $u[range.clone()],
                    &mut sat[range.clone()],
                    &mut fault[range],
                ))
                .unwrap();
                $k = ($k + n) % LEN;
                left -= n;
            }
            black_box(&$u);
        }};
    }
    // STEPS targets from `k` on through a C API run call, as `run_into!`
    macro_rules! api_run {
        ($run:expr, $c:expr, $targets:expr, $u:expr, $k:expr) => {{
            let mut left = STEPS;
            while left > 0 {
                let n = (LEN - $k).min(left);
                let k = $k;
                // SAFETY: a live compensator and `n` values from `k` in each array.
                let rc = unsafe {
                    $run(
                        $c,
                        black_box($targets[k..].as_ptr()),
                        $u[k..].as_mut_ptr(),
                        api_flags[k..].as_mut_ptr(),
                        n,
                    )
                };
                assert_eq!(rc, 0);
                $k = (k + n) % LEN;
                left -= n;
            }
            black_box(&$u);
        }};
    }
    // one C API call per sample, STEPS of them
    macro_rules! api_calls {
        ($step:expr, $c:expr, $targets:expr, $k:expr) => {{
            let mut s = 0.0;
            let mut flags = 0;
            for _ in 0..STEPS {
                $k = ($k + 1) & (LEN - 1);
                // SAFETY: a live compensator and a writable int.
                s += unsafe { $step($c, black_box($targets[$k]), &mut flags) };
            }
            black_box((s, flags));
        }};
    }
    let mut time = |which: usize, ks: &mut [usize; 11]| -> f64 {
        let t0 = Instant::now();
        match which {
            // SAFETY: the peer's pointer and LEN targets, as peer_run expects.
            0..HEAP_F64 => {
                black_box(unsafe {
                    (peers[which].1)(
                        c_states[which],
                        c_targets.as_ptr(),
                        &mut c_ks[which],
                        STEPS as i64,
                    )
                });
            }
            HEAP_F64 => {
                let mut s = 0.0;
                for _ in 0..STEPS {
                    ks[0] = (ks[0] + 1) & (LEN - 1);
                    s += heap.compensate(black_box(targets[ks[0]])).u;
                }
                black_box(s);
            }
            INLINE_F64 => {
                let mut s = 0.0;
                for _ in 0..STEPS {
                    ks[1] = (ks[1] + 1) & (LEN - 1);
                    s += fixed64.compensate(black_box(targets[ks[1]])).u;
                }
                black_box(s);
            }
            INLINE_F32 => {
                let mut s = 0.0;
                for _ in 0..STEPS {
                    ks[2] = (ks[2] + 1) & (LEN - 1);
                    s += fixed32.compensate(black_box(targets32[ks[2]])).u;
                }
                black_box(s);
            }
            INTO_F64 => run_into!(into64, targets, u64s, ks[3]),
            INTO_F32 => run_into!(into32, targets32, u32s, ks[4]),
            API_CALL => api_calls!(api_step, api, targets, ks[5]),
            API_RUN => api_run!(api_run, api, targets, u64s, ks[6]),
            OWNED_CALL_F64 => api_calls!(owned_step64, owned64, targets, ks[7]),
            OWNED_RUN_F64 => api_run!(owned_run64, owned64, targets, u64s, ks[8]),
            OWNED_CALL_F32 => api_calls!(owned_step32, owned32, targets32, ks[9]),
            OWNED_RUN_F32 => api_run!(owned_run32, owned32, targets32, u32s, ks[10]),
            _ => unreachable!("row {which} of {} names", names.len()),
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
    // the p-th quantile of the rounds (nearest rank)
    let quantile = |v: &[f64], p: f64| {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        v[((v.len() - 1) as f64 * p).round() as usize]
    };
    let ratios: Vec<Vec<f64>> = times
        .iter()
        .map(|t| {
            t.iter()
                .zip(&times[STRONGEST])
                .map(|(a, c)| a / c)
                .collect()
        })
        .collect();
    println!("CPU: {}", mfcbeam::internals::cpu_description());
    let k = mfcbeam::internals::Kernels::detect();
    println!(
        "kernels: {} (the f64 step on {}, the f32 step on {}); {ROUNDS} rounds of {STEPS} steps each, interleaved",
        k.name(),
        k.for_single_step::<f64>().name(),
        k.for_single_step::<f32>().name()
    );
    println!(
        "{:<46} {:>9} {:>15} {:>12} {:>15}",
        "implementation", "median ns", "p10-p90 ns", "/ strongest", "p10-p90"
    );
    let mut summary = Vec::new();
    for (i, name) in names.iter().enumerate() {
        let (t, r) = (&times[i], &ratios[i]);
        println!(
            "{name:<46} {:>9.2} {:>7.2}-{:<7.2} {:>12.3} {:>7.3}-{:<7.3}",
            quantile(t, 0.5),
            quantile(t, 0.1),
            quantile(t, 0.9),
            quantile(r, 0.5),
            quantile(r, 0.1),
            quantile(r, 0.9)
        );
        summary.push(format!("{:.4}/{:.4}", quantile(t, 0.5), quantile(r, 0.5)));
    }
    // one row's time over another's, round by round
    let over = |a: usize, b: usize| -> Vec<f64> {
        times[a].iter().zip(&times[b]).map(|(x, y)| x / y).collect()
    };
    // like against like: one call per sample against the C's step called
    // once per sample, a run against the C's loop over its inlined step;
    // then what `f32` buys. Each: its line, the two rows, and the key of
    // its median in the summary (`run.sh` reads them in this order).
    let lines = [
        (
            "one call per sample: Compensator<f64> / the strongest C's",
            INLINE_F64,
            STRONGEST_CALL,
            Some("call/c_call"),
        ),
        (
            "a run: compensate_into f64 / the strongest C's loop",
            INTO_F64,
            STRONGEST,
            None,
        ),
        (
            "a run: compensate_into f32 / the strongest C's loop in f32",
            INTO_F32,
            STRONGEST_F32,
            None,
        ),
        (
            "a run: compensate_into f32 / f64",
            INTO_F32,
            INTO_F64,
            Some("run_f32/f64"),
        ),
        (
            "Compensator<f32> / Compensator<f64> (nominal::Capacity)",
            INLINE_F32,
            INLINE_F64,
            Some("f32/f64"),
        ),
        (
            "strongest C in f32 / strongest C in f64",
            STRONGEST_F32,
            STRONGEST,
            Some("c_f32/f64"),
        ),
        (
            "Compensator<f32> / strongest C in f32",
            INLINE_F32,
            STRONGEST_F32,
            None,
        ),
        (
            "C API, one call per sample: mfcbeam_compensator_compensate / the strongest C's",
            API_CALL,
            STRONGEST_CALL,
            Some("api_call/c_call"),
        ),
        (
            "C API, a run: mfcbeam_compensator_compensate_into / the strongest C's loop",
            API_RUN,
            STRONGEST,
            Some("api_run/c_loop"),
        ),
        (
            "C API, caller-owned storage, one call per sample: mfcbeam_compensator_f64_compensate / the strongest C's",
            OWNED_CALL_F64,
            STRONGEST_CALL,
            Some("owned_call/c_call"),
        ),
        (
            "C API, caller-owned storage, a run: mfcbeam_compensator_f64_compensate_into / the strongest C's loop",
            OWNED_RUN_F64,
            STRONGEST,
            Some("owned_run/c_loop"),
        ),
        (
            "C API, caller-owned storage, a run in f32 / the strongest C's loop in f32",
            OWNED_RUN_F32,
            STRONGEST_F32,
            Some("owned_run_f32/c_f32_loop"),
        ),
    ];
    for (name, a, b, key) in lines {
        let r = over(a, b);
        println!(
            "{name}: {:.3} (p10-p90 {:.3}-{:.3})",
            quantile(&r, 0.5),
            quantile(&r, 0.1),
            quantile(&r, 0.9)
        );
        if let Some(key) = key {
            summary.push(format!("{key}={:.4}", quantile(&r, 0.5)));
        }
    }
    // median ns / median ratio to the strongest peer, per implementation,
    // then the keyed ratios
    println!("summary: {}", summary.join(" "));
    let median = |a: usize, b: usize| vec![quantile(&over(a, b), 0.5)];
    let figure = |name: &str, unit, values| common::results::Figure {
        name: name.to_string(),
        unit,
        values,
    };
    common::results::record(
        "peers",
        &[
            figure(
                "step_f64_run_over_strongest_c",
                "ratio",
                median(INTO_F64, STRONGEST),
            ),
            figure(
                "step_f64_call_over_strongest_c",
                "ratio",
                median(INLINE_F64, STRONGEST_CALL),
            ),
            figure("step_f32_over_f64_run", "ratio", median(INTO_F32, INTO_F64)),
            figure(
                "step_f32_over_f64_call",
                "ratio",
                median(INLINE_F32, INLINE_F64),
            ),
            figure(
                "strongest_c_f32_over_f64",
                "ratio",
                median(STRONGEST_F32, STRONGEST),
            ),
            figure(
                "capi_call_over_strongest_c",
                "ratio",
                median(API_CALL, STRONGEST_CALL),
            ),
            figure(
                "step_f64_run_ns",
                "ns",
                vec![quantile(&times[INTO_F64], 0.5)],
            ),
        ],
    );
}

#[cfg(not(target_os = "linux"))]
fn main() {
    eprintln!("benches/peers.rs loads the C peer with dlopen: Linux only");
}

mod common;
