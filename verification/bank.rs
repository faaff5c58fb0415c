//! `CompensatorBank`: every channel gives the bits of a single
//! inline `Compensator` of its model (one shared model or one per channel,
//! `f32` and `f64`, through saturation, recovery and non-finite targets),
//! every kernel set gives the bits of the portable one (at every order
//! and wherever the state lies in memory), and bad parameters and slices
//! are refused with the field named.

use mfcbeam::internals as simd;
use mfcbeam::operators::bank::{CompensatorBank, Par};
use mfcbeam::operators::model::ModelFile;
use mfcbeam::operators::nominal::nominal_model_file;
use mfcbeam::realtime::{Compensator, CompensatorSettings, Inline, ParameterError, Real};
use mfcbeam::suite::conformance::{random_model, ModelShape, Rng};

type Single<T> = Compensator<T, Inline<12, 72>>;
/// A compensator on the heap: any layout, the general step or the paper's.
type Free<T> = Compensator<T, mfcbeam::operators::heap::Heap>;
/// An inline compensator with the paper's layout's room for the plays and
/// creep (and the default room for `S` and a dead time).
type Placed<T> = Compensator<T, Inline<12, 60>>;

/// `count` models of one shape (random, or the paper's model): the first as
/// drawn, the others with weights scaled (which keeps (11) and (17)) and
/// their own offsets.
fn models(rng: &mut Rng, count: usize, paper_order: bool) -> Vec<ModelFile> {
    let base = if paper_order {
        nominal_model_file()
    } else {
        random_model(rng, 12, ModelShape::Virgin)
    };
    (0..count)
        .map(|c| {
            let mut m = base.clone();
            if c > 0 {
                let k = rng.uniform(0.5, 2.0);
                m.hysteresis.weights.iter_mut().for_each(|w| *w *= k);
                if let Some(cr) = &mut m.creep {
                    let k = rng.uniform(0.5, 2.0);
                    cr.weights.iter_mut().for_each(|w| *w *= k);
                }
                m.offset = Some(rng.uniform(-50.0, 50.0));
            }
            m
        })
        .collect()
}

/// Linear dynamics for the model file `f`: a resonance at a tenth of its
/// sample rate, lightly damped, with a fractional delay `delay_fraction`.
fn resonance(
    f: &ModelFile,
    delay_fraction: Option<f64>,
) -> mfcbeam::operators::model::DynamicsData {
    use mfcbeam::operators::model::{DynamicsData, ResonanceData};
    DynamicsData {
        low_pass: None,
        resonance: Some(ResonanceData {
            frequency: 0.1 / f.sample_time,
            damping: 0.05,
        }),
        delay_fraction,
        state: None,
    }
}

/// Targets for `channels` channels over `len` samples: random walks that
/// overshoot the limits now and then, with a non-finite target every so often.
fn targets(rng: &mut Rng, channels: usize, len: usize, limit: f64) -> Vec<Vec<f64>> {
    let mut level = vec![0.0; channels];
    (0..len)
        .map(|_| {
            (0..channels)
                .map(|c| {
                    level[c] = (level[c] + rng.uniform(-0.2, 0.2) * limit)
                        .clamp(-1.5 * limit, 1.5 * limit);
                    match rng.int(0, 200) {
                        0 => f64::NAN,
                        1 => f64::INFINITY,
                        _ => level[c],
                    }
                })
                .collect()
        })
        .collect()
}

fn same_as_singles<T: Real>(seed: u64, channels: usize, shared: bool, paper_order: bool) {
    let mut rng = Rng::new(seed);
    let files = models(&mut rng, if shared { 1 } else { channels }, paper_order);
    let params: Vec<_> = files.iter().map(ModelFile::parameters).collect();
    let limit = rng.uniform(100.0, 600.0);
    let mut bank = if shared {
        CompensatorBank::<T>::uniform(
            &params[0],
            channels,
            CompensatorSettings::with_limits(-limit, limit),
        )
        .unwrap()
    } else {
        CompensatorBank::<T>::new(&params, CompensatorSettings::with_limits(-limit, limit)).unwrap()
    };
    // the bank on every kernel set this CPU has, the portable one first
    let mut each: Vec<_> = simd::Kernels::all().map(|k| (k, bank.clone())).collect();
    let mut singles: Vec<Single<T>> = (0..channels)
        .map(|c| {
            Single::<T>::new(
                &params[if shared { 0 } else { c }].validate().unwrap(),
                CompensatorSettings::with_limits(-limit, limit),
            )
            .unwrap()
        })
        .collect();
    let mut out = vec![Default::default(); channels];
    let mut out_each = out.clone();
    let (mut saturated, mut faults) = (0, 0);
    for row in targets(&mut rng, channels, 1500, limit) {
        let row: Vec<T> = row.iter().map(|&t| T::from_f64(t)).collect();
        bank.compensate(&row, &mut out).unwrap();
        for (k, other) in &mut each {
            other.compensate_using(*k, &row, &mut out_each).unwrap();
            assert_eq!(
                out, out_each,
                "seed {seed}: {k:?} and the default kernels differ"
            );
        }
        for c in 0..channels {
            let single = singles[c].compensate(row[c]);
            assert_eq!(
                (out[c].u.to_f64().to_bits(), out[c].saturated, out[c].fault),
                (single.u.to_f64().to_bits(), single.saturated, single.fault),
                "seed {seed}, channel {c} of {channels}: bank {:?}, single {single:?}",
                out[c]
            );
            saturated += usize::from(single.saturated);
            faults += usize::from(single.fault);
        }
    }
    // the run went through the cases it is meant to cover
    assert!(
        saturated > 0 && faults > 0,
        "seed {seed}: {saturated} saturated, {faults} faults"
    );
}

