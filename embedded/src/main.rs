//! The paper's Fig. 10 staircase through `W⁻¹` and then `W` on a Cortex-M4
//! (QEMU `mps2-an386`), in `f32` and in `f64`, with the paper-sized
//! `Compensator` and `Model` of `mfcbeam::realtime` in `nominal::Capacity`,
//! and in `f32` for an asymmetric actuator with dead time: the nominal
//! `H + C` followed by a superposition operator `S` and 2 samples of delay
//! (`Inline<12, 60, 5, 2>`; the compensator is given the target 2 samples
//! ahead, and the identity is checked from sample 2 on), and in `f32` for
//! a stage with linear dynamics after `H + C`: a 300 Hz resonance with
//! damping 0.05 and a delay of 0.3 samples (the resonance's one sample of
//! lag is previewed as the dead time is).
//!
//! Prints, per run, the worst identity error `max|W[W⁻¹[y]] − y|`
//! against its rounding bound (`RoundingBounds::identity`), and the cost of
//! one compensator step from the cycle counter, then exits through
//! semihosting: 0 when every identity error is within its bound, 1 otherwise.
//!
//! The cycle counter is the DWT's `CYCCNT` where the emulator provides it
//! (QEMU 7 does not: it reads as 0); otherwise SysTick on the core clock.
//! Under emulation neither is the hardware's cycle count: QEMU models no
//! pipeline, so with `-icount shift=0` (one instruction = 1 ns of virtual
//! time) SysTick at the 25 MHz core clock reports executed instructions / 40.

#![no_std]
#![no_main]

use core::fmt::Write;
use core::panic::PanicInfo;

use cortex_m::peripheral::{syst::SystClkSource, DWT, SYST};
use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::{debug, hio};
use mfcbeam::realtime::{
    nominal, Compensator, CompensatorSettings, DynamicsParameters, Inline, Model, ModelParameters,
    Real, Resonance, RoundingBounds, Storage, SuperpositionParameters,
};

/// The asymmetric actuator's `S`: slopes 0.75 and 1.0 below, 1 in the
/// middle, 0.8 and 0.65 above; and a dead time of 2 samples after it.
const ASYMMETRIC: ModelParameters<'static> = ModelParameters {
    superposition: Some(SuperpositionParameters {
        thresholds: &[-500.0, -200.0, 0.0, 150.0, 400.0],
        weights: &[0.25, -0.25, 1.0, -0.2, -0.15],
    }),
    delay: 2,
    ..nominal::PARAMETERS
};

/// A stage's resonance and a fraction of a sample of delay after the
/// nominal `H + C`.
const RESONANT: ModelParameters<'static> = ModelParameters {
    dynamics: Some(DynamicsParameters {
        low_pass: None,
        resonance: Some(Resonance {
            frequency: 300.0,
            damping: 0.05,
        }),
        delay_fraction: 0.3,
    }),
    ..nominal::PARAMETERS
};

/// MPS2's core clock (the SysTick reference with the core clock source).
const CORE_CLOCK_HZ: u32 = 25_000_000;

/// Fig. 10's target: the staircase 0 → 500 → −500 → 0 V in steps of 125 V,
/// each a 0.2 s raised-cosine rise and a 1.8 s plateau, at 5 kHz.
struct Staircase;

impl Staircase {
    const AMPLITUDE: f64 = 500.0;
    const STEPS: usize = 4;
    const RISE: f64 = 0.2;
    const PLATEAU: f64 = 1.8;

    fn level(k: usize) -> f64 {
        let h = Self::AMPLITUDE / Self::STEPS as f64;
        let q = Self::STEPS;
        let k = k + 1;
        if k <= q {
            k as f64 * h
        } else if k <= 3 * q {
            Self::AMPLITUDE - (k - q) as f64 * h
        } else {
            -Self::AMPLITUDE + (k - 3 * q) as f64 * h
        }
    }

    fn samples() -> usize {
        let duration = (4 * Self::STEPS) as f64 * (Self::RISE + Self::PLATEAU);
        libm::round(duration / nominal::SAMPLE_TIME) as usize + 1
    }

    fn value(t: f64) -> f64 {
        let seg = Self::RISE + Self::PLATEAU;
        if t <= 0.0 {
            return 0.0;
        }
        let k = (libm::floor(t / seg) as usize).min(4 * Self::STEPS - 1);
        let from = if k == 0 { 0.0 } else { Self::level(k - 1) };
        let to = Self::level(k);
        let tau = t - k as f64 * seg;
        if tau >= Self::RISE {
            to
        } else {
            let s = tau / Self::RISE;
            from + (to - from) * 0.5 * (1.0 - libm::cos(core::f64::consts::PI * s))
        }
    }
}

/// The cycle counter: DWT CYCCNT if it runs, else SysTick (24 bits, down).
enum Counter {
    Dwt,
    SysTick,
}

impl Counter {
    fn now(&self) -> u32 {
        match self {
            Counter::Dwt => DWT::cycle_count(),
            Counter::SysTick => SYST::get_current(),
        }
    }

    fn elapsed(&self, start: u32, end: u32) -> u32 {
        match self {
            Counter::Dwt => end.wrapping_sub(start),
            Counter::SysTick => start.wrapping_sub(end) & 0x00ff_ffff,
        }
    }

