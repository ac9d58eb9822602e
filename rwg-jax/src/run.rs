//! [`crate::JaxSource::run_blocks`]: the chunks of a cell handed round
//! robin to the workers (one thread each), their outcomes put back together
//! in chunk order. Each worker has one chunk more in flight than it has
//! devices: the next chunk is on its way while a device computes, and the
//! next chunk's weights and seeds are drawn meanwhile. With the compilation
//! cache on, the first worker compiles the cell and the others, started
//! meanwhile, read its program from the cache.

use crate::chunks::{chunk_len, chunks, per_chunk, results, Assembly, Chunk};
use crate::protocol::{CellShape, Outcome};
use crate::worker::JaxWorker;
use crate::{CallError, JaxError, JaxSource};
use rwg_core::sampler::{draw_block_weights, reset_seed, BlockResult, CellPlan, SampleError};
use std::collections::VecDeque;
use std::ops::Range;
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::Barrier;

/// Outcomes a worker thread may have ready before they are put back.
const AHEAD_PER_WORKER: usize = 2;

/// See [`crate::JaxSource::run_blocks`].
pub fn run_blocks<G, X>(
    src: &JaxSource,
    plan: &CellPlan,
    blocks: &[Range<u64>],
    threads: usize,
    mut on_block: G,
) -> Result<(), X>
where
    G: FnMut(BlockResult) -> Result<(), X>,
    X: From<SampleError> + From<CallError> + Send,
{
    let cell = src.cell_shape(plan);
    // every worker, and every device of a worker, gets a chunk if it can
    let total = blocks.iter().map(|b| b.end - b.start).sum();
    let parallel = src.workers_for(threads) * src.info.devices.max(1);
    let all = chunks(blocks, per_chunk(cell.networks, total, parallel));
    let mut assembly = Assembly::new(blocks, plan.episodes);
    if all.is_empty() {
        return assembly.add(&[], &mut on_block);
    }
    let workers = src.workers_for(threads).min(all.len());
    // with a compilation cache, the first worker's compile serves the others
    let compiled = src
        .config
        .compile_cache
        .is_some()
        .then(|| Barrier::new(workers));
    let warm = src.warm_ups.begin(workers);
    std::thread::scope(|scope| {
        let mut outcomes = vec![];
        let mut handles = vec![];
        for t in 0..workers {
            let (tx, rx) = sync_channel(AHEAD_PER_WORKER);
            outcomes.push(rx);
            let (cell, all, compiled, warm) = (&cell, &all, compiled.as_ref(), &warm);
            handles.push(scope.spawn(move || {
                let w = ready_worker(src, cell, t, compiled);
                warm.ready();
                serve(src, plan, cell, all, (t, workers), w, tx)
            }));
        }
        let r = collect(plan, &all, &outcomes, &mut assembly, &mut on_block);
        drop(outcomes); // the threads end after their chunk in flight
        for h in handles {
            if let Ok(Some(w)) = h.join() {
                src.lock_pool().push(w);
            }
        }
        r
    })
}

/// The main thread's loop: takes chunk `c`'s outcome from worker
/// `c % workers`, puts the outcomes back in chunk order, stops at the first
/// failure.
fn collect<G, X>(
    plan: &CellPlan,
    all: &[Chunk],
    outcomes: &[Receiver<Result<Outcome, Failed>>],
    assembly: &mut Assembly<'_>,
    on_block: &mut G,
) -> Result<(), X>
where
    G: FnMut(BlockResult) -> Result<(), X>,
    X: From<SampleError> + From<CallError> + Send,
{
    for (c, chunk) in all.iter().enumerate() {
        let outcome = outcomes[c % outcomes.len()]
            .recv()
            .unwrap_or_else(|_| unreachable!("a worker thread ended before its chunk {c}"));
        let outcome = outcome.map_err(|e| chunk_error(plan, chunk, e))?;
        let (ok, failure) = results(plan, chunk, &outcome);
        assembly.add(&ok, on_block)?;
        if let Some(f) = failure {
            return Err(f.into());
        }
    }
    Ok(())
}

/// Why a worker thread sent no outcome for a chunk.
enum Failed {
    /// Its worker could not start or compile the cell.
    Setup(JaxError),
    /// The chunk's call failed as a whole.
    Call(JaxError),
}

