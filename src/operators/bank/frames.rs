//! A planned signal of many frames in one call
//! ([`CompensatorBank::compensate_frames`]): tiles of a few blocks, each
//! stepped through a run of frames before the next, so that a tile's state
//! stays in L1 from one frame to the next (each block is independent of
//! the others, so the order changes no bit).

use crate::realtime::checks::check_length;
use crate::realtime::compensator::Compensated;
use crate::realtime::error::ParameterError;
use crate::realtime::real::Real;
use crate::realtime::simd::block::{lanes, Row};
use crate::realtime::simd::Kernels;

use super::step::step_blocks;
use super::walk::Walk;
use super::CompensatorBank;

/// How [`CompensatorBank::compensate_frames`] walks its frames: runs of
/// `run_frames` frames (at least one), and in each, tiles of blocks of at
/// most `tile_bytes` of state (at least one block), each stepped through
/// every frame of the run before the next; with `prefetch`, the next
/// tile's targets and outputs are asked into L2 while a tile is stepped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameTiling {
    /// The most state a tile holds (at least one block).
    pub tile_bytes: usize,
    /// The frames of a run (at least one).
    pub run_frames: usize,
    /// Whether the next tile's targets and outputs are prefetched.
    pub prefetch: bool,
}

impl Default for FrameTiling {
    /// Tiles of half of a 48 KiB L1 of state (4 blocks of the paper's
    /// model in `f64` or `f32`), so that the frames' targets and outputs
    /// and the parameters stay in L1 beside it; runs of 16 frames; the
    /// next tile's prefetched. `benches/frame_tiling.rs` times the others
    /// on the CPU at hand. The prefetch matters beyond L2: a tile's slice
    /// of each frame is a page of its own there, and the hardware
    /// prefetcher does not run ahead of that many pages (without it, runs
    /// of 64 frames fell below a frame a call where measured).
    fn default() -> Self {
        FrameTiling {
            tile_bytes: 24 * 1024,
            run_frames: 16,
            prefetch: true,
        }
    }
}

/// Asks for the lines of `len` values from `at` to be brought into L2
/// (x86-64; nothing elsewhere): a tile's targets and outputs, while the
/// tile before is stepped. A tile's slice of each frame lies in its own
/// page when the bank is large, and a page at a time the hardware
/// prefetcher does not run ahead of it.
#[inline]
fn prefetch<X>(at: *const X, len: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{_mm_prefetch, _MM_HINT_T1};
        // every line the values touch, from the one the first starts in
        let start = at.cast::<i8>();
        let skew = start as usize % 64;
        let line = start.wrapping_sub(skew);
        for offset in (0..skew + len * core::mem::size_of::<X>()).step_by(64) {
            // SAFETY: SSE is in every x86-64 CPU; a prefetch does not
            // access memory and never faults, whatever the address
            unsafe { _mm_prefetch::<_MM_HINT_T1>(line.wrapping_add(offset)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (at, len);
}

impl<T: Real> CompensatorBank<T> {
    /// Many samples of every channel at once: `targets` holds whole frames
    /// one after the other (frame `f`'s channel `c` at `f · channels + c`),
    /// and `out` gets each frame's voltages in the same places. The same
    /// bits as one [`CompensatorBank::compensate`] per frame, in order;
    /// for a planned signal (a feedforward computed ahead), not for a loop
    /// that learns its next target only at the next sample.
    ///
    /// It steps a few blocks through a run of frames before it moves on
    /// (each block is independent of the others), so that their state
    /// stays in L1 from one frame to the next: a bank whose state does not
    /// fit in L1 streams it through L2 once a frame in `compensate`, here
    /// once a run of frames. Allocation-free; `targets.len()` must be a
    /// whole number of frames and `out.len()` the same.
    pub fn compensate_frames(
        &mut self,
        targets: &[T],
        out: &mut [Compensated<T>],
    ) -> Result<(), ParameterError> {
        let tiling = FrameTiling::default();
        self.compensate_frames_on(Kernels::detect(), tiling, targets, out)
    }

    /// [`CompensatorBank::compensate_frames`] on the kernels `k`, tiled as
    /// `tiling` says (for tests and benches).
    #[cfg(feature = "internals")]
    pub fn compensate_frames_using(
        &mut self,
        k: Kernels,
        tiling: FrameTiling,
        targets: &[T],
        out: &mut [Compensated<T>],
    ) -> Result<(), ParameterError> {
        self.compensate_frames_on(k, tiling, targets, out)
    }

    /// [`CompensatorBank::compensate_frames`] on the kernels `k`, tiled as
    /// `tiling` says.
    fn compensate_frames_on(
        &mut self,
        k: Kernels,
        tiling: FrameTiling,
        targets: &[T],
        out: &mut [Compensated<T>],
    ) -> Result<(), ParameterError> {
        let channels = self.channels;
        let frames = targets.len().div_ceil(channels);
        check_length("bank.targets", frames * channels, targets.len())?;
        check_length("bank.out", targets.len(), out.len())?;
        let (sr, width) = (self.layout.state_rows(), lanes::<T>());
        let tile = (tiling.tile_bytes / (sr * core::mem::size_of::<Row>())).max(1);
        let run = tiling.run_frames.max(1);
        let (parity, tiles) = (self.parity, self.blocks.div_ceil(tile));
        let (mut fixed, state) = self.split();
        // tile `t`'s channels, and its slice of frame `f`
        let lanes_of = |t: usize| t * tile * width..((t + 1) * tile * width).min(channels);
        let slice = |f: usize, t: usize| {
            let lanes = lanes_of(t);
            f * channels + lanes.start..f * channels + lanes.end
        };
        let (targets_at, out_at) = (targets.as_ptr(), out.as_ptr());
        for first_frame in (0..frames).step_by(run) {
            let run_frames = first_frame..(first_frame + run).min(frames);
            for (t, state) in state.chunks_mut(tile * sr).enumerate() {
                if tiling.prefetch {
                    // the next tile's targets and outputs (of the next run
                    // after the last tile), while this one is stepped
                    let (next_frames, next_tile) = if t + 1 < tiles {
                        (run_frames.clone(), t + 1)
                    } else {
                        (run_frames.end..(run_frames.end + run).min(frames), 0)
                    };
                    for f in next_frames {
                        let r = slice(f, next_tile);
                        prefetch(targets_at.wrapping_add(r.start), r.len());
                        prefetch(out_at.wrapping_add(r.start), r.len());
                    }
                }
                for f in run_frames.clone() {
                    fixed.parity = parity ^ (f & 1);
                    let walk = Walk::of_step(fixed.parity);
                    let r = slice(f, t);
                    let (targets, out) = (&targets[r.clone()], &mut out[r]);
                    step_blocks(k, &fixed, t * tile, state, targets, out, walk);
                }
            }
        }
        self.parity ^= frames & 1;
        for f in 0..frames {
            let at = f * channels..(f + 1) * channels;
            let (targets, out) = (&targets[at.clone()], &mut out[at]);
            self.dynamic_channels(targets, out);
        }
        Ok(())
    }
}