#[test]
fn each_channel_is_a_single_compensator_bit_for_bit() {
    for seed in 0..24 {
        for channels in [1, 3, 8, 13, 17, 40] {
            same_as_singles::<f64>(seed, channels, seed % 2 == 0, false);
            same_as_singles::<f32>(seed, channels, seed % 2 == 1, false);
        }
    }
}

/// The same at the paper's order (12 plays, 12 creep thresholds × 5
/// eigenvalues), for which the step is compiled with its loop counts known
/// (the random shapes above rarely draw it).
#[test]
fn at_the_paper_order_each_channel_is_a_single_compensator_bit_for_bit() {
    for seed in 0..8 {
        for channels in [1, 8, 13, 40] {
            same_as_singles::<f64>(seed, channels, seed % 2 == 0, true);
            same_as_singles::<f32>(seed, channels, seed % 2 == 1, true);
        }
    }
}

#[test]
fn every_kernel_set_gives_the_portable_bits() {
    eprintln!("kernels on this CPU: {:?}", simd::Kernels::detect());
    let mut rng = Rng::new(7);
    for seed in 0..40u64 {
        let file = random_model(&mut rng, 12, ModelShape::Any);
        let p = file.parameters();
        let mut a = Single::<f64>::new(
            &p.validate().unwrap(),
            CompensatorSettings::with_limits(-700.0, 700.0),
        )
        .unwrap();
        let mut b = a.clone();
        let mut a32 = Single::<f32>::new(
            &p.validate().unwrap(),
            CompensatorSettings::with_limits(-700.0, 700.0),
        )
        .unwrap();
        let mut b32 = a32.clone();
        // every kernel set the CPU has, against the portable one
        let mut each: Vec<_> = simd::Kernels::all()
            .map(|k| (k, a.clone(), a32.clone()))
            .collect();
        for row in targets(&mut Rng::new(seed), 1, 2000, 700.0) {
            let t = row[0];
            let expected = b.compensate_portable(t);
            assert_eq!(a.compensate(t), expected, "seed {seed}");
            let expected32 = b32.compensate_portable(t as f32);
            assert_eq!(a32.compensate(t as f32), expected32, "seed {seed}");
            for (k, c, c32) in &mut each {
                assert_eq!(c.compensate_using(*k, t), expected, "seed {seed}, {k:?}");
                assert_eq!(
                    c32.compensate_using(*k, t as f32),
                    expected32,
                    "seed {seed}, {k:?}"
                );
            }
        }
    }
}

/// The same at every order the kernels treat differently: 1 to 40 plays
/// and creep thresholds (whole 8- and 4-lane blocks, the scalar tail),
/// limited and unlimited, with targets far beyond the plays (up to `10³⁸`,
/// where `f32` overflows).
#[test]
fn every_kernel_set_gives_the_portable_bits_at_every_order() {
    let mut rng = Rng::new(11);
    for seed in 0..60u64 {
        let file = random_model(&mut rng, 40, ModelShape::Any);
        let p = file.parameters();
        let settings = if seed % 2 == 0 {
            CompensatorSettings::unlimited()
        } else {
            CompensatorSettings::with_limits(-700.0, 700.0)
        };
        let mut b = Free::<f64>::new(&p.validate().unwrap(), settings).unwrap();
        let mut b32 = Free::<f32>::new(&p.validate().unwrap(), settings).unwrap();
        let mut each: Vec<_> = simd::Kernels::all()
            .map(|k| (k, b.clone(), b32.clone()))
            .collect();
        let mut signal: Vec<f64> = targets(&mut Rng::new(seed), 1, 400, 1500.0)
            .into_iter()
            .map(|row| row[0])
            .collect();
        signal.extend([1e30, -1e38, 3e38, 0.0, -0.0, 5.0]);
        for t in signal {
            let expected = b.compensate_portable(t);
            let expected32 = b32.compensate_portable(t as f32);
            for (k, c, c32) in &mut each {
                let (u, u32) = (
                    c.compensate_using(*k, t),
                    c32.compensate_using(*k, t as f32),
                );
                assert_eq!(
                    (u.u.to_f64().to_bits(), u.saturated, u.fault),
                    (expected.u.to_bits(), expected.saturated, expected.fault),
                    "seed {seed}, {k:?}, target {t}"
                );
                assert_eq!(
                    (u32.u.to_bits(), u32.saturated, u32.fault),
                    (
                        expected32.u.to_bits(),
                        expected32.saturated,
                        expected32.fault
                    ),
                    "seed {seed}, {k:?}, target {t} (f32)"
                );
            }
        }
    }
}

