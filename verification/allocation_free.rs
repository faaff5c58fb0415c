//! The per-sample `step` of every operator (the rate-dependent one's
//! inverse, from a clone, too, and the compensator of a model with it), of
//! the compensator and of a
//! compensator bank, with and without a superposition operator, and of the
//! built-in feedback designs allocates nothing: counted with a global
//! allocator that records every allocation.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use mfcbeam::operators::creep::{ElementaryCreepOperator, LogCreepOperator};
use mfcbeam::prelude::*;

struct Counting;

// Per thread: the test harness's own threads allocate at any time, and only
// this thread's allocations are the code under test's.
thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

/// Every thread's allocations: for the bank's worker threads, counted while
/// this file's only test holds the machine (the harness's main thread
/// waits for it without allocating).
static ALL_THREADS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

fn count() {
    let _ = ALLOCATIONS.try_with(|n| n.set(n.get() + 1));
    ALL_THREADS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations_during(f: impl FnOnce()) -> usize {
    let before = ALLOCATIONS.with(Cell::get);
    f();
    ALLOCATIONS.with(Cell::get) - before
}

#[test]
fn steps_and_in_place_runs_allocate_nothing() {
    let model = nominal_model();
    let input: Vec<f64> = (0..20_000)
        .map(|k| 1200.0 * (k as f64 * 7e-4).sin())
        .collect();
    let mut out = vec![0.0; input.len()];
    let mut sat = vec![false; input.len()];
    let mut fault = vec![false; input.len()];

    let mut play = PlayOperator::new(100.0).unwrap();
    let mut h = model.hysteresis().clone();
    let mut inv = h.inverse();
    let mut c = model.creep().unwrap().clone();
    let mut log = LogCreepOperator::new(50.0, &[500.0, 5.0, 0.05], 2e-4).unwrap();
    let mut el = ElementaryCreepOperator::new(50.0, 5.0, 2e-4).unwrap();
    let mut w = model.clone();
    // limits well inside the input range, so the saturated path runs too
    let mut comp = model
        .compensator(CompensatorSettings::with_limits(-300.0, 300.0))
        .unwrap();
    let mut bisection = mfcbeam::suite::reference::BisectionCompensator::from_file(
        &model.to_file(),
        CompensatorSettings::with_limits(-300.0, 300.0),
    )
    .unwrap();

    use mfcbeam::realtime::{nominal, Compensator, CompensatorSettings, Model};
    let mut fixed32 = Compensator::<f32, nominal::Capacity>::new(
        &nominal::PARAMETERS.validate().unwrap(),
        CompensatorSettings::with_limits(-300.0, 300.0),
    )
    .unwrap();
    let mut fixed64 = Compensator::<f64, nominal::Capacity>::new(
        &nominal::PARAMETERS.validate().unwrap(),
        CompensatorSettings::with_limits(-300.0, 300.0),
    )
    .unwrap();
    let mut plant32 =
        Model::<f32, nominal::Capacity>::new(&nominal::PARAMETERS.validate().unwrap()).unwrap();
    let mut bank = mfcbeam::operators::bank::CompensatorBank::<f32>::uniform(
        &nominal::PARAMETERS.validate().unwrap(),
        19,
        CompensatorSettings::with_limits(-300.0, 300.0),
    )
    .unwrap();
    // with an asymmetric superposition operator S: W = S[H + C], W⁻¹ with S⁻¹
    let mut file = model.to_file();
    file.superposition = Some(mfcbeam::operators::model::SuperpositionData {
        thresholds: vec![-500.0, -200.0, 0.0, 150.0, 400.0],
        weights: vec![0.25, -0.25, 1.0, -0.2, -0.15],
    });
    // and a dead time of 4 samples after it (heap and inline delay lines)
    file.delay = Some(4);
    let mut w_s = HysteresisCreepModel::from_file(&file).unwrap();
    let mut w_s_inline =
        Model::<f32, mfcbeam::realtime::Inline<12, 60, 5, 4>>::from_file(&file).unwrap();
    let s_settings = CompensatorSettings::with_limits(-300.0, 300.0);
    let mut comp_s = w_s.compensator(s_settings).unwrap();
    let mut bank_s = mfcbeam::operators::bank::CompensatorBank::<f64>::uniform(
        &file.parameters(),
        5,
        s_settings,
    )
    .unwrap();
    let mut bank_s_out = [mfcbeam::realtime::Compensated::<f64>::default(); 5];
    let mut targets = [0.0f32; 19];
    let mut bank_out = [mfcbeam::realtime::Compensated::<f32>::default(); 19];

    // a planned signal of 40 frames in one call (several runs of frames)
    let frame_targets: Vec<f32> = (0..40 * 19)
        .map(|i| (i % 97) as f32 * 7.0 - 300.0)
        .collect();
    let mut frame_out = vec![mfcbeam::realtime::Compensated::<f32>::default(); 40 * 19];
    let frame_targets_s = vec![120.0f64; 40 * 5];
    let mut frame_out_s = vec![mfcbeam::realtime::Compensated::<f64>::default(); 40 * 5];

    let mut rate = mfcbeam::operators::rate_dependent::RateDependentHysteresis::new(
        model.hysteresis().thresholds(),
        &[
            0.45, 0.1, 0.08, 0.06, 0.05, 0.04, 0.03, 0.03, 0.02, 0.02, 0.01, 0.0,
        ],
        5e-5,
        2e-4,
    )
    .unwrap();
    let mut rate_inverse = rate.clone();
    // the model and compensator with those thresholds (S, dead time)
    let mut rate_file = file.clone();
    rate_file.hysteresis.weights = rate.weights().to_vec();
    rate_file.hysteresis.rate_gain = Some(5e-5);
    let mut rate_model = HysteresisCreepModel::from_file(&rate_file).unwrap();
    let mut rate_comp = rate_model.compensator(s_settings).unwrap();
    let mut rate_comp32 = Compensator::<f32, mfcbeam::realtime::Inline<12, 60, 5, 4>>::from_file(
        &rate_file, s_settings,
    )
    .unwrap();

    let n = allocations_during(|| {
        for &v in &input {
            std::hint::black_box(rate_inverse.invert(rate.step(v)));
            std::hint::black_box(rate_model.step(rate_comp.compensate(v).u));
            std::hint::black_box(rate_comp32.compensate(v as f32));
            std::hint::black_box(play.step(v));
            std::hint::black_box(h.step(v));
            std::hint::black_box(inv.step(v));
            std::hint::black_box(c.step(v));
            std::hint::black_box(log.step(v));
            std::hint::black_box(el.step(v));
            std::hint::black_box(w.step(v));
            std::hint::black_box(comp.compensate(v));
            std::hint::black_box(bisection.compensate(v));
            std::hint::black_box(plant32.step(fixed32.compensate(v as f32).u));
            std::hint::black_box(fixed64.compensate(v));
            for (c, t) in targets.iter_mut().enumerate() {
                *t = (v as f32) * (1.0 + c as f32 / 19.0);
            }
            bank.compensate(&targets, &mut bank_out).unwrap();
            std::hint::black_box(w_s.step(comp_s.compensate(v).u));
            std::hint::black_box(w_s_inline.step(v as f32));
            bank_s.compensate(&[v; 5], &mut bank_s_out).unwrap();
        }
        targets[3] = f32::NAN;
        bank.compensate(&targets, &mut bank_out).unwrap();
        assert!(bank_out[3].fault && bank_out.iter().any(|o| o.saturated));
        std::hint::black_box(fixed32.compensate(f32::NAN));
        // non-finite samples take the held path
        std::hint::black_box(comp.compensate(f64::NAN));
        std::hint::black_box(rate_comp.compensate(f64::NAN));
        std::hint::black_box(w.step(f64::INFINITY));
        w.run_into(&input, &mut out).unwrap();
        bank.compensate_frames(&frame_targets, &mut frame_out)
            .unwrap();
        bank_s
            .compensate_frames(&frame_targets_s, &mut frame_out_s)
            .unwrap();
        let (saturated, faults) = comp
            .compensate_into(&input, &mut out, &mut sat, &mut fault)
            .unwrap();
        assert!(saturated > 0 && faults == 0);
    });
    assert_eq!(n, 0, "{n} allocations in the per-sample path");

    // a bank stepped on two threads from a control loop that runs inside
    // their pool (the documented way): no allocation in either
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let mut big = mfcbeam::operators::bank::CompensatorBank::<f64>::uniform(
        &nominal::PARAMETERS.validate().unwrap(),
        100,
        CompensatorSettings::with_limits(-300.0, 300.0),
    )
    .unwrap();
    let mut big_out = vec![mfcbeam::realtime::Compensated::<f64>::default(); 100];
    let rows: Vec<Vec<f64>> = input
        .iter()
        .take(2000)
        .map(|&v| (0..100).map(|c| v * (1.0 + c as f64 / 99.0)).collect())
        .collect();
    let par = mfcbeam::operators::bank::Par::rayon(2);
    let n = pool.install(|| {
        big.compensate_on(par, &rows[0], &mut big_out).unwrap(); // the threads started
        let before = ALL_THREADS.load(std::sync::atomic::Ordering::SeqCst);
        for row in &rows {
            big.compensate_on(par, row, &mut big_out).unwrap();
        }
        ALL_THREADS.load(std::sync::atomic::Ordering::SeqCst) - before
    });
    assert_eq!(
        n, 0,
        "{n} allocations in 2000 steps of a bank on two threads"
    );
    // the built-in feedback designs: one step per sample of a loop
    let bench = mfcbeam::control::Benchmark::nominal().unwrap();
    for kind in [
        mfcbeam::control::BuiltinController::Pid,
        mfcbeam::control::BuiltinController::StateFeedback,
    ] {
        use mfcbeam::control::Controller;
        let mut c = bench.controller_file(kind).unwrap().build().unwrap();
        let n = allocations_during(|| {
            for k in 0..2000 {
                let s = mfcbeam::control::LoopSample {
                    k,
                    t: k as f64 * 2e-4,
                    reference: 1e-3,
                    measurement: 1e-3 * (k as f64 * 1e-2).sin(),
                };
                std::hint::black_box(c.step(&s).unwrap());
            }
        });
        assert_eq!(n, 0, "{n} allocations in 2000 steps of {kind:?}");
    }
    // the counter does see allocations
    assert!(
        allocations_during(|| {
            std::hint::black_box(vec![1.0f64; 3]);
        }) >= 1
    );
    assert!(
        allocations_during(|| {
            std::hint::black_box(h.state());
        }) >= 1
    );
}
