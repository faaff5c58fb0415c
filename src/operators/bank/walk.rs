//! The order in which a step walks a run of a bank's blocks ([`Walk`]):
//! what the caches and the hardware prefetcher hold when a block is
//! reached depends on it.

/// The order a run of blocks is stepped in: the same bits either way (each
/// block is independent of the others).
///
/// A core that walks its blocks up the memory has its hardware prefetcher
/// run on past its last block, into the blocks after it. When another core
/// steps those (the next part of a split step), it finds their lines taken
/// from its cache at every step (where measured, the second half of a
/// bank split in two then took 1.3–1.5× the first's time per block,
/// whichever thread stepped it). So a split walks its even parts down and
/// its odd parts up: with two parts both run off the ends of the bank.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Walk {
    Up,
    Down,
}

impl Walk {
    /// The walk of a step on one thread: up and down in turn (`parity`
    /// changes at every step). A walk in one direction over more state
    /// than a cache holds finds none of it there: a cache that keeps the
    /// lines used last has evicted each just before it is needed again.
    /// Walked back, a step starts on the lines the step before left in the
    /// cache (5–10 % less time where the state is about twice L2, where
    /// measured; nothing where it fits). A split keeps its parts' fixed
    /// walks ([`Walk::of_part`]): turned, its two parts would walk towards
    /// each other every other step, one core's prefetcher into the other's
    /// blocks.
    pub(super) fn of_step(parity: usize) -> Self {
        if parity.is_multiple_of(2) {
            Walk::Up
        } else {
            Walk::Down
        }
    }

    /// The walk of part `part` of a split: even parts down, odd parts up
    /// (with more than two parts, an odd part still runs on into the even
    /// one after it).
    #[cfg_attr(not(feature = "rayon"), allow(dead_code))]
    pub(super) fn of_part(part: usize) -> Self {
        if part.is_multiple_of(2) {
            Walk::Down
        } else {
            Walk::Up
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_thread_steps_walk_up_and_down_in_turn() {
        let walks: Vec<Walk> = (0..4).map(Walk::of_step).collect();
        assert_eq!(walks, [Walk::Up, Walk::Down, Walk::Up, Walk::Down]);
    }

    #[test]
    fn a_split_walks_its_even_parts_down_and_its_odd_parts_up() {
        let walks: Vec<Walk> = (0..4).map(Walk::of_part).collect();
        assert_eq!(walks, [Walk::Down, Walk::Up, Walk::Down, Walk::Up]);
    }
}
