//! The Python module's worker pools: one per thread count asked for (the last few kept), all
//! of the module's parallel work — loading, rendering, the image's summary — runs on them, never
//! on rayon's global pool. After `fork` (Python's `multiprocessing` on Linux) a child has the
//! parent's pools without their threads; a pool made by another process is made again.

use super::convert::scene_error;
use pyo3::prelude::*;
use rayon::ThreadPool;
use std::sync::{Arc, Mutex};

/// Pools kept: more thread counts than a script alternates between.
const KEPT: usize = 4;

/// The pool of `threads` workers (None: rayon's default, every core), made if needed.
pub(super) fn pool(threads: Option<usize>) -> PyResult<Arc<ThreadPool>> {
    static POOLS: Mutex<Vec<(u32, usize, Arc<ThreadPool>)>> = Mutex::new(Vec::new());
    let n = threads.unwrap_or(0);
    let max = crate::max_threads();
    if threads.is_some() && !(1..=max).contains(&n) {
        return Err(scene_error(format!(
            "threads: must lie in 1..={max} (8 per core on this machine), got {n}"
        )));
    }
    let pid = std::process::id();
    let mut pools = POOLS.lock().unwrap_or_else(|e| e.into_inner());
    // Another process's pools (we are a forked child) have no threads here.
    pools.retain(|(p, _, _)| *p == pid);
    if let Some(k) = pools.iter().position(|(_, m, _)| *m == n) {
        let entry = pools.remove(k);
        let p = entry.2.clone();
        pools.push(entry); // the most recently used last
        return Ok(p);
    }
    let p = rayon::ThreadPoolBuilder::new().num_threads(n).build().map_err(|e| {
        pyo3::exceptions::PyOSError::new_err(format!("cannot start worker threads: {e}"))
    })?;
    let p = Arc::new(p);
    pools.push((pid, n, p.clone()));
    if pools.len() > KEPT {
        pools.remove(0);
    }
    Ok(p)
}

/// Runs `f` on the pool of `threads` workers with the GIL released.
pub(super) fn off_gil<T: Send>(
    py: Python<'_>,
    threads: Option<usize>,
    f: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    let p = pool(threads)?;
    Ok(py.detach(|| p.install(f)))
}