/// The same for the step compiled for the paper's layout (12 plays, 12
/// creep thresholds × 5 eigenvalues): random models of that layout
/// (the paper's thresholds and weights scaled, random eigenvalues, with the
/// offset, `S` and dead time a random model draws), inline and on the heap,
/// limited and unlimited, with targets far beyond the plays; and a layout
/// one short of it (11 plays) through the general step.
#[test]
fn the_paper_layouts_step_gives_the_portable_bits() {
    let mut rng = Rng::new(29);
    for seed in 0..40u64 {
        let drawn = random_model(&mut rng, 12, ModelShape::Any);
        let mut file = nominal_model_file();
        let (r, w, wc) = (
            rng.uniform(0.3, 3.0),
            rng.uniform(0.3, 3.0),
            rng.uniform(0.0, 3.0),
        );
        file.hysteresis.thresholds.iter_mut().for_each(|x| *x *= r);
        file.hysteresis.weights.iter_mut().for_each(|x| *x *= w);
        let creep = file.creep.as_mut().unwrap();
        creep.thresholds.iter_mut().for_each(|x| *x *= r);
        creep.weights.iter_mut().for_each(|x| *x *= wc);
        creep
            .eigenvalues
            .iter_mut()
            .for_each(|a| *a = 10f64.powf(rng.uniform(-2.0, 3.0)));
        (file.offset, file.superposition, file.delay) =
            (drawn.offset, drawn.superposition, drawn.delay);
        if seed % 5 == 4 {
            // one play short: the general step
            file.hysteresis.thresholds.pop();
            file.hysteresis.weights.pop();
        }
        let p = file.parameters();
        let settings = if seed % 2 == 0 {
            CompensatorSettings::unlimited()
        } else {
            CompensatorSettings::with_limits(-700.0 * w, 700.0 * w)
        };
        let (mut b, mut b32) = (
            Free::<f64>::new(&p.validate().unwrap(), settings).unwrap(),
            Free::<f32>::new(&p.validate().unwrap(), settings).unwrap(),
        );
        let (inline, inline32) = (
            Placed::<f64>::new(&p.validate().unwrap(), settings).unwrap(),
            Placed::<f32>::new(&p.validate().unwrap(), settings).unwrap(),
        );
        let mut each: Vec<_> = simd::Kernels::all()
            .map(|k| (k, b.clone(), b32.clone(), inline.clone(), inline32.clone()))
            .collect();
        let mut signal: Vec<f64> = targets(&mut Rng::new(seed), 1, 400, 1500.0 * w)
            .into_iter()
            .map(|row| row[0])
            .collect();
        signal.extend([1e30, -1e38, 3e38, 0.0, -0.0, f64::NAN, 5.0]);
        for t in signal {
            let expected = b.compensate_portable(t);
            let expected32 = b32.compensate_portable(t as f32);
            let bits =
                |u: mfcbeam::realtime::Compensated<f64>| (u.u.to_bits(), u.saturated, u.fault);
            let bits32 =
                |u: mfcbeam::realtime::Compensated<f32>| (u.u.to_bits(), u.saturated, u.fault);
            for (k, c, c32, ci, ci32) in &mut each {
                let at = format!("seed {seed}, {k:?}, target {t}");
                assert_eq!(bits(c.compensate_using(*k, t)), bits(expected), "{at}");
                assert_eq!(bits(ci.compensate_using(*k, t)), bits(expected), "{at}");
                let t32 = t as f32;
                assert_eq!(
                    bits32(c32.compensate_using(*k, t32)),
                    bits32(expected32),
                    "{at}"
                );
                assert_eq!(
                    bits32(ci32.compensate_using(*k, t32)),
                    bits32(expected32),
                    "{at}"
                );
            }
        }
    }
}

/// Every sample's voltage, whether it was clipped, whether it was a fault.
type Outputs<T> = Vec<(T, bool, bool)>;

/// `c` run over `signal` on the kernels `k` in the pieces between the
/// indices `cuts` (one `compensate_into` each): every sample's voltage and
/// flags, and the pieces' counts of clipped samples and faults summed.
fn run_in_pieces<T: Real, S: mfcbeam::realtime::Storage>(
    c: &mut Compensator<T, S>,
    k: simd::Kernels,
    signal: &[T],
    cuts: &[usize],
) -> (Outputs<T>, (usize, usize)) {
    let n = signal.len();
    let (mut u, mut saturated, mut fault) = (vec![T::ZERO; n], vec![false; n], vec![false; n]);
    let mut total = (0, 0);
    for w in cuts.windows(2) {
        let r = w[0]..w[1];
        let (clipped, faults) = c
            .compensate_into_using(
                k,
                &signal[r.clone()],
                &mut u[r.clone()],
                &mut saturated[r.clone()],
                &mut fault[r],
            )
            .unwrap();
        total = (total.0 + clipped, total.1 + faults);
    }
    let out = u.into_iter().zip(saturated).zip(fault);
    (out.map(|((u, s), f)| (u, s, f)).collect(), total)
}

