//! Where the creep state `χ` starts in its buffer, so that no register's
//! worth of it straddles a 4 KiB page.
//!
//! The creep pass (20) loads and stores every `χ_ij` once per sample, in
//! registers of 4 or 8 values along each eigenvalue's row of `n` values
//! (`χ[j * n + i]`, `i` the threshold). A load or store split across two
//! pages costs the CPU a second access, and one that also matches stack
//! slots the step has just written waits for them: a compensator whose `χ`
//! straddled a page stepped up to a fifth slower, with the same bits.
//!
//! So `χ`'s buffer holds [`SLACK`] values more than it needs, and `χ`
//! starts where the page boundary inside it (if any) falls between two
//! registers of every kernel: at a multiple of 8 values into a row, up to
//! the row's last block of 8 (`n − n mod 8`), or in the row's tail that
//! every kernel steps one value at a time (from `n − n mod 4` on). The
//! boundary at `p` values into a row moves back to `p − p mod 8` below
//! `n − n mod 8` and to `n − n mod 8` between it and `n − n mod 4`, so the
//! start moves by at most 7 values. Only the first boundary is placed: a
//! `χ` longer than a page (none in the paper's layout) may still straddle
//! the next ones, as slowly as before and with the same bits.
//!
//! An object that moves (a Rust move, a copy of C storage) carries its `χ`
//! to a new address: the step compares the buffer's address with the one
//! it placed `χ` for and places it again when they differ, once (a copy
//! of `χ` in that step). Only on x86-64 with `std`, where the vector
//! kernels run; elsewhere `χ` stays at its buffer's start.

/// Values a buffer for `χ` holds beyond `n · m`: the most the start moves.
pub const SLACK: usize = 7;

/// Bytes in the pages whose boundaries matter.
const PAGE: usize = 4096;

/// How many values into its row (of `n`) the first page boundary after
/// `at` falls, in `len` values of `size` bytes each from `at`; `None` if
/// it falls at or past the end, if there are no rows, or if the values
/// are not aligned to their size (never for a Rust `f32` or `f64`).
fn boundary_in_row(at: usize, size: usize, n: usize, len: usize) -> Option<usize> {
    let to_boundary = PAGE - at % PAGE;
    if n == 0 || !to_boundary.is_multiple_of(size) {
        return None;
    }
    let b = to_boundary / size;
    (b < len).then_some(b % n)
}

/// The last block of 8 and the start of the scalar tail of a row of `n`:
/// `(n − n mod 8, n − n mod 4)`.
fn row_blocks(n: usize) -> (usize, usize) {
    (n - n % 8, n - n % 4)
}

/// The index in a buffer at address `at` where `len` values of
/// `size` bytes each (`χ`, rows of `n`) start so that the first page
/// boundary after `at` cuts no register (see the module's note): `0..=7`.
#[cfg_attr(not(all(feature = "std", target_arch = "x86_64")), allow(dead_code))]
pub fn chi_start(at: usize, size: usize, n: usize, len: usize) -> usize {
    // `χ` starting at index `s` has the boundary `s` values earlier in
    // its row
    let Some(p) = boundary_in_row(at, size, n, len) else {
        return 0;
    };
    let (full8, full4) = row_blocks(n);
    let s = if p < full8 {
        p % 8
    } else if p < full4 {
        p - full8
    } else {
        0
    };
    // `s ≤ p`: the boundary stays in its row
    debug_assert!(s <= p);
    s
}

/// Whether a register of 8 or of 4 values, as the kernels load `χ`
/// (`len` values of `size` bytes from `at`, rows of `n`), straddles the
/// first page boundary after `at`: what [`chi_start`] avoids.
#[cfg_attr(not(all(feature = "std", target_arch = "x86_64")), allow(dead_code))]
pub fn cuts_a_register(at: usize, size: usize, n: usize, len: usize) -> bool {
    let Some(p) = boundary_in_row(at, size, n, len) else {
        return false;
    };
    let (full8, full4) = row_blocks(n);
    // the blocks of 8 (one kernel) and of 4 (the other, and the 8-lane
    // kernels' last half block) that hold values on both sides of `p`
    let in_eight = p < full8 && !p.is_multiple_of(8);
    let in_four = p < full4 && !p.is_multiple_of(4);
    let in_half = p > full8 && p < full4;
    in_eight || in_four || in_half
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every register a kernel loads from `χ` (rows of `n`, `m` rows):
    /// `(first, count)` for the 4-lane kernel's blocks and the 8-lane
    /// kernels' blocks of 8 and last half block, as the kernels walk them.
    fn registers(n: usize, m: usize) -> Vec<(usize, usize)> {
        let mut all = Vec::new();
        for j in 0..m {
            for i0 in (0..n - n % 4).step_by(4) {
                all.push((j * n + i0, 4));
            }
            for i0 in (0..n - n % 8).step_by(8) {
                all.push((j * n + i0, 8));
            }
            if n % 8 >= 4 {
                all.push((j * n + n - n % 8, 4));
            }
        }
        all
    }

    /// The start chosen leaves no register across the first page
    /// boundary, for every address a value can have in a page, `f32` and
    /// `f64`, rows of 1 to 20 and 1 to 6 rows; `χ` stays in its buffer
    /// (start ≤ [`SLACK`]); and [`cuts_a_register`] says exactly what the
    /// registers listed one by one say.
    #[test]
    fn the_start_leaves_every_register_in_one_page() {
        let mut moved = 0;
        for size in [4usize, 8] {
            for n in 1..=20 {
                for m in 1..=6 {
                    let len = n * m;
                    let regs = registers(n, m);
                    for at in (0..2 * PAGE).step_by(size) {
                        let cut_at = |start: usize| {
                            let first = at + start * size;
                            regs.iter().any(|&(i, k)| {
                                let a = first + i * size;
                                // the first boundary after the buffer's start
                                let boundary = (at / PAGE + 1) * PAGE;
                                a < boundary && a + k * size > boundary
                            })
                        };
                        let s = chi_start(at, size, n, len);
                        assert!(s <= SLACK, "size {size}, n {n}, m {m}, at {at}: {s}");
                        assert!(!cut_at(s), "size {size}, n {n}, m {m}, at {at}: start {s}");
                        assert!(
                            !cuts_a_register(at + s * size, size, n, len),
                            "size {size}, n {n}, m {m}, at {at}"
                        );
                        assert_eq!(
                            cuts_a_register(at, size, n, len),
                            cut_at(0),
                            "size {size}, n {n}, m {m}, at {at}"
                        );
                        moved += usize::from(s > 0);
                    }
                }
            }
        }
        // the rule does move some
        assert!(moved > 1000, "{moved}");
    }

    /// The paper's layout in `f64` (12 × 5): a boundary inside `χ` cuts a
    /// register unless it falls at a row's start or 8 values in (blocks
    /// of 0–7 and 8–11, of 0–3, 4–7 and 8–11), and a cut one is moved.
    #[test]
    fn the_papers_layout_moves_off_a_cut() {
        for at in (PAGE - 480..PAGE).step_by(8) {
            let cut = cuts_a_register(at, 8, 12, 60);
            let p = (PAGE - at) / 8 % 12;
            assert_eq!(cut, p != 0 && p != 8, "at {at}");
            let s = chi_start(at, 8, 12, 60);
            assert!(!cuts_a_register(at + 8 * s, 8, 12, 60), "at {at}");
        }
    }
}
