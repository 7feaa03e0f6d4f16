//! Independent jobs spread over the cores with rayon, on a pool of a given size: the fit's
//! `--threads`, or one thread per core. Every caller collects results in the jobs' order,
//! so what it computes never depends on the number of threads or on their timing.

use rayon::prelude::*;

/// The number of threads for `threads`: itself, or one per core when 0.
pub fn thread_count(threads: usize) -> usize {
    if threads > 0 {
        return threads;
    }
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Runs `work` on a pool of [`thread_count`]`(threads)` threads: rayon's global pool (one
/// thread per core, made once per process) for 0, else a pool of its own. The calling
/// thread waits; where no pool can be made (no thread can be spawned), it runs `work`
/// itself.
pub fn on_pool<R: Send>(threads: usize, work: impl FnOnce() -> R + Send) -> R {
    if threads == 0 {
        return work();
    }
    match rayon::ThreadPoolBuilder::new()
        .num_threads(thread_count(threads))
        .build()
    {
        Ok(pool) => pool.install(work),
        Err(_) => work(),
    }
}

/// `work(0..jobs)` on [`thread_count`]`(threads)` threads; the results in job order.
pub fn in_parallel<T: Send>(
    jobs: usize,
    threads: usize,
    work: impl Fn(usize) -> T + Sync + Send,
) -> Vec<T> {
    on_pool(threads, || (0..jobs).into_par_iter().map(work).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_come_in_job_order_whatever_the_threads() {
        for threads in [0, 1, 2, 5] {
            let squares = in_parallel(100, threads, |k| k * k);
            assert_eq!(squares, (0..100).map(|k| k * k).collect::<Vec<_>>());
        }
        assert!(in_parallel(0, 2, |k| k).is_empty());
    }

    #[test]
    fn zero_threads_means_one_per_core() {
        assert_eq!(thread_count(3), 3);
        assert!(thread_count(0) >= 1);
    }
}