/// A run (`compensate_into`: one loop in the kernels' function, the creep's
/// output carried from sample to sample in a register) gives the bits of
/// one portable step per sample, on every kernel set: the paper's layout
/// (inline and on the heap) and random ones, with an offset, `S`, a dead
/// time and, in some, `G` (the samples a run sends down the general path),
/// limited and unlimited, with non-finite and huge targets; in runs of
/// random lengths, so that a stream continues across calls.
#[test]
fn a_run_gives_the_bits_of_its_steps_on_every_kernel_set() {
    use mfcbeam::operators::model::{DynamicsData, LowPassData, ResonanceData};
    let mut rng = Rng::new(43);
    for seed in 0..48u64 {
        let mut file = if seed % 3 == 0 {
            nominal_model_file()
        } else {
            random_model(&mut rng, 12, ModelShape::Any)
        };
        if seed % 4 == 1 {
            let nyquist = 0.5 / file.sample_time;
            file.dynamics = Some(DynamicsData {
                low_pass: Some(LowPassData {
                    frequency: 0.2 * nyquist,
                }),
                resonance: Some(ResonanceData {
                    frequency: 0.1 * nyquist,
                    damping: 0.2,
                }),
                delay_fraction: None,
                state: None,
            });
        }
        let p = file.parameters();
        let settings = if seed % 2 == 0 {
            CompensatorSettings::unlimited()
        } else {
            CompensatorSettings::with_limits(-400.0, 400.0)
        };
        let mut signal: Vec<f64> = targets(&mut Rng::new(seed), 1, 1500, 700.0)
            .into_iter()
            .map(|row| row[0])
            .collect();
        signal.extend([1e30, -1e38, 3e38, 0.0, -0.0, f64::NAN, 5.0, 300.0]);
        let signal32: Vec<f32> = signal.iter().map(|&t| t as f32).collect();

        // one portable step per sample: the reference
        let mut reference = Free::<f64>::new(&p.validate().unwrap(), settings).unwrap();
        let mut reference32 = Free::<f32>::new(&p.validate().unwrap(), settings).unwrap();
        let expected: Vec<_> = signal
            .iter()
            .map(|&t| {
                let o = reference.compensate_portable(t);
                (o.u.to_bits(), o.saturated, o.fault)
            })
            .collect();
        let expected32: Vec<_> = signal32
            .iter()
            .map(|&t| {
                let o = reference32.compensate_portable(t);
                (o.u.to_bits(), o.saturated, o.fault)
            })
            .collect();
        fn counts<B>(e: &[(B, bool, bool)]) -> (usize, usize) {
            let clipped = e.iter().filter(|x| x.1).count();
            (clipped, e.iter().filter(|x| x.2).count())
        }
        assert!(
            seed % 2 == 0 || counts(&expected).0 > 0,
            "seed {seed}: the limits clip no sample"
        );
        let cuts: Vec<usize> = {
            let mut cut_rng = Rng::new(1000 + seed);
            let mut at = vec![0];
            while *at.last().unwrap() < signal.len() {
                let next = at.last().unwrap() + cut_rng.int(0, 300);
                at.push(next.min(signal.len()));
            }
            at
        };
        for k in simd::Kernels::all() {
            let at = |what: &str| format!("seed {seed}, {k:?}, {what}");
            let bits = |out: Outputs<f64>| -> Vec<_> {
                out.into_iter()
                    .map(|(u, s, f)| (u.to_bits(), s, f))
                    .collect()
            };
            let mut free = Free::<f64>::new(&p.validate().unwrap(), settings).unwrap();
            let (out, total) = run_in_pieces(&mut free, k, &signal, &cuts);
            assert_eq!(bits(out), expected, "{}", at("heap"));
            assert_eq!(total, counts(&expected), "{}", at("heap, counts"));
            if let Ok(mut placed) = Placed::<f64>::new(&p.validate().unwrap(), settings) {
                let (out, total) = run_in_pieces(&mut placed, k, &signal, &cuts);
                assert_eq!(bits(out), expected, "{}", at("inline"));
                assert_eq!(total, counts(&expected), "{}", at("inline, counts"));
            }
            let mut free32 = Free::<f32>::new(&p.validate().unwrap(), settings).unwrap();
            let (out, total) = run_in_pieces(&mut free32, k, &signal32, &cuts);
            let out: Vec<_> = out
                .into_iter()
                .map(|(u, s, f)| (u.to_bits(), s, f))
                .collect();
            assert_eq!(out, expected32, "{}", at("f32"));
            assert_eq!(total, counts(&expected32), "{}", at("f32, counts"));
        }
    }
}

