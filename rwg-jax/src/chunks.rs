//! Blocks of networks cut into chunks of one compiled call, and the chunks'
//! outcomes put back together into blocks, in block order.

use crate::protocol::{Outcome, FAULT_OBS, FAULT_RETURN, FAULT_REWARD};
use rwg_core::sampler::{
    with_end_hint, BlockResult, CellPlan, EpisodeResult, NonFinite, SampleError,
};
use rwg_env::EnvError;
use std::ops::Range;

/// The networks of one block that one chunk runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Piece {
    /// The block's index in the blocks given.
    pub block: usize,
    /// The networks.
    pub samples: Range<u64>,
}

/// The networks of one compiled call: pieces of consecutive blocks.
pub type Chunk = Vec<Piece>;

/// Networks in a chunk.
pub fn chunk_len(chunk: &Chunk) -> usize {
    chunk
        .iter()
        .map(|p| (p.samples.end - p.samples.start) as usize)
        .sum()
}

/// Networks per chunk of a call of `total` networks run by `workers`
/// workers (or devices) on a program that holds `capacity` networks:
/// `capacity`, or fewer where `capacity` would leave a worker without a
/// chunk (a cell of 1024 networks on two CPU workers: two chunks of 512,
/// not one of 1024 and an idle core); a multiple of
/// [`crate::NETWORKS_MULTIPLE`]. A chunk of
/// fewer networks than the program holds runs only those (its loops' trip
/// counts are the chunk's), and no result depends on how networks are
/// grouped into chunks.
pub fn per_chunk(capacity: u32, total: u64, workers: usize) -> usize {
    let m = u64::from(crate::NETWORKS_MULTIPLE);
    let spread = total.div_ceil(workers.max(1) as u64).div_ceil(m) * m;
    spread.clamp(m.min(u64::from(capacity)), u64::from(capacity).max(1)) as usize
}

/// `blocks` (in order) cut into chunks of at most `per_call` networks,
/// each filled with the networks of consecutive blocks (a block that does
/// not fit is split between chunks); empty blocks are in no chunk.
pub fn chunks(blocks: &[Range<u64>], per_call: usize) -> Vec<Chunk> {
    let per_call = per_call.max(1) as u64;
    let mut out: Vec<Chunk> = vec![];
    let mut room = 0u64;
    for (b, range) in blocks.iter().enumerate() {
        let mut s = range.start;
        while s < range.end {
            if room == 0 {
                out.push(vec![]);
                room = per_call;
            }
            let e = range.end.min(s + room);
            out.last_mut().expect("pushed").push(Piece {
                block: b,
                samples: s..e,
            });
            room -= e - s;
            s = e;
        }
    }
    out
}

/// The episode results of a chunk's outcome (network-major, `episodes`
/// per network, networks in chunk order) for the cell `plan`, up to the
/// first episode that failed (a fault bit, or a total that is not finite
/// or beyond ±1e100), with that failure. With [`NonFinite::End`], an
/// episode with fault bits after at least one step ended there (the
/// compiled episode stopped at its first value that was not finite): it is
/// flagged, not failed.
pub fn results(
    plan: &CellPlan,
    chunk: &Chunk,
    o: &Outcome,
) -> (Vec<EpisodeResult>, Option<SampleError>) {
    let samples = chunk.iter().flat_map(|p| p.samples.clone());
    let e = plan.episodes as usize;
    let end = plan.non_finite == NonFinite::End;
    let mut out = Vec::with_capacity(o.returns.len());
    for (k, sample) in samples.enumerate() {
        for episode in 0..e {
            let i = k * e + episode;
            let (score, steps, fault) = (o.returns[i], o.lengths[i], o.faults[i]);
            let r = match (fault, end) {
                (0, _) => EpisodeResult::finished(score, steps),
                (_, true) if steps > 0 => EpisodeResult::finished(score, steps)
                    .map(|r| EpisodeResult::cut(r.score, r.steps)),
                (_, true) => Err(EnvError::Other(format!(
                    "{} (after its reset: an env that cannot start an episode fails it, \
                     whatever non_finite says)",
                    fault_text(fault, 0, true)
                ))),
                (_, false) => Err(EnvError::Other(with_end_hint(&fault_text(
                    fault, steps, false,
                )))),
            };
            match r {
                Ok(r) => out.push(r),
                Err(error) => {
                    let failure = SampleError {
                        env: plan.env_id.clone(),
                        sample,
                        episode: episode as u32,
                        step: steps,
                        error,
                    };
                    return (out, Some(failure));
                }
            }
        }
    }
    (out, None)
}

