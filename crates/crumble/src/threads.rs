//! The step's threads outside the solver's passes: which pool a step runs
//! in, how many workers it has, and loops over bodies that the threads
//! share out. Each item a loop hands out touches only what is its own, so
//! the result never depends on the number of threads. (The solver's own
//! sharing, with its safety contract, is in `solver/schedule.rs`.)

use std::sync::Arc;

use rayon::prelude::*;

use crate::world::WorldError;

/// `v` emptied, with room for `len` items, and that room: to be written
/// item by item (by several threads) before `set_len(len)`.
pub(crate) fn uninit<T: Copy>(v: &mut Vec<T>, len: usize) -> &mut [std::mem::MaybeUninit<T>] {
    v.clear();
    v.reserve(len);
    &mut v.spare_capacity_mut()[..len]
}

/// Bodies (or other items) one task takes in [`for_each_index`].
const INDEX_CHUNK: usize = 512;

/// Calls `one(k)` for every `k < n`: in chunks on the threads of `pool`
/// (or of the pool the step runs in) when `parallel`, else in order here.
/// Each call must touch only what is its own: then the result does not
/// depend on the threads.
pub(crate) fn for_each_index(pool: Option<&rayon::ThreadPool>, parallel: bool, n: usize, one: impl Fn(usize) + Sync) {
    if parallel {
        on_pool(pool, true, || {
            (0..n.div_ceil(INDEX_CHUNK)).into_par_iter().for_each(|c| {
                (c * INDEX_CHUNK..((c + 1) * INDEX_CHUNK).min(n)).for_each(&one);
            })
        });
    } else {
        (0..n).for_each(one);
    }
}

/// Runs `run` in `pool` when there is one and `parallel` (so that its
/// rayon calls use that pool's threads), else where it is called.
pub(crate) fn on_pool<R: Send>(pool: Option<&rayon::ThreadPool>, parallel: bool, run: impl FnOnce() -> R + Send) -> R {
    match pool {
        Some(pool) if parallel => pool.install(run),
        _ => run(),
    }
}

/// The threads a step may use: 1 with `threads: 1` (rayon is not asked:
/// `rayon::current_num_threads` would start its global pool, which that
/// setting promises to leave alone), else those of the world's own pool,
/// or of the rayon pool the step runs in (rayon's global pool outside
/// any).
pub(crate) fn workers(threads: usize, pool: Option<&rayon::ThreadPool>) -> usize {
    match (threads, pool) {
        (1, _) => 1,
        (_, Some(pool)) => pool.current_num_threads(),
        (_, None) => rayon::current_num_threads(),
    }
}

/// The pool that `WorldSettings::threads` asks the world to own, if any.
pub(crate) fn thread_pool(threads: usize) -> Result<Option<Arc<rayon::ThreadPool>>, WorldError> {
    if threads < 2 {
        return Ok(None);
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|k| format!("crumble-solver-{k}"))
        .build()
        .map(|pool| Some(Arc::new(pool)))
        .map_err(|e| WorldError::ThreadPool(e.to_string()))
}