/// The same wherever the compensator lies: an inline one placed at every
/// offset of a page (in a page-aligned buffer, so that each of its arrays
/// straddles the page boundary at every place it can), where the kernels
/// move a register's worth of the plays' states that would straddle the
/// page one value at a time and the creep state is placed off the
/// boundary; and moved halfway, as a copy of C storage moves it, to the
/// mirrored offset of another page, where the creep state is placed again.
#[test]
fn every_kernel_set_gives_the_portable_bits_wherever_the_state_lies() {
    fn sweep<T: Real>() {
        // the nominal model's room only (no `S`, no dead time)
        type Nominal<T> = Compensator<T, mfcbeam::realtime::nominal::Capacity>;
        let settings = CompensatorSettings::with_limits(-700.0, 700.0);
        let proto = Nominal::<T>::new(
            &mfcbeam::realtime::nominal::PARAMETERS.validate().unwrap(),
            settings,
        )
        .unwrap();
        let signal: Vec<T> = targets(&mut Rng::new(3), 1, 48, 900.0)
            .into_iter()
            .map(|row| T::from_f64(row[0]))
            .collect();
        let mut reference = proto.clone();
        let expected: Vec<_> = signal
            .iter()
            .map(|&t| reference.compensate_portable(t))
            .collect();
        let size = std::mem::size_of::<Nominal<T>>();
        let layout = std::alloc::Layout::from_size_align(size + 4096, 4096).unwrap();
        // SAFETY: a non-zero size; freed below with the same layout.
        let (first, second) = unsafe { (std::alloc::alloc(layout), std::alloc::alloc(layout)) };
        assert!(!first.is_null() && !second.is_null());
        let mut placed = 0;
        for k in simd::Kernels::all() {
            for offset in (0..4096).step_by(std::mem::align_of::<Nominal<T>>()) {
                let mirrored = (4096 - offset) % 4096;
                // SAFETY: both offsets + size ≤ the buffers' size, aligned
                // for the type; the value is written before use, moved by
                // a copy (the first place not used again) and dropped after.
                unsafe {
                    let mut at = first.add(offset).cast::<Nominal<T>>();
                    at.write(proto.clone());
                    for (i, (&t, e)) in signal.iter().zip(&expected).enumerate() {
                        if i == signal.len() / 2 {
                            let to = second.add(mirrored).cast::<Nominal<T>>();
                            std::ptr::copy_nonoverlapping(at, to, 1);
                            at = to;
                        }
                        let u = (*at).compensate_using(k, t);
                        assert_eq!(
                            (u.u.to_f64().to_bits(), u.saturated, u.fault),
                            (e.u.to_f64().to_bits(), e.saturated, e.fault),
                            "{k:?}, offset {offset}, sample {i}"
                        );
                    }
                    assert!(*at == reference, "{k:?}, offset {offset}");
                    std::ptr::drop_in_place(at);
                }
                placed += 1;
            }
        }
        // SAFETY: allocated above with this layout.
        unsafe {
            std::alloc::dealloc(first, layout);
            std::alloc::dealloc(second, layout);
        }
        assert!(placed >= 512);
    }
    sweep::<f64>();
    sweep::<f32>();
}

/// The choice bites: where the CPU has AVX2 (or AVX-512) the explicit
/// kernels run (the compensator's `H⁻¹` and creep pass in `f64` and `f32`,
/// the bank's blocks in `f64` and `f32`), the portable entry points never
/// run them, and without AVX2 nothing does. (The calls are counted per
/// thread, with debug assertions.)
#[test]
fn the_vector_kernels_run_exactly_where_the_cpu_has_them() {
    if !cfg!(debug_assertions) {
        return; // not counted
    }
    let avx2 = simd::Kernels::detect().is_avx2();
    eprintln!("AVX2 on this CPU: {avx2}");
    let calls = simd::simd_kernel_calls;
    let settings = CompensatorSettings::default();
    let p = mfcbeam::realtime::nominal::PARAMETERS;

    let mut c = Single::<f64>::new(&p.validate().unwrap(), settings).unwrap();
    let before = calls();
    c.compensate_portable(300.0);
    assert_eq!(calls(), before, "the portable f64 step ran AVX2 kernels");
    c.compensate(350.0);
    // H⁻¹ and the creep pass
    assert_eq!(calls() - before, if avx2 { 2 } else { 0 });

    // f32 too: 8-lane H⁻¹ and creep pass
    let mut c32 = Single::<f32>::new(&p.validate().unwrap(), settings).unwrap();
    let before = calls();
    c32.compensate_portable(300.0);
    assert_eq!(calls(), before, "the portable f32 step ran AVX2 kernels");
    c32.compensate(350.0);
    assert_eq!(calls() - before, if avx2 { 2 } else { 0 });

    for channels in [4, 8] {
        let mut b64 = CompensatorBank::<f64>::uniform(&p, channels, settings).unwrap();
        let mut b32 = CompensatorBank::<f32>::uniform(&p, channels, settings).unwrap();
        let mut out64 = vec![Default::default(); channels];
        let mut out32 = vec![Default::default(); channels];
        let before = calls();
        b64.compensate_portable(&vec![300.0; channels], &mut out64)
            .unwrap();
        b32.compensate_portable(&vec![300.0; channels], &mut out32)
            .unwrap();
        assert_eq!(calls(), before, "the portable bank ran AVX2 kernels");
        b64.compensate(&vec![350.0; channels], &mut out64).unwrap();
        let after64 = calls();
        assert_eq!(after64 > before, avx2, "f64 bank, {channels} channels");
        b32.compensate(&vec![350.0; channels], &mut out32).unwrap();
        assert_eq!(calls() > after64, avx2, "f32 bank, {channels} channels");
    }
}

