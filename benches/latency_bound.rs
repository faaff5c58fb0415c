//! The latency bound of one compensator step on the CPU at hand
//! (`docs/MATHEMATICS.md` §4.4), next to the measured step.
//!
//! The chain from one step's creep increment `Δ` to the next one's, for the
//! nominal model in 4-lane `f64` registers, is 14 additions or
//! subtractions, 4 min/max, 2 multiplications, 2 in-lane shuffles, 2
//! shuffles across the 128-bit halves, and `Δ` stored by one call and
//! loaded (broadcast) by the next. This bench measures each of those
//! latencies here, as dependent chains of the instruction (timed against a
//! chain of dependent integer additions, one cycle each on every x86-64
//! core), and prints the bound in cycles and nanoseconds, the CPU, and the
//! measured step on each kernel set (median of rounds of 100 000 steps).
//!
//! It also checks the kernel choice on the CPU that runs it: the set
//! [`Kernels::detect`] dispatches to must not be slower than the portable
//! one beyond the rounds' spread (exit code 1 if it is; `.ci/run` runs it).
//!
//! `cargo bench --bench latency_bound`

#[cfg(target_arch = "x86_64")]
fn main() {
    use std::arch::asm;
    use std::hint::black_box;
    use std::time::Instant;

    use mfcbeam::realtime::simd::{cpu_description, Kernels};
    use mfcbeam::realtime::{nominal, Compensator, CompensatorSettings};

    if !std::is_x86_feature_detected!("avx2") {
        eprintln!("the bound is stated for the AVX2 kernels; this CPU has no AVX2");
        return;
    }
    const N: u64 = 20_000_000;
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    // ns per dependent instruction of a chain of 4 N; the median of 7 runs
    let time = |f: &dyn Fn()| {
        median(
            (0..7)
                .map(|_| {
                    let t0 = Instant::now();
                    f();
                    t0.elapsed().as_nanos() as f64 / (4 * N) as f64
                })
                .collect(),
        )
    };
    let cycle = time(&|| {
        let mut x = 1u64;
        for _ in 0..N {
            // SAFETY: register arithmetic only.
            unsafe {
                asm!("add {0}, {0}", "add {0}, {0}", "add {0}, {0}", "add {0}, {0}", inout(reg) x)
            };
        }
        black_box(x);
    });
    macro_rules! chain {
        ($($op:literal),+) => {
            time(&|| {
                for _ in 0..N {
                    // SAFETY: AVX2 is present (tested above); registers only.
                    unsafe {
                        asm!(
                            "vxorpd ymm1, ymm1, ymm1",
                            $($op, $op, $op, $op,)+
                            out("ymm0") _, out("ymm1") _,
                        )
                    };
                }
            }) / cycle
        };
    }
    let add = chain!("vaddpd ymm0, ymm0, ymm1");
    let minmax = chain!("vminpd ymm0, ymm0, ymm1");
    let mul = chain!("vmulpd ymm0, ymm0, ymm1");
    let shuffle = chain!("vshufpd ymm0, ymm0, ymm0, 5");
    let cross = chain!("vpermpd ymm0, ymm0, 0x4e");
    // Δ written by one call, read and broadcast by the next
    let forward = time(&|| {
        let mut slot = [0.0f64; 4];
        for _ in 0..N {
            // SAFETY: the slot is a local array; AVX2 is present.
            unsafe {
                asm!(
                    "vmovsd qword ptr [{p}], xmm0",
                    "vbroadcastsd ymm0, qword ptr [{p}]",
                    "vmovsd qword ptr [{p}], xmm0",
                    "vbroadcastsd ymm0, qword ptr [{p}]",
                    "vmovsd qword ptr [{p}], xmm0",
                    "vbroadcastsd ymm0, qword ptr [{p}]",
                    "vmovsd qword ptr [{p}], xmm0",
                    "vbroadcastsd ymm0, qword ptr [{p}]",
                    p = in(reg) slot.as_mut_ptr(),
                    out("ymm0") _,
                )
            };
        }
        black_box(slot);
    }) / cycle;
    let bound = 14.0 * add + 4.0 * minmax + 2.0 * mul + 2.0 * shuffle + 2.0 * cross + forward;

    println!("CPU: {}", cpu_description());
    println!(
        "clock: {:.2} GHz (a dependent integer add per cycle)",
        1.0 / cycle
    );
    println!(
        "latencies (cycles): add {add:.1}, min/max {minmax:.1}, mul {mul:.1}, \
         in-lane shuffle {shuffle:.1}, cross-half shuffle {cross:.1}, \
         store to broadcast load {forward:.1}"
    );
    println!(
        "latency bound of one step (nominal model, 4-lane f64): {bound:.0} cycles = {:.1} ns",
        bound * cycle
    );

    // the measured step on each kernel set, rounds of 100 000 steps
    let model = mfcbeam::operators::nominal::nominal_model();
    let targets = {
        use mfcbeam::operators::traits::Operator;
        let input = common::test_input(4096);
        model.clone().run(&input)
    };
    let mut medians = Vec::new();
    for k in Kernels::all() {
        let mut c = Compensator::<f64, nominal::Capacity>::new(
            &nominal::PARAMETERS,
            CompensatorSettings::default(),
        )
        .unwrap();
        let mut i = 0usize;
        let rounds: Vec<f64> = (0..31)
            .map(|_| {
                let t0 = Instant::now();
                for _ in 0..100_000 {
                    i = (i + 1) & 4095;
                    black_box(c.compensate_using(k, black_box(targets[i])));
                }
                t0.elapsed().as_nanos() as f64 / 1e5
            })
            .collect();
        let mut sorted = rounds.clone();
        sorted.sort_by(f64::total_cmp);
        let spread = (sorted[sorted.len() * 9 / 10] - sorted[sorted.len() / 10]) / sorted[0];
        let step = median(rounds);
        println!(
            "measured step, {:>8} kernels: {step:.1} ns = {:.0} cycles ({:.2}x the bound)",
            k.name(),
            step / cycle,
            step / (bound * cycle)
        );
        medians.push((k, step, spread));
    }
    // the kernel choice on this CPU: the dispatched set against portable
    let (_, portable, spread) = medians[0];
    let chosen = Kernels::detect();
    let &(_, dispatched, spread_d) = medians.iter().find(|(k, ..)| *k == chosen).unwrap();
    let noise = spread.max(spread_d).max(0.02);
    let verdict = dispatched <= portable * (1.0 + noise);
    println!(
        "kernel choice: {} dispatched, {:.2}x the portable step (noise {:.1} %): {}",
        chosen.name(),
        dispatched / portable,
        100.0 * noise,
        if verdict { "not slower" } else { "SLOWER" }
    );
    if !verdict {
        std::process::exit(1);
    }
}

#[cfg(not(target_arch = "x86_64"))]
fn main() {
    eprintln!("the latency bound is measured with x86-64 instructions");
}

mod common;
