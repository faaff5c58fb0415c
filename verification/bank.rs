//! `CompensatorBank`: every channel gives the bits of a single
//! inline `Compensator` of its model (one shared model or one per channel,
//! `f32` and `f64`, through saturation, recovery and non-finite targets),
//! the run-time AVX2 path gives the bits of the portable one, and bad
//! parameters and slices are refused with the field named.

use mfcbeam::operators::bank::CompensatorBank;
use mfcbeam::operators::model::ModelFile;
use mfcbeam::realtime::{simd, Compensator, CompensatorSettings, Inline, ParameterError, Real};
use mfcbeam::suite::conformance::{random_model, ModelShape, Rng};

type Single<T> = Compensator<T, Inline<12, 72>>;

/// `count` models of one random shape: the first as drawn, the others with
/// weights scaled (which keeps (11) and (17)) and their own offsets.
fn models(rng: &mut Rng, count: usize) -> Vec<ModelFile> {
    let base = random_model(rng, 12, ModelShape::Virgin);
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

fn same_as_singles<T: Real>(seed: u64, channels: usize, shared: bool) {
    let mut rng = Rng::new(seed);
    let files = models(&mut rng, if shared { 1 } else { channels });
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
    let mut portable = bank.clone();
    let mut singles: Vec<Single<T>> = (0..channels)
        .map(|c| {
            Single::<T>::new(
                &params[if shared { 0 } else { c }],
                CompensatorSettings::with_limits(-limit, limit),
            )
            .unwrap()
        })
        .collect();
    let mut out = vec![Default::default(); channels];
    let mut out_portable = out.clone();
    let (mut saturated, mut faults) = (0, 0);
    for row in targets(&mut rng, channels, 1500, limit) {
        let row: Vec<T> = row.iter().map(|&t| T::from_f64(t)).collect();
        bank.compensate(&row, &mut out).unwrap();
        portable
            .compensate_portable(&row, &mut out_portable)
            .unwrap();
        for c in 0..channels {
            let single = singles[c].compensate(row[c]);
            assert_eq!(
                (out[c].u.to_f64().to_bits(), out[c].saturated, out[c].fault),
                (single.u.to_f64().to_bits(), single.saturated, single.fault),
                "seed {seed}, channel {c} of {channels}: bank {:?}, single {single:?}",
                out[c]
            );
            assert_eq!(
                out[c], out_portable[c],
                "seed {seed}: AVX2 and portable differ"
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
        for channels in [1, 3, 8, 13] {
            same_as_singles::<f64>(seed, channels, seed % 2 == 0);
            same_as_singles::<f32>(seed, channels, seed % 2 == 1);
        }
    }
}

#[test]
fn the_avx2_step_gives_the_portable_bits() {
    eprintln!("kernels on this CPU: {:?}", simd::Kernels::detect());
    let mut rng = Rng::new(7);
    for seed in 0..40u64 {
        let file = random_model(&mut rng, 12, ModelShape::Any);
        let p = file.parameters();
        let mut a =
            Single::<f64>::new(&p, CompensatorSettings::with_limits(-700.0, 700.0)).unwrap();
        let mut b = a.clone();
        let mut a32 =
            Single::<f32>::new(&p, CompensatorSettings::with_limits(-700.0, 700.0)).unwrap();
        let mut b32 = a32.clone();
        for row in targets(&mut Rng::new(seed), 1, 2000, 700.0) {
            let t = row[0];
            assert_eq!(a.compensate(t), b.compensate_portable(t), "seed {seed}");
            let t = t as f32;
            assert_eq!(a32.compensate(t), b32.compensate_portable(t), "seed {seed}");
        }
    }
}

/// The choice bites: where the CPU has AVX2 the AVX2 kernels run (the `f64`
/// compensator's `H⁻¹` and creep pass, the bank's lane blocks in `f64` and
/// `f32`), the portable entry points never run them, and without AVX2
/// nothing does. (The calls are counted per thread, with debug assertions.)
#[test]
fn the_avx2_kernels_run_exactly_where_the_cpu_has_avx2() {
    if !cfg!(debug_assertions) {
        return; // not counted
    }
    let avx2 = simd::Kernels::detect().is_avx2();
    eprintln!("AVX2 on this CPU: {avx2}");
    let calls = simd::avx2_kernel_calls;
    let settings = CompensatorSettings::default();
    let p = mfcbeam::realtime::nominal::PARAMETERS;

    let mut c = Single::<f64>::new(&p, settings).unwrap();
    let before = calls();
    c.compensate_portable(300.0);
    assert_eq!(calls(), before, "the portable f64 step ran AVX2 kernels");
    c.compensate(350.0);
    // H⁻¹ and the creep pass
    assert_eq!(calls() - before, if avx2 { 2 } else { 0 });

    // f32 single steps are vectorised by the compiler, no explicit kernels
    let mut c32 = Single::<f32>::new(&p, settings).unwrap();
    let before = calls();
    c32.compensate(300.0);
    assert_eq!(calls(), before);

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
    let files = models(&mut rng, 2);
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
