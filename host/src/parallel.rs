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

/// Items handed from the reading thread to the computing one at a time: a few dozen
/// hand-overs a second, each of which can wait for a core on a busy machine.
const READ_AHEAD_CHUNK: usize = 16 * 1024;
/// Chunks read ahead of the computation at most: memory stays bounded whatever the
/// input's length.
const READ_AHEAD_CHUNKS: usize = 2;

/// `consume` of every item of the stream `open` makes, the stream read on a thread of its
/// own while `consume` runs on the caller's: reading a ride (parsing its text, resampling)
/// and computing on it (the model, the weighting) take about as long as each other, so on
/// two cores the two overlap. Items arrive in order, in chunks of `READ_AHEAD_CHUNK`,
/// at most `READ_AHEAD_CHUNKS` chunks ahead. The first error, of the stream or of
/// `consume`, stops both and is returned; so does a thread that cannot be spawned.
///
/// Called on a thread of a rayon pool (a ride read inside a parallel job: `report
/// --band`'s sets), the stream is read on the caller's thread instead: a pool's thread
/// waiting on the channel could not run other jobs, and the reading's own parallel
/// parsing ([`crate::io::csv_blocks`]) waits for the pool's threads, so every thread of
/// the pool waiting on its reader would be a deadlock. Read in line, a pool's thread only
/// ever waits inside rayon, which runs other jobs meanwhile.
///
/// Written here rather than taken from a crate: it is `std`'s scoped threads and bounded
/// channel, a dozen lines; rayon's pools and crossbeam's channels serve other shapes.
pub fn read_ahead<T, I>(
    open: impl FnOnce() -> anyhow::Result<I> + Send,
    mut consume: impl FnMut(T) -> anyhow::Result<()>,
) -> anyhow::Result<()>
where
    T: Send,
    I: Iterator<Item = anyhow::Result<T>>,
{
    if rayon::current_thread_index().is_some() {
        for item in open()? {
            consume(item?)?;
        }
        return Ok(());
    }
    let (sender, receiver) =
        std::sync::mpsc::sync_channel::<anyhow::Result<Vec<T>>>(READ_AHEAD_CHUNKS);
    std::thread::scope(|scope| {
        let reader = std::thread::Builder::new().spawn_scoped(scope, move || {
            let mut stream = match open() {
                Ok(stream) => stream,
                Err(e) => {
                    let _ = sender.send(Err(e));
                    return;
                }
            };
            loop {
                let mut chunk = Vec::with_capacity(READ_AHEAD_CHUNK);
                for item in stream.by_ref().take(READ_AHEAD_CHUNK) {
                    match item {
                        Ok(item) => chunk.push(item),
                        Err(e) => {
                            let _ = sender.send(Ok(chunk));
                            let _ = sender.send(Err(e));
                            return;
                        }
                    }
                }
                let last = chunk.len() < READ_AHEAD_CHUNK;
                // A closed receiver: the computation stopped; so does the reading.
                if sender.send(Ok(chunk)).is_err() || last {
                    return;
                }
            }
        });
        if let Err(e) = reader {
            return Err(anyhow::anyhow!("cannot start the reading thread: {e}"));
        }
        for chunk in receiver {
            for item in chunk? {
                consume(item)?;
            }
        }
        Ok(())
    })
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

    #[test]
    fn rides_read_inside_every_job_of_a_busy_pool_all_finish() {
        // More jobs than the global pool has threads, each reading a stream whose items
        // are themselves made on that pool (as a ride's blocks are parsed): with each
        // reader on a thread of its own and every thread of the pool waiting for one,
        // none would finish.
        let jobs = 4 * thread_count(0);
        let streams = in_parallel(jobs, 0, |k| {
            let mut sum = 0u64;
            super::read_ahead(
                || {
                    Ok((0..4 * super::READ_AHEAD_CHUNK as u64)
                        .map(move |i| Ok(in_parallel(2, 0, |j| i + j as u64 + k as u64)[1])))
                },
                |v| {
                    sum += v;
                    Ok(())
                },
            )
            .map(|()| sum)
        });
        let n = 4 * super::READ_AHEAD_CHUNK as u64;
        for (k, sum) in streams.into_iter().enumerate() {
            assert_eq!(sum.unwrap(), n * (n - 1) / 2 + n * (k as u64 + 1));
        }
    }

    #[test]
    fn read_ahead_hands_every_item_in_order_and_stops_at_the_first_error() {
        let n = 3 * super::READ_AHEAD_CHUNK + 17;
        let mut seen = Vec::new();
        super::read_ahead(
            || Ok((0..n).map(anyhow::Ok)),
            |k| {
                seen.push(k);
                Ok(())
            },
        )
        .unwrap();
        assert_eq!(seen, (0..n).collect::<Vec<_>>());
        // The stream's error, after the items before it.
        let mut seen = 0;
        let err = super::read_ahead(
            || {
                Ok((0..n).map(|k| {
                    if k == 5000 {
                        Err(anyhow::anyhow!("bad row {k}"))
                    } else {
                        Ok(k)
                    }
                }))
            },
            |_| {
                seen += 1;
                Ok(())
            },
        )
        .unwrap_err();
        assert_eq!((err.to_string(), seen), ("bad row 5000".to_string(), 5000));
        // The consumer's error stops the reading of an endless stream.
        let err = super::read_ahead(
            || Ok((0..).map(anyhow::Ok)),
            |k: u64| {
                if k == 10 {
                    anyhow::bail!("enough")
                } else {
                    Ok(())
                }
            },
        )
        .unwrap_err();
        assert_eq!(err.to_string(), "enough");
    }
}
