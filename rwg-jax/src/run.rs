//! [`crate::JaxSource::run_blocks`]: the chunks of a cell handed round
//! robin to the workers (one thread each, one chunk in flight each, the next
//! chunk's weights and seeds drawn while the worker computes), their
//! outcomes put back together in chunk order.

use crate::chunks::{chunk_len, chunks, results, Assembly, Chunk};
use crate::protocol::{CellShape, Outcome};
use crate::warm_up::WarmUp;
use crate::worker::JaxWorker;
use crate::{CallError, JaxError, JaxSource};
use rwg_core::policy::PolicyKind;
use rwg_core::sampler::{
    draw_block_weights, reset_seed, BlockResult, CellPlan, NonFinite, SampleError,
};
use std::ops::Range;
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};

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
    let shape = plan.net_shape(&src.info.spec);
    let cell = CellShape {
        hidden: plan.arch.hidden.clone(),
        bias: plan.arch.bias,
        networks: src.networks_per_call(),
        episodes: plan.episodes,
        n_weights: shape.n_weights(),
        random: plan.policy == PolicyKind::Random,
        non_finite_ends: plan.non_finite == NonFinite::End,
    };
    let all = chunks(blocks, cell.networks as usize);
    let mut assembly = Assembly::new(blocks, plan.episodes);
    if all.is_empty() {
        return assembly.add(&[], &mut on_block);
    }
    let workers = src.workers_for(threads).min(all.len());
    let warm = src.warm_ups.begin(workers);
    std::thread::scope(|scope| {
        let mut outcomes = vec![];
        let mut handles = vec![];
        for t in 0..workers {
            let (tx, rx) = sync_channel(AHEAD_PER_WORKER);
            outcomes.push(rx);
            let (cell, all, warm) = (&cell, &all, &warm);
            handles
                .push(scope.spawn(move || serve(src, plan, (cell, warm), all, (t, workers), tx)));
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

/// A worker thread `t` of `workers`: takes a worker (idle or new),
/// compiles the cell (then tells `warm` it is ready), runs chunks `t`,
/// `t + workers`, ... in order, drawing
/// each chunk's inputs while the worker runs the one before. Returns the
/// worker if it is still sound.
fn serve(
    src: &JaxSource,
    plan: &CellPlan,
    (cell, warm): (&CellShape, &WarmUp),
    all: &[Chunk],
    (t, workers): (usize, usize),
    outcomes: SyncSender<Result<Outcome, Failed>>,
) -> Option<JaxWorker> {
    let mut worker = match src.take_worker() {
        Ok(mut w) => w.set_cell(cell).map(|_| w),
        Err(e) => Err(e),
    };
    warm.ready();
    let mut inputs = (vec![], vec![]);
    let mut next = (vec![], vec![]);
    chunk_inputs(plan, cell, &all[t], &mut next);
    for c in (t..all.len()).step_by(workers) {
        std::mem::swap(&mut inputs, &mut next);
        let w = match worker {
            Ok(ref mut w) => w,
            Err(e) => {
                // a start-up or compile failure, reported for its first chunk
                let _ = outcomes.send(Err(Failed::Setup(e)));
                return None;
            }
        };
        let n = chunk_len(&all[c]);
        let outcome = w
            .send_chunk(n, &inputs.0, &inputs.1)
            .and_then(|()| {
                if let Some(after) = all.get(c + workers) {
                    chunk_inputs(plan, cell, after, &mut next);
                }
                w.recv_outcome(inputs.1.len())
            })
            .map_err(Failed::Call);
        let broken = outcome.is_err();
        if outcomes.send(outcome).is_err() || broken {
            return None;
        }
    }
    worker.ok()
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
