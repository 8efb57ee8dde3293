//! The caller's choice of parallelism, in faer's style: [`Par::Seq`] runs
//! on the calling thread only, [`Par::rayon`]`(n)` on `n` rayon threads
//! (`0`: the global pool, all threads, the default of every option that has
//! a `par` field).
//!
//! Every parallel loop of the library computes each item independently of
//! the others and collects the items in input order, so the sequential and
//! the parallel paths give bit-identical results (sums over threads, as in
//! the least-squares engine, are the exception: their order depends on the
//! threads).

use std::cell::Cell;

pub use faer::Par;
use rayon::prelude::*;

thread_local! {
    /// Set while [`install`] runs `Par::Seq` work on this thread.
    static SEQUENTIAL: Cell<bool> = const { Cell::new(false) };
}

/// Runs `f` with the parallelism `par`: `Par::Seq` on the calling thread
/// with every parallel loop inside run as a plain loop; `Par::rayon(0)` on
/// the global rayon pool; `Par::rayon(n)` on a pool of `n` threads built for
/// the call.
///
/// ```
/// use mtwin::par::{Par, install};
/// let caller = std::thread::current().id();
/// assert_eq!(install(Par::Seq, || std::thread::current().id()), caller);
/// assert_eq!(install(Par::rayon(2), || rayon::current_num_threads()), 2);
/// ```
pub fn install<R: Send>(par: Par, f: impl FnOnce() -> R + Send) -> R {
    match par {
        Par::Seq => with_flag(true, f),
        Par::Rayon(n) if n.get() == rayon::current_num_threads() => with_flag(false, f),
        Par::Rayon(n) => match rayon::ThreadPoolBuilder::new().num_threads(n.get()).build() {
            Ok(pool) => pool.install(|| with_flag(false, f)),
            // No threads to be had: the work still gets done, here.
            Err(_) => with_flag(false, f),
        },
    }
}

/// Runs `f` on the calling thread with `par`: `Par::Seq` makes every
/// parallel loop inside a plain loop; `Par::rayon(_)` runs them on the rayon
/// pool the caller is in (the thread count is the pool's: run the call inside
/// [`install`] to choose it). For work that cannot move to another thread.
pub(crate) fn here<R>(par: Par, f: impl FnOnce() -> R) -> R {
    with_flag(matches!(par, Par::Seq), f)
}

fn with_flag<R>(seq: bool, f: impl FnOnce() -> R) -> R {
    let before = SEQUENTIAL.with(|s| s.replace(seq));
    struct Restore(bool);
    impl Drop for Restore {
        fn drop(&mut self) {
            SEQUENTIAL.with(|s| s.set(self.0));
        }
    }
    let _restore = Restore(before);
    f()
}

/// Whether the current work runs sequentially (inside `install(Par::Seq, …)`).
pub(crate) fn sequential() -> bool {
    SEQUENTIAL.with(|s| s.get())
}

/// The parallelism to hand to faer for the current work.
pub(crate) fn faer() -> Par {
    if sequential() {
        Par::Seq
    } else {
        Par::rayon(0)
    }
}

/// `f(i, item)` of every item, in order; in parallel (at least `min_len`
/// items per task) unless sequential.
pub(crate) fn map<T: Sync, R: Send>(
    items: &[T],
    min_len: usize,
    f: impl Fn(usize, &T) -> R + Sync + Send,
) -> Vec<R> {
    if sequential() {
        items.iter().enumerate().map(|(i, x)| f(i, x)).collect()
    } else {
        items
            .par_iter()
            .enumerate()
            .with_min_len(min_len)
            .map(|(i, x)| f(i, x))
            .collect()
    }
}

/// `f(i, item)` of every item, collected in order; in parallel unless
/// sequential, the items taken up one at a time in their order (a free
/// thread takes the next), so that the first items start first — for work
/// whose early results make later items cheaper.
pub(crate) fn map_in_turn<T: Sync, R: Send>(
    items: &[T],
    f: impl Fn(usize, &T) -> R + Sync + Send,
) -> Vec<R> {
    if sequential() {
        items.iter().enumerate().map(|(i, x)| f(i, x)).collect()
    } else {
        let mut out: Vec<(usize, R)> = items
            .iter()
            .enumerate()
            .par_bridge()
            .map(|(i, x)| (i, f(i, x)))
            .collect();
        out.sort_unstable_by_key(|(i, _)| *i);
        out.into_iter().map(|(_, r)| r).collect()
    }
}

/// [`map`] over the chunks of `chunk` items (the last may be shorter), with
/// one scratch value per task made by `init`.
pub(crate) fn map_chunks_init<T: Sync, S, R: Send>(
    items: &[T],
    chunk: usize,
    min_len: usize,
    init: impl Fn() -> S + Sync + Send,
    f: impl Fn(&mut S, usize, &[T]) -> R + Sync + Send,
) -> Vec<R> {
    if sequential() {
        let mut s = init();
        items
            .chunks(chunk)
            .enumerate()
            .map(|(i, c)| f(&mut s, i, c))
            .collect()
    } else {
        items
            .par_chunks(chunk)
            .enumerate()
            .with_min_len(min_len)
            .map_init(init, |s, (i, c)| f(s, i, c))
            .collect()
    }
}

/// `(a(), b())`, both at once unless sequential.
pub(crate) fn join<A: Send, B: Send>(
    a: impl FnOnce() -> A + Send,
    b: impl FnOnce() -> B + Send,
) -> (A, B) {
    if sequential() {
        (a(), b())
    } else {
        rayon::join(a, b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seq_runs_every_item_on_the_calling_thread_and_keeps_the_order() {
        let caller = std::thread::current().id();
        let items: Vec<u64> = (0..10_000).collect();
        let (ids, values) = install(Par::Seq, || {
            let ids = map(&items, 1, |_, _| std::thread::current().id());
            let values = map(&items, 1, |i, x| (i as u64) * x);
            (ids, values)
        });
        assert!(ids.iter().all(|&t| t == caller));
        assert_eq!(values[7], 49);
        let parallel = install(Par::rayon(2), || map(&items, 1, |i, x| (i as u64) * x));
        assert_eq!(parallel, values);
        assert!(!sequential(), "the flag is restored after install");
    }
}
