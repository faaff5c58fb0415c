//! How many channel-steps per second the traffic of a bank's state allows
//! on one core: the memory side of the bank's bound.
//!
//! A bank step touches every row of every block's state once, each row one
//! cache line (`CompensatorBank`'s layout: `2 n + n_C m + 3` rows — the
//! two copies of the inverse plays, the creep states, the last voltage,
//! the creep's output and input): it reads the current copy of the plays,
//! writes the other, and reads and writes the rest. This pass does the
//! same to a buffer of the same size and shape with one add per lane and
//! nothing else, so that only the loads, the stores and the cache moving
//! the lines limit it. Where the state outgrows L1 (from about 64 `f64`
//! channels on a core with 48 KiB), a bank can step no faster than this,
//! however fast it computes.

use std::hint::black_box;
use std::time::Instant;

/// One cache line of a block's state.
#[repr(C, align(64))]
#[derive(Clone, Copy)]
struct Line([f64; 8]);

/// A pass over every block of `state` (`rows` lines each, the first `2 n`
/// the two copies of the plays): copy `half` read, the other written, the
/// rest read and written, each line by `add(line, c)`.
#[inline(always)]
fn pass_with(
    state: &mut [Line],
    rows: usize,
    n: usize,
    half: usize,
    add: impl Fn(&Line, &mut Line),
) {
    for block in state.chunks_exact_mut(rows) {
        let (plays, rest) = block.split_at_mut(2 * n);
        let (first, second) = plays.split_at_mut(n);
        let (read, write) = if half == 0 {
            (&*first, second)
        } else {
            (&*second, first)
        };
        for (w, r) in write.iter_mut().zip(read) {
            add(r, w);
        }
        for line in rest {
            let r = *line;
            add(&r, line);
        }
    }
}

/// Whole lines with AVX-512F: one load, one add, one store each (left to
/// the compiler, the loop over lines became gathers and scatters).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn pass_avx512(state: &mut [Line], rows: usize, n: usize, half: usize, c: f64) {
    use core::arch::x86_64::*;
    let c = _mm512_set1_pd(c);
    pass_with(state, rows, n, half, |r, w| {
        // SAFETY: a Line is 64 bytes, 64-byte aligned
        unsafe {
            _mm512_store_pd(
                w.0.as_mut_ptr(),
                _mm512_add_pd(_mm512_load_pd(r.0.as_ptr()), c),
            )
        }
    })
}

/// Whole lines with AVX2: two 32-byte halves each.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn pass_avx2(state: &mut [Line], rows: usize, n: usize, half: usize, c: f64) {
    use core::arch::x86_64::*;
    let c = _mm256_set1_pd(c);
    pass_with(state, rows, n, half, |r, w| {
        // SAFETY: a Line is 64 bytes, 64-byte aligned: two aligned halves
        unsafe {
            let (p, q) = (r.0.as_ptr(), w.0.as_mut_ptr());
            _mm256_store_pd(q, _mm256_add_pd(_mm256_load_pd(p), c));
            _mm256_store_pd(q.add(4), _mm256_add_pd(_mm256_load_pd(p.add(4)), c));
        }
    })
}

/// The widest loads and stores the CPU has (elsewhere the compiler's).
fn pass_widest(state: &mut [Line], rows: usize, n: usize, half: usize, c: f64) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F
            return unsafe { pass_avx512(state, rows, n, half, c) };
        }
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2
            return unsafe { pass_avx2(state, rows, n, half, c) };
        }
    }
    pass_with(state, rows, n, half, |r, w| {
        for (w, r) in w.0.iter_mut().zip(&r.0) {
            *w = *r + c;
        }
    })
}

/// The state's traffic bound for `channels` channels in blocks of `lanes`
/// lanes with `rows` state rows of which the first `2 n` are the plays'
/// two copies: M channel-steps per second (per lane: a partial block
/// counts whole), from the fastest of fifteen batches of about 2 ms of
/// passes (after 20 ms of warm-up). A bound where the cache's bandwidth
/// limits (the state in L2); where its latency does (in L3 or memory), a
/// bank that computes between its loads can give the prefetchers the time
/// a bare pass does not, and beat it.
pub fn bound(channels: usize, lanes: usize, rows: usize, n: usize) -> f64 {
    let blocks = channels.div_ceil(lanes);
    let mut state = vec![Line([1.0; 8]); blocks * rows];
    let passes = (4_000_000 / (blocks * rows).max(1)).clamp(4, 1_000_000);
    let c = black_box(1e-12);
    let mut half = 0;
    let mut batch = |state: &mut [Line]| {
        let t0 = Instant::now();
        for _ in 0..passes {
            pass_widest(black_box(&mut *state), rows, n, half, c);
            half ^= 1;
        }
        t0.elapsed().as_nanos() as f64 / passes as f64
    };
    let warm = Instant::now();
    while warm.elapsed().as_millis() < 20 {
        batch(&mut state);
    }
    let best = (0..15)
        .map(|_| batch(&mut state))
        .fold(f64::INFINITY, f64::min);
    black_box(&state);
    // per lane, as the arithmetic bound counts: a partial block's idle
    // lanes cost its traffic as well
    (blocks * lanes) as f64 / best * 1e3
}