#[test]
fn bad_banks_and_slices_are_refused_with_the_field_named() {
    let mut rng = Rng::new(3);
    let files = models(&mut rng, 2, false);
    let p: Vec<_> = files.iter().map(ModelFile::parameters).collect();
    assert_eq!(
        CompensatorBank::<f64>::new(&[], CompensatorSettings::with_limits(-1.0, 1.0)).unwrap_err(),
        ParameterError::Empty {
            field: "bank.channels"
        }
    );
    assert!(matches!(
        CompensatorBank::<f64>::uniform(&p[0], 4, CompensatorSettings::with_limits(1.0, -1.0)),
        Err(ParameterError::InvalidLimits { .. })
    ));
    // a channel of another order
    let mut other = files[1].clone();
    other
        .hysteresis
        .thresholds
        .push(other.hysteresis.thresholds.last().unwrap() + 10.0);
    other.hysteresis.weights.push(0.01);
    let mixed = [p[0], other.parameters()];
    let e = CompensatorBank::<f64>::new(&mixed, CompensatorSettings::with_limits(-1.0, 1.0))
        .unwrap_err();
    assert_eq!(
        e,
        ParameterError::ChannelMismatch {
            field: "hysteresis.thresholds",
            channel: 1
        }
    );
    assert!(e
        .to_string()
        .starts_with("models[1].hysteresis.thresholds: "));
    // an inadmissible channel is named by its own check
    let mut bad = files[1].clone();
    bad.hysteresis.weights[0] = -1.0;
    let bad_pair = [p[0], bad.parameters()];
    assert!(
        CompensatorBank::<f64>::new(&bad_pair, CompensatorSettings::with_limits(-1.0, 1.0))
            .is_err()
    );

    let mut bank =
        CompensatorBank::<f64>::uniform(&p[0], 3, CompensatorSettings::with_limits(-1.0, 1.0))
            .unwrap();
    let mut out = vec![Default::default(); 3];
    assert_eq!(
        bank.compensate(&[0.0; 2], &mut out).unwrap_err(),
        ParameterError::LengthMismatch {
            field: "bank.targets",
            expected: 3,
            found: 2
        }
    );
    assert_eq!(
        bank.compensate(&[0.0; 3], &mut out[..1]).unwrap_err(),
        ParameterError::LengthMismatch {
            field: "bank.out",
            expected: 3,
            found: 1
        }
    );
    // nothing moved: the next good step equals a fresh bank's
    let mut fresh =
        CompensatorBank::<f64>::uniform(&p[0], 3, CompensatorSettings::with_limits(-1.0, 1.0))
            .unwrap();
    let mut out2 = out.clone();
    bank.compensate(&[0.5; 3], &mut out).unwrap();
    fresh.compensate(&[0.5; 3], &mut out2).unwrap();
    assert_eq!(out, out2);
}

/// A bank stepped with its blocks split over threads (`Par::Rayon`) gives
/// the bits of the same bank on one thread, whatever the split (more parts
/// than blocks, a last block partly filled, per-channel models with
/// saturation and faults), over many steps, inside a pool of its own and
/// from outside any pool.
#[test]
fn a_bank_on_threads_gives_the_bits_of_one_thread() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap();
    let pars = [
        Par::Seq,
        Par::rayon(1),
        Par::rayon(2),
        Par::rayon(3),
        Par::rayon(7),
    ];
    for (seed, channels) in [(1u64, 5usize), (2, 16), (3, 37), (4, 130)] {
        let mut rng = Rng::new(seed);
        // the paper's order (its own compiled step) in every other
        let files = models(&mut rng, channels, seed % 2 == 0);
        let params: Vec<_> = files.iter().map(ModelFile::parameters).collect();
        let limit = rng.uniform(100.0, 600.0);
        let settings = CompensatorSettings::with_limits(-limit, limit);
        let mut one = CompensatorBank::<f64>::new(&params, settings).unwrap();
        let mut one32 = CompensatorBank::<f32>::new(&params, settings).unwrap();
        let mut split: Vec<_> = pars
            .iter()
            .map(|&par| (par, one.clone(), one32.clone()))
            .collect();
        let mut out = vec![Default::default(); channels];
        let mut out32 = vec![Default::default(); channels];
        let mut out_split = out.clone();
        let mut out_split32 = out32.clone();
        for (k, row) in targets(&mut rng, channels, 300, limit)
            .into_iter()
            .enumerate()
        {
            let row32: Vec<f32> = row.iter().map(|&t| t as f32).collect();
            one.compensate(&row, &mut out).unwrap();
            one32.compensate(&row32, &mut out32).unwrap();
            for (par, bank, bank32) in &mut split {
                let mut step = || {
                    bank.compensate_on(*par, &row, &mut out_split).unwrap();
                    bank32
                        .compensate_on(*par, &row32, &mut out_split32)
                        .unwrap();
                };
                if k % 2 == 0 {
                    pool.install(step);
                } else {
                    step();
                }
                assert_eq!(out_split, out, "{par:?}, {channels} channels");
                assert_eq!(out_split32, out32, "{par:?}, {channels} channels");
            }
        }
        for (par, bank, bank32) in &split {
            assert_eq!(*bank, one, "{par:?}");
            assert_eq!(*bank32, one32, "{par:?}");
        }
    }
}

