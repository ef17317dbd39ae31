//! The thread pool of the elementwise passes: scoped threads over contiguous chunks, one
//! per thread of the run, so that a result never depends on the split.

/// Elements per job below which an elementwise pass is not split across threads.
pub const PAR_MIN_CHUNK: usize = 32 * 1024;

/// Length of the contiguous chunks an elementwise pass over `n` elements is split into: one
/// chunk per thread of the run (`RAYON_NUM_THREADS`, see `gpecnet_train::train::set_num_threads`),
/// none shorter than [`PAR_MIN_CHUNK`]. Every element is computed on its own, so the result
/// does not depend on the split.
pub fn chunk_len(n: usize) -> usize {
    let threads = candle_core::utils::get_num_threads().max(1);
    n.div_ceil(threads).max(PAR_MIN_CHUNK).max(1)
}

/// Runs `f` on every job, the first on the calling thread and the others on scoped threads
/// (inline when a thread cannot be started). Returns when all are done.
pub fn for_each_job<T: Send, F: Fn(T) + Sync>(jobs: impl IntoIterator<Item = T>, f: F) {
    let mut jobs = jobs.into_iter();
    let Some(first) = jobs.next() else {
        return;
    };
    let f = &f;
    std::thread::scope(|s| {
        let mut inline = Vec::new();
        for job in jobs {
            // A job the OS refuses a thread for runs on this thread instead.
            let (tx, rx) = std::sync::mpsc::channel::<T>();
            let spawned = std::thread::Builder::new().spawn_scoped(s, move || {
                if let Ok(job) = rx.recv() {
                    f(job);
                }
            });
            match spawned {
                Ok(_) => {
                    if let Err(std::sync::mpsc::SendError(job)) = tx.send(job) {
                        inline.push(job);
                    }
                }
                Err(_) => inline.push(job),
            }
        }
        f(first);
        inline.into_iter().for_each(f);
    });
}

/// A new vector of `n` elements filled by `fill(range, out)` over contiguous ranges (each
/// `out` is the vector's `range`, its length a multiple of `align` but for the last), split
/// over threads as [`chunk_len`] says.
pub fn map_elements<F: Fn(std::ops::Range<usize>, &mut [f32]) + Sync>(
    n: usize,
    align: usize,
    fill: F,
) -> Vec<f32> {
    let mut out = vec![0f32; n];
    let align = align.max(1);
    let chunk = chunk_len(n).div_ceil(align) * align;
    let jobs = out
        .chunks_mut(chunk)
        .enumerate()
        .map(|(i, o)| (i * chunk..i * chunk + o.len(), o));
    for_each_job(jobs, |(range, o)| fill(range, o));
    out
}
