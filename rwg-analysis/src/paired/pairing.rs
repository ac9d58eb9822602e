//! Which cells a paired comparison puts side by side, and whether network
//! `n` is the same network in both.

use crate::plot::panels::tick;
use rwg_study::rundir::data::CellData;
use rwg_study::rundir::meta::RunMeta;

/// One side of a paired comparison: an env of a run, with its cells (one
/// per architecture × bias setting).
#[derive(Debug, Clone)]
pub struct PairSide {
    /// Label of the run in tables and legends.
    pub run: String,
    /// The run's `run.json`.
    pub meta: RunMeta,
    /// The env compared.
    pub env: String,
    /// The env's cells in the run, in `run.json` order.
    pub cells: Vec<CellData>,
}

/// Two cells of one architecture × bias setting, one from each side.
#[derive(Debug, Clone, Copy)]
pub struct CellPair<'a> {
    /// The first side's cell.
    pub a: &'a CellData,
    /// The second side's cell.
    pub b: &'a CellData,
}

/// The cells of `a` and `b` with the same architecture (name and hidden
/// layers) and bias setting, in `a`'s order.
pub fn cell_pairs<'a>(a: &'a PairSide, b: &'a PairSide) -> Vec<CellPair<'a>> {
    a.cells
        .iter()
        .filter_map(|ca| {
            let ia = &ca.meta.id;
            b.cells
                .iter()
                .find(|cb| {
                    let ib = &cb.meta.id;
                    ib.arch == ia.arch && ib.hidden == ia.hidden && ib.bias == ia.bias
                })
                .map(|cb| CellPair { a: ca, b: cb })
        })
        .collect()
}

/// Why network `n` of the two cells is not one network, or `None` when it
/// is: the same manifest seed, seed id ([`rwg_study::cells::seed_id`]),
/// weight distribution and scale, architecture, bias and network shape
/// (observation length and weight count) give the same weights
/// (the seeds of `rwg_core::plan`).
pub fn not_same_networks(a: &PairSide, b: &PairSide, pair: CellPair) -> Option<String> {
    let (ma, mb) = (&a.meta, &b.meta);
    let (ca, cb) = (&pair.a.meta, &pair.b.meta);
    if ma.seed != mb.seed {
        return Some(format!(
            "the manifest seeds differ ({} and {})",
            ma.seed, mb.seed
        ));
    }
    let (sa, sb) = (
        rwg_study::cells::seed_id(&a.env),
        rwg_study::cells::seed_id(&b.env),
    );
    if sa != sb {
        return Some(format!("the seed ids differ ({sa} and {sb})"));
    }
    if ma.weights != mb.weights {
        return Some(format!(
            "the weight distributions differ ({} {} and {} {})",
            ma.weights.distribution,
            tick(&ma.weights.scale),
            mb.weights.distribution,
            tick(&mb.weights.scale)
        ));
    }
    if (ca.obs_dim, ca.n_weights) != (cb.obs_dim, cb.n_weights) {
        return Some(format!(
            "the networks differ in shape ({} inputs and {} weights against {} and {})",
            ca.obs_dim, ca.n_weights, cb.obs_dim, cb.n_weights
        ));
    }
    None
}

/// What makes the two cells' means incomparable as samples of one
/// benchmark: a different number of episodes per network (the means of
/// fewer episodes spread more). Empty when there is nothing.
pub fn pair_differences(pair: CellPair) -> Vec<String> {
    let (ea, eb) = (pair.a.episodes, pair.b.episodes);
    if ea != eb {
        vec![format!(
            "{}: episodes per network differ ({ea} and {eb}), so the means spread differently",
            pair.a.meta.id.arch
        )]
    } else {
        vec![]
    }
}
