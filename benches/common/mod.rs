//! The input every operator bench uses.

/// A seeded random walk of `len` samples in [-600, 600] V with frequent
/// reversals, so that branch predictors see realistic play switching.
pub fn test_input(len: usize) -> Vec<f64> {
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut v = 0.0f64;
    (0..len)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let step = ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 40.0;
            v = (v + step).clamp(-600.0, 600.0);
            v
        })
        .collect()
}