/// The caller's spawn hook makes the threads the bank's parts run on
/// (where a real-time caller pins them and sets their priority): a step
/// in that pool runs its parts on those threads and nowhere else.
#[test]
fn a_split_step_runs_on_the_threads_of_the_callers_spawn_hook() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    let spawned = Arc::new(AtomicUsize::new(0));
    let counted = Arc::clone(&spawned);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .spawn_handler(move |thread| {
            counted.fetch_add(1, Ordering::SeqCst);
            std::thread::Builder::new()
                .name(format!("pinned-{}", thread.index()))
                .spawn(move || thread.run())?;
            Ok(())
        })
        .build()
        .unwrap();
    assert_eq!(spawned.load(Ordering::SeqCst), 2);
    let p = mfcbeam::realtime::nominal::PARAMETERS;
    let channels = 8 * 64;
    let mut bank =
        CompensatorBank::<f64>::uniform(&p, channels, CompensatorSettings::default()).unwrap();
    let mut alone = bank.clone();
    let targets: Vec<f64> = (0..channels).map(|c| 2.0 * c as f64).collect();
    let (mut out, mut out_alone) = (
        vec![Default::default(); channels],
        vec![Default::default(); channels],
    );
    let names = pool.install(|| {
        bank.compensate_on(Par::rayon(2), &targets, &mut out)
            .unwrap();
        std::thread::current().name().map(str::to_owned)
    });
    alone.compensate(&targets, &mut out_alone).unwrap();
    assert_eq!(out, out_alone);
    assert!(names.is_some_and(|n| n.starts_with("pinned-")));
    // no thread was made for the step
    assert_eq!(spawned.load(Ordering::SeqCst), 2);
}

/// Channels whose models have linear dynamics run on their own compensator
/// inside the bank: the bits of a single compensator of that model, the
/// preview with the resonance's lag, on one thread and on three, and a
/// reset back to the virgin state.
#[test]
fn channels_with_dynamics_give_the_bits_of_their_own_compensator() {
    let mut rng = Rng::new(11);
    let mut files = models(&mut rng, 19, false);
    for (i, f) in files.iter_mut().enumerate() {
        if i % 3 == 1 {
            f.dynamics = Some(resonance(f, Some(0.2)));
        }
    }
    let params: Vec<_> = files.iter().map(ModelFile::parameters).collect();
    let settings = CompensatorSettings::with_limits(-400.0, 400.0);
    let mut bank = CompensatorBank::<f64>::new(&params, settings).unwrap();
    let mut split = bank.clone();
    let mut single: Vec<_> = params
        .iter()
        .map(|p| {
            Compensator::<f64, Inline<12, 72, 9, 4>>::new(&p.validate().unwrap(), settings).unwrap()
        })
        .collect();
    for (c, d) in bank.delays().iter().enumerate() {
        assert_eq!(*d, files[c].delay.unwrap_or(0) + usize::from(c % 3 == 1));
    }
    let (mut out, mut out_split) = (vec![Default::default(); 19], vec![Default::default(); 19]);
    for (step, row) in targets(&mut rng, 19, 200, 400.0).into_iter().enumerate() {
        bank.compensate(&row, &mut out).unwrap();
        split
            .compensate_on(Par::rayon(3), &row, &mut out_split)
            .unwrap();
        assert_eq!(out, out_split);
        for (c, comp) in single.iter_mut().enumerate() {
            let expected = comp.compensate(row[c]);
            assert_eq!(out[c], expected, "channel {c}, step {step}");
        }
        if step == 100 {
            bank.reset();
            split.reset();
            single.iter_mut().for_each(|c| c.reset());
        }
    }
}

