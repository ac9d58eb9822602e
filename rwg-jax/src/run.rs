//! [`crate::JaxSource::run_blocks`]: the chunks of a cell handed to the
//! workers (one thread each, one chunk in flight each), their outcomes put
//! back together in chunk order.

use crate::chunks::{chunk_len, chunks, results, Assembly, Chunk};
use crate::protocol::{CellShape, Outcome};
use crate::worker::JaxWorker;
use crate::{JaxError, JaxSource};
use rwg_core::policy::NetShape;
use rwg_core::sampler::{draw_block_weights, reset_seed, BlockResult, CellPlan, SampleError};
use rwg_env::EnvError;
use std::collections::BTreeMap;
use std::ops::Range;
use std::sync::mpsc::{channel, Receiver, Sender};

/// Chunks handed out ahead of the first one not yet put back, per worker.
const AHEAD_PER_WORKER: usize = 2;

/// A worker thread's answer: (thread, chunk, outcome).
type Answer = (usize, usize, Result<Outcome, JaxError>);

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
    X: From<SampleError> + Send,
{
    let spec = &src.info.spec;
    let shape = NetShape::new(
        spec.obs_dim(),
        &plan.arch,
        NetShape::outputs_for(&spec.action_space),
    );
    let cell = CellShape {
        hidden: plan.arch.hidden.clone(),
        bias: plan.arch.bias,
        networks: src.networks_per_call(),
        episodes: plan.episodes,
        n_weights: shape.n_weights(),
    };
    let all = chunks(blocks, cell.networks as usize);
    let mut assembly = Assembly::new(blocks, plan.episodes);
    if all.is_empty() {
        return assembly.add(&[], &mut on_block);
    }
    let workers = src.workers_for(threads).min(all.len());
    std::thread::scope(|scope| {
        let (answer_tx, answers) = channel::<Answer>();
        let mut jobs = vec![];
        let mut handles = vec![];
        for t in 0..workers {
            let (job_tx, job_rx) = channel::<usize>();
            jobs.push(job_tx);
            let (answer_tx, cell, all) = (answer_tx.clone(), &cell, &all);
            handles.push(scope.spawn(move || serve(src, plan, cell, all, t, job_rx, answer_tx)));
        }
        drop(answer_tx);
        let r = collect(plan, &all, &jobs, &answers, &mut assembly, &mut on_block);
        drop(jobs); // the threads end after their chunk in flight
        for h in handles {
            if let Ok(Some(w)) = h.join() {
                src.lock_pool().push(w);
            }
        }
        r
    })
}

/// The main thread's loop: hands chunks to free workers (at most
/// [`AHEAD_PER_WORKER`] per worker past the first chunk not yet put back),
/// puts their outcomes back in chunk order, stops at the first failure.
fn collect<G, X>(
    plan: &CellPlan,
    all: &[Chunk],
    jobs: &[Sender<usize>],
    answers: &Receiver<Answer>,
    assembly: &mut Assembly<'_>,
    on_block: &mut G,
) -> Result<(), X>
where
    G: FnMut(BlockResult) -> Result<(), X>,
    X: From<SampleError> + Send,
{
    let window = AHEAD_PER_WORKER * jobs.len();
    let mut idle: Vec<usize> = (0..jobs.len()).rev().collect();
    let mut next_job = 0;
    let mut next_done = 0;
    let mut pending: BTreeMap<usize, Result<Outcome, JaxError>> = BTreeMap::new();
    let mut failed = false;
    while next_done < all.len() {
        while !failed && next_job < all.len() && next_job < next_done + window {
            let Some(t) = idle.pop() else { break };
            if jobs[t].send(next_job).is_err() {
                continue; // its worker is gone (its failure is on the way)
            }
            next_job += 1;
        }
        let Ok((t, c, outcome)) = answers.recv() else {
            unreachable!("a thread ended with chunks in flight");
        };
        failed |= outcome.is_err();
        idle.push(t);
        pending.insert(c, outcome);
        while let Some(outcome) = pending.remove(&next_done) {
            let chunk = &all[next_done];
            let outcome = outcome.map_err(|e| chunk_error(plan, chunk, e))?;
            let (ok, failure) = results(&plan.env_id, chunk, plan.episodes, &outcome);
            assembly.add(&ok, on_block)?;
            if let Some(f) = failure {
                return Err(f.into());
            }
            next_done += 1;
        }
    }
    Ok(())
}

/// The error of a chunk whose call failed: named by its first network.
fn chunk_error(plan: &CellPlan, chunk: &Chunk, e: JaxError) -> SampleError {
    let first = chunk[0].samples.start;
    let last = chunk.last().expect("a chunk has networks").samples.end - 1;
    SampleError {
        env: plan.env_id.clone(),
        sample: first,
        episode: 0,
        step: 0,
        error: EnvError::Other(format!(
            "in the compiled call running networks {first} to {last} ({} networks, every \
             episode): {e}",
            chunk_len(chunk)
        )),
    }
}

/// A worker thread: takes a worker (idle or new), compiles the cell, runs
/// the chunks it is handed. Returns the worker if it is still sound.
fn serve(
    src: &JaxSource,
    plan: &CellPlan,
    cell: &CellShape,
    all: &[Chunk],
    t: usize,
    jobs: Receiver<usize>,
    answers: Sender<Answer>,
) -> Option<JaxWorker> {
    let mut worker = src.take_worker();
    if let Ok(w) = &mut worker {
        if let Err(e) = w.set_cell(cell) {
            worker = Err(e);
        }
    }
    let mut weights = vec![];
    let mut seeds = vec![];
    for c in jobs {
        let w = match worker {
            Ok(ref mut w) => w,
            Err(e) => {
                // a start-up or compile failure, reported for its first chunk
                let _ = answers.send((t, c, Err(e)));
                return None;
            }
        };
        chunk_inputs(plan, cell, &all[c], &mut weights, &mut seeds);
        let outcome = w.run_chunk(chunk_len(&all[c]), &weights, &seeds);
        let broken = outcome.is_err();
        if answers.send((t, c, outcome)).is_err() || broken {
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
    weights: &mut Vec<f64>,
    seeds: &mut Vec<u64>,
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