/// What a fault byte says; `exact`: the episode stopped at the value, so
/// `steps` says where.
fn fault_text(fault: u8, steps: u32, exact: bool) -> String {
    let mut what = vec![];
    if fault & FAULT_OBS != 0 {
        what.push("an observation");
    }
    if fault & FAULT_REWARD != 0 {
        what.push("a reward");
    }
    if fault & FAULT_RETURN != 0 {
        what.push("the return (beyond ±1e100)");
    }
    if what.is_empty() {
        what.push("a value (unknown fault bits)");
    }
    let verb = if what.len() > 1 { "were" } else { "was" };
    let when = if exact {
        format!("at step {steps}")
    } else {
        format!(
            "in this episode, which ran {steps} steps (the compiled episode does not say at \
             which step)"
        )
    };
    format!(
        "{} {verb} not finite (NaN or infinite) {when}; the env computes non-finite values for \
         this network: fix the env, or bound its observations and rewards",
        what.join(" and ")
    )
}

/// The blocks being put together from chunks' results, handed out in order.
pub struct Assembly<'a> {
    blocks: &'a [Range<u64>],
    episodes: usize,
    /// Results so far of the blocks from `next` on (index - next).
    filling: Vec<Vec<EpisodeResult>>,
    next: usize,
}

impl<'a> Assembly<'a> {
    /// Nothing put together yet of `blocks`.
    pub fn new(blocks: &'a [Range<u64>], episodes: u32) -> Self {
        Assembly {
            blocks,
            episodes: episodes as usize,
            filling: vec![],
            next: 0,
        }
    }

    fn block_len(&self, b: usize) -> usize {
        let r = &self.blocks[b];
        (r.end - r.start) as usize * self.episodes
    }

    /// Adds the next results (those of the networks after the ones added
    /// before, in block order), then hands every finished block to
    /// `on_block`, in order.
    pub fn add<X>(
        &mut self,
        mut results: &[EpisodeResult],
        on_block: &mut impl FnMut(BlockResult) -> Result<(), X>,
    ) -> Result<(), X> {
        loop {
            while self.next < self.blocks.len() && self.block_len(self.next) == 0 {
                self.done(0, on_block)?; // an empty block
            }
            if results.is_empty() || self.next >= self.blocks.len() {
                return Ok(());
            }
            if self.filling.is_empty() {
                self.filling
                    .push(Vec::with_capacity(self.block_len(self.next)));
            }
            let need = self.block_len(self.next) - self.filling[0].len();
            let take = need.min(results.len());
            self.filling[0].extend_from_slice(&results[..take]);
            results = &results[take..];
            if take == need {
                self.done(1, on_block)?;
            }
        }
    }

    /// Hands block `next` to `on_block` (its results the first `had` of
    /// `filling`).
    fn done<X>(
        &mut self,
        had: usize,
        on_block: &mut impl FnMut(BlockResult) -> Result<(), X>,
    ) -> Result<(), X> {
        let episodes = if had == 1 {
            self.filling.remove(0)
        } else {
            vec![]
        };
        let samples = self.blocks[self.next].clone();
        self.next += 1;
        on_block(BlockResult { samples, episodes })
    }

    /// Whether every block was handed out.
    pub fn finished(&self) -> bool {
        self.next >= self.blocks.len()
    }
}

#[cfg(test)]
#[expect(
    clippy::single_range_in_vec_init,
    reason = "one block of networks is meant"
)]
mod tests {
    use super::*;

    fn er(score: f64) -> EpisodeResult {
        EpisodeResult {
            score,
            steps: 1,
            non_finite: false,
        }
    }

    #[test]
    fn a_chunk_is_smaller_than_the_program_where_a_worker_would_idle() {
        // the program's capacity when there is work enough for every worker
        assert_eq!(per_chunk(6528, 100_000, 2), 6528);
        assert_eq!(per_chunk(1664, 5000, 1), 1664);
        // one worker: one call of all the networks either way
        assert_eq!(per_chunk(1664, 1000, 1), 1024);
        // a cell of one program's worth or less: spread over the workers
        assert_eq!(per_chunk(6528, 1024, 2), 512);
        assert_eq!(per_chunk(6528, 100, 2), 64);
        assert_eq!(per_chunk(6528, 6528, 2), 3264);
        // never below one multiple, never above the capacity
        assert_eq!(per_chunk(6528, 1, 4), 32);
        assert_eq!(per_chunk(32, 10_000, 8), 32);
        assert_eq!(per_chunk(6528, 0, 2), 32);
        for (cap, total, workers) in [(6528, 1024, 2), (1664, 5000, 3), (64, 1000, 16)] {
            let n = per_chunk(cap, total, workers);
            let calls = chunks(&[0..total], n).len();
            assert!(
                calls >= workers.min(total.div_ceil(32) as usize),
                "{n} {calls}"
            );
            assert!(n as u32 <= cap && n.is_multiple_of(32));
        }
    }