/// `compensate_frames` gives the bits of one `compensate` per frame, in
/// order, and leaves the same state: one model or one per channel (some
/// with `S`, some with dynamics), `f32` and `f64`, on every kernel set,
/// with runs of one block and one frame, of two blocks and three frames,
/// and the default tiling, over
/// calls of 0 to 31 frames (odd counts too, so that a call starts on
/// either copy of the plays), through saturation and non-finite targets.
#[test]
fn frames_give_the_bits_of_one_step_per_frame() {
    use mfcbeam::internals::FrameTiling;
    use mfcbeam::suite::conformance::random_superposition;
    fn check<T: Real>(seed: u64, channels: usize, shared: bool) {
        let mut rng = Rng::new(seed);
        let mut files = models(
            &mut rng,
            if shared { 1 } else { channels },
            seed.is_multiple_of(3),
        );
        if !shared {
            for (c, f) in files.iter_mut().enumerate() {
                if c % 5 == 2 {
                    f.superposition = Some(random_superposition(&mut rng, 300.0));
                }
                if c % 7 == 3 {
                    f.dynamics = Some(resonance(f, None));
                }
            }
        }
        let params: Vec<_> = files.iter().map(ModelFile::parameters).collect();
        let limit = rng.uniform(100.0, 600.0);
        let settings = CompensatorSettings::with_limits(-limit, limit);
        let mut stepped = if shared {
            CompensatorBank::<T>::uniform(&params[0], channels, settings).unwrap()
        } else {
            CompensatorBank::<T>::new(&params, settings).unwrap()
        };
        // a block of the paper's model is 87 rows of 64 bytes
        // runs of one frame, of three, and of the default length
        let tilings = [
            FrameTiling {
                tile_bytes: 1,
                run_frames: 1,
                prefetch: false,
            },
            FrameTiling {
                tile_bytes: 2 * 87 * 64,
                run_frames: 3,
                prefetch: true,
            },
            FrameTiling::default(),
        ];
        let mut framed: Vec<_> = simd::Kernels::all()
            .flat_map(|k| tilings.map(|t| (k, t)))
            .map(|kt| (kt, stepped.clone()))
            .collect();
        let rows: Vec<Vec<T>> = targets(&mut rng, channels, 300, limit)
            .iter()
            .map(|row| row.iter().map(|&t| T::from_f64(t)).collect())
            .collect();
        let mut expected = vec![Default::default(); channels];
        let mut got = Vec::new();
        let mut rows = rows.as_slice();
        let (mut saturated, mut faults) = (0, 0);
        for frames in [0usize, 1, 2, 5, 31, 7, 16].into_iter().cycle() {
            if rows.is_empty() {
                break;
            }
            let (call, rest) = rows.split_at(frames.min(rows.len()));
            rows = rest;
            let flat: Vec<T> = call.iter().flatten().copied().collect();
            let mut want = Vec::new();
            for row in call {
                stepped.compensate(row, &mut expected).unwrap();
                want.extend_from_slice(&expected);
                saturated += expected.iter().filter(|c| c.saturated).count();
                faults += expected.iter().filter(|c| c.fault).count();
            }
            for ((k, tile), bank) in &mut framed {
                got.clear();
                got.resize(flat.len(), Default::default());
                bank.compensate_frames_using(*k, *tile, &flat, &mut got)
                    .unwrap();
                assert_eq!(
                    got,
                    want,
                    "seed {seed}, {channels} channels, {k:?}, {tile:?}, {frames} frames, {}",
                    T::NAME
                );
                assert_eq!(*bank, stepped, "seed {seed}, {k:?}, {tile:?}: the state");
            }
        }
        assert!(
            saturated > 0 && faults > 0,
            "seed {seed}: {saturated} saturated, {faults} faults"
        );
        // the default call is one of those checked
        let mut bank = framed[0].1.clone();
        let flat = vec![T::from_f64(0.25 * limit); 3 * channels];
        let mut got = vec![Default::default(); flat.len()];
        bank.compensate_frames(&flat, &mut got).unwrap();
        for f in 0..3 {
            stepped
                .compensate(&flat[f * channels..][..channels], &mut expected)
                .unwrap();
            assert_eq!(got[f * channels..][..channels], expected[..]);
        }
    }
    for seed in 0..6 {
        for channels in [1, 3, 8, 13, 17, 40, 70] {
            check::<f64>(seed, channels, seed % 2 == 0);
            check::<f32>(seed, channels, seed % 2 == 1);
        }
    }
}

/// A call of frames that are not whole, or whose outputs do not match its
/// targets, is refused with the field named, and the bank is unchanged.
#[test]
fn frames_that_are_not_whole_are_refused() {
    let p = mfcbeam::realtime::nominal::PARAMETERS;
    let settings = CompensatorSettings::with_limits(-400.0, 400.0);
    let mut bank = CompensatorBank::<f64>::uniform(&p, 3, settings).unwrap();
    let fresh = bank.clone();
    let mut out = vec![Default::default(); 7];
    assert_eq!(
        bank.compensate_frames(&[1.0; 7], &mut out).unwrap_err(),
        ParameterError::LengthMismatch {
            field: "bank.targets",
            expected: 9,
            found: 7
        }
    );
    assert_eq!(
        bank.compensate_frames(&[1.0; 6], &mut out).unwrap_err(),
        ParameterError::LengthMismatch {
            field: "bank.out",
            expected: 6,
            found: 7
        }
    );
    assert_eq!(bank, fresh);
    // no frames: nothing to do
    bank.compensate_frames(&[], &mut []).unwrap();
    assert_eq!(bank, fresh);
}