    fn name(&self) -> &'static str {
        match self {
            Counter::Dwt => "DWT CYCCNT",
            Counter::SysTick => "SysTick (core clock)",
        }
    }
}

struct Outcome {
    identity: f64,
    bound: f64,
    samples: usize,
    saturated: usize,
    ticks_min: u32,
    ticks_max: u32,
    ticks_sum: u64,
}

fn run<T: Real, St: Storage>(counter: &Counter, p: &ModelParameters<'_>) -> Outcome {
    let p = p.validate().expect("valid model");
    let mut comp = Compensator::<T, St>::new(&p, CompensatorSettings::with_limits(-1000.0, 1000.0))
        .expect("valid model");
    let mut plant = Model::<T, St>::new(&p).expect("valid model");
    let mut o = Outcome {
        identity: 0.0,
        bound: 0.0,
        samples: Staircase::samples(),
        saturated: 0,
        ticks_min: u32::MAX,
        ticks_max: 0,
        ticks_sum: 0,
    };
    let (mut u_max, mut y_max) = (0.0f64, 0.0f64);
    // with a dead time d the target is previewed: the one wanted d samples on
    let d = comp.delay();
    for k in 0..o.samples {
        let y = T::from_f64(Staircase::value(k as f64 * nominal::SAMPLE_TIME));
        let ahead = T::from_f64(Staircase::value((k + d) as f64 * nominal::SAMPLE_TIME));
        let start = counter.now();
        let c = comp.compensate(ahead);
        let end = counter.now();
        let ticks = counter.elapsed(start, end);
        let w = plant.step(c.u);
        o.ticks_min = o.ticks_min.min(ticks);
        o.ticks_max = o.ticks_max.max(ticks);
        o.ticks_sum += u64::from(ticks);
        o.saturated += usize::from(c.saturated);
        if k >= d {
            o.identity = o.identity.max(libm::fabs((w - y).to_f64()));
        }
        u_max = u_max.max(libm::fabs(c.u.to_f64()));
        y_max = y_max.max(libm::fabs(y.to_f64()));
    }
    o.bound = RoundingBounds {
        parameters: *p,
        state_max: 0.0,
        eps: T::EPSILON.to_f64(),
    }
    .identity(u_max, y_max);
    o
}

#[entry]
fn main() -> ! {
    let mut out = hio::hstdout().ok();
    let mut cp = cortex_m::Peripherals::take().expect("first take");
    cp.DCB.enable_trace();
    cp.DWT.enable_cycle_counter();
    let a = DWT::cycle_count();
    cortex_m::asm::delay(1000);
    let counter = if DWT::cycle_count() != a {
        Counter::Dwt
    } else {
        cp.SYST.set_clock_source(SystClkSource::Core);
        cp.SYST.set_reload(0x00ff_ffff);
        cp.SYST.clear_current();
        cp.SYST.enable_counter();
        Counter::SysTick
    };

    let mut ok = true;
    if let Some(o) = out.as_mut() {
        let _ = writeln!(
            o,
            "mfcbeam on Cortex-M4: Fig. 10 staircase through W^-1 then W, Compensator ({} bytes f32, {} bytes f64)",
            core::mem::size_of::<Compensator<f32, nominal::Capacity>>(),
            core::mem::size_of::<Compensator<f64, nominal::Capacity>>()
        );
        let _ = writeln!(o, "counter: {} at {} Hz", counter.name(), CORE_CLOCK_HZ);
    }
    type Asymmetric = Inline<{ nominal::PLAYS }, { nominal::CREEP }, 5, 2>;
    let nominal = &nominal::PARAMETERS;
    for (name, o) in [
        ("f32", run::<f32, nominal::Capacity>(&counter, nominal)),
        ("f64", run::<f64, nominal::Capacity>(&counter, nominal)),
        (
            "f32 with S and dead time",
            run::<f32, Asymmetric>(&counter, &ASYMMETRIC),
        ),
        (
            "f32 with a resonance and a delay fraction",
            run::<f32, nominal::Capacity>(&counter, &RESONANT),
        ),
    ] {
        let pass = o.identity <= o.bound && o.saturated == 0;
        ok &= pass;
        if let Some(out) = out.as_mut() {
            let _ = writeln!(
                out,
                "{name}: {} samples, max|W[W^-1[y]] - y| = {:.3e} V (bound {:.3e} V), saturated {}, \
                 compensator step {}/{}/{} counter ticks (min/mean/max) -> {}",
                o.samples,
                o.identity,
                o.bound,
                o.saturated,
                o.ticks_min,
                o.ticks_sum / o.samples as u64,
                o.ticks_max,
                if pass { "PASS" } else { "FAIL" }
            );
        }
    }
    debug::exit(if ok {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    loop {
        cortex_m::asm::bkpt();
    }
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    if let Ok(mut o) = hio::hstdout() {
        let _ = writeln!(o, "hard fault: {frame:?}");
    }
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::bkpt();
    }
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    if let Ok(mut o) = hio::hstdout() {
        let _ = writeln!(o, "panic: {info}");
    }
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::bkpt();
    }
}