/// The error of a chunk whose worker failed: a setup failure is the env's,
/// a call's is named by its networks (no episode of it is to blame).
fn chunk_error(plan: &CellPlan, chunk: &Chunk, e: Failed) -> CallError {
    let (networks, error) = match e {
        Failed::Setup(e) => (None, e),
        Failed::Call(e) => {
            let first = chunk[0].samples.start;
            let last = chunk.last().expect("a chunk has networks").samples.end - 1;
            (Some((first, last, chunk_len(chunk))), e)
        }
    };
    CallError {
        env: plan.env_id.clone(),
        networks,
        error,
    }
}

/// Worker thread `t`'s worker (idle or new) with the cell compiled. With
/// `compiled` (a compilation cache), thread 0 compiles first and the others
/// wait for it (starting their workers meanwhile), then read the cache.
fn ready_worker(
    src: &JaxSource,
    cell: &CellShape,
    t: usize,
    compiled: Option<&Barrier>,
) -> Result<JaxWorker, JaxError> {
    let mut worker = src.take_worker();
    if t == 0 {
        worker = worker.and_then(|mut w| w.set_cell(cell).map(|_| w));
    }
    if let Some(b) = compiled {
        b.wait(); // every thread passes here once, whatever failed
    }
    if t != 0 {
        worker = worker.and_then(|mut w| w.set_cell(cell).map(|_| w));
    }
    worker
}

/// A worker thread `t` of `workers`: runs chunks `t`, `t + workers`, ... in
/// order on `worker`, one more in flight than it has devices, drawing each
/// chunk's inputs while the worker runs the ones before. Returns the
/// worker if it is still sound.
fn serve(
    src: &JaxSource,
    plan: &CellPlan,
    cell: &CellShape,
    all: &[Chunk],
    (t, workers): (usize, usize),
    worker: Result<JaxWorker, JaxError>,
    outcomes: SyncSender<Result<Outcome, Failed>>,
) -> Option<JaxWorker> {
    let mut w = match worker {
        Ok(w) => w,
        Err(e) => {
            // a start-up or compile failure, reported for its first chunk
            let _ = outcomes.send(Err(Failed::Setup(e)));
            return None;
        }
    };
    let depth = src.info.devices + 1;
    let mine: Vec<usize> = (t..all.len()).step_by(workers).collect();
    let mut sent = VecDeque::new();
    let mut inputs = (vec![], vec![]);
    let mut next = (vec![], vec![]);
    chunk_inputs(plan, cell, &all[mine[0]], &mut next);
    let episodes = plan.episodes as usize;
    let answer = |w: &mut JaxWorker, sent: &mut VecDeque<usize>| {
        let c = sent.pop_front().expect("a chunk in flight");
        let outcome = w
            .recv_outcome(chunk_len(&all[c]) * episodes)
            .map_err(Failed::Call);
        let broken = outcome.is_err();
        outcomes.send(outcome).is_ok() && !broken
    };
    for (j, &c) in mine.iter().enumerate() {
        std::mem::swap(&mut inputs, &mut next);
        let answers = usize::from(w.in_flight() + 1 >= depth);
        if let Err(e) = w.send_chunk(answers, chunk_len(&all[c]), &inputs.0, &inputs.1) {
            let _ = outcomes.send(Err(Failed::Call(e)));
            return None;
        }
        sent.push_back(c);
        if let Some(&after) = mine.get(j + 1) {
            chunk_inputs(plan, cell, &all[after], &mut next);
        }
        if answers == 1 && !answer(&mut w, &mut sent) {
            return None;
        }
    }
    if let Err(e) = w.flush() {
        let _ = outcomes.send(Err(Failed::Call(e)));
        return None;
    }
    while !sent.is_empty() {
        if !answer(&mut w, &mut sent) {
            return None;
        }
    }
    Some(w)
}

/// The weights (network-major) and reset seeds (network-major, then
/// episode) of a chunk's networks.
fn chunk_inputs(
    plan: &CellPlan,
    cell: &CellShape,
    chunk: &Chunk,
    (weights, seeds): &mut (Vec<f64>, Vec<u64>),
) {
    let nw = cell.n_weights;
    weights.clear();
    seeds.clear();
    let mut piece = vec![];
    for p in chunk {
        draw_block_weights(plan, &p.samples, nw, &mut piece);
        weights.extend_from_slice(&piece[..(p.samples.end - p.samples.start) as usize * nw]);
        for n in p.samples.clone() {
            seeds.extend((0..plan.episodes).map(|e| reset_seed(plan.seed, &plan.env_id, n, e)));
        }
    }
}