    #[test]
    fn chunks_fill_with_consecutive_blocks_and_split_what_does_not_fit() {
        let c = chunks(&[0..3, 3..3, 10..14, 20..21], 4);
        let p = |block, samples| Piece { block, samples };
        assert_eq!(
            c,
            vec![
                vec![p(0, 0..3), p(2, 10..11)],
                vec![p(2, 11..14), p(3, 20..21)],
            ]
        );
        assert!(c.iter().all(|c| chunk_len(c) <= 4));
        assert_eq!(chunks(&[0..9], 4).len(), 3);
        assert!(chunks(&[], 4).is_empty());
    }

    #[test]
    fn blocks_come_out_whole_and_in_order_whatever_the_chunking() {
        let blocks = [0..2, 2..2, 5..8, 8..9];
        for per_call in 1..6 {
            let mut got = vec![];
            let mut a = Assembly::new(&blocks, 2);
            let mut sink = |b: BlockResult| -> Result<(), ()> {
                got.push(b);
                Ok(())
            };
            let mut next = 0.0;
            for c in chunks(&blocks, per_call) {
                let rs: Vec<EpisodeResult> = (0..2 * chunk_len(&c))
                    .map(|_| {
                        next += 1.0;
                        er(next)
                    })
                    .collect();
                a.add(&rs, &mut sink).unwrap();
            }
            assert!(a.finished());
            let samples: Vec<_> = got.iter().map(|b| b.samples.clone()).collect();
            assert_eq!(samples, blocks, "per_call {per_call}");
            let scores: Vec<f64> = got
                .iter()
                .flat_map(|b| b.episodes.iter().map(|e| e.score))
                .collect();
            assert_eq!(scores, (1..=12).map(f64::from).collect::<Vec<_>>());
        }
    }

    #[test]
    fn the_first_fault_names_its_network_and_episode_and_ends_the_results() {
        let chunk = vec![
            Piece {
                block: 0,
                samples: 4..5,
            },
            Piece {
                block: 1,
                samples: 9..11,
            },
        ];
        let o = Outcome {
            returns: vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
            lengths: vec![1, 2, 3, 4, 5, 6],
            faults: vec![0, 0, 0, FAULT_REWARD, FAULT_OBS, 0],
        };
        let (ok, err) = results(&plan(NonFinite::Stop), &chunk, &o);
        assert_eq!(ok.len(), 3);
        let err = err.unwrap();
        assert_eq!((err.sample, err.episode, err.step), (9, 1, 4));
        assert!(err.to_string().contains("a reward was not finite"), "{err}");
        assert!(err.to_string().contains("non_finite = \"end\""), "{err}");
        let clean = Outcome {
            faults: vec![0; 6],
            ..o.clone()
        };
        let (ok, err) = results(&plan(NonFinite::Stop), &chunk, &clean);
        assert_eq!((ok.len(), err), (6, None));
        // with end: the faulty episodes are flagged, not failed ...
        let (ok, err) = results(&plan(NonFinite::End), &chunk, &o);
        assert_eq!(err, None);
        let flags: Vec<bool> = ok.iter().map(|r| r.non_finite).collect();
        assert_eq!(flags, [false, false, false, true, true, false]);
        assert_eq!(ok[3], EpisodeResult::cut(4.0, 4));
        // ... but one at its reset (0 steps) still fails
        let reset = Outcome {
            lengths: vec![1, 2, 3, 0, 5, 6],
            ..o
        };
        let (ok, err) = results(&plan(NonFinite::End), &chunk, &reset);
        assert_eq!(ok.len(), 3);
        assert!(err.unwrap().to_string().contains("after its reset"));
    }

    fn plan(non_finite: NonFinite) -> CellPlan {
        CellPlan {
            seed: 0,
            env_id: "CartPole-v1".into(),
            arch: rwg_core::policy::Architecture {
                hidden: vec![],
                bias: false,
            },
            episodes: 2,
            dist: rwg_core::sampler::WeightDist::Normal { std: 1.0 },
            policy: rwg_core::policy::PolicyKind::Network,
            non_finite,
        }
    }
}
