//! [`LaneClock`]: the host's time limit over the lanes of a batch or vector
//! env, as [`TimeLimit`](rwg_env::TimeLimit) applies it to one instance,
//! at one counter update per call in the common case.

/// Each lane's step count, kept as `clock - base[i]`: `clock` counts step
/// calls, and a lane that does not step in one has its `base` moved up, so
/// a call in which every lane steps updates one counter, not one per lane.
#[derive(Debug)]
pub(super) struct LaneClock {
    clock: u64,
    base: Vec<u64>,
    /// At least the steps of every lane's episode: the lanes are compared
    /// with the time limit only when this reaches it.
    elapsed_bound: u64,
    max_steps: u32,
}

impl LaneClock {
    /// Clocks of `lanes` lanes under a limit of `max_steps` steps.
    pub(super) fn new(lanes: usize, max_steps: u32) -> Self {
        LaneClock {
            clock: 0,
            base: vec![0; lanes],
            elapsed_bound: 0,
            max_steps,
        }
    }

    /// Lane `i` starts an episode.
    #[inline]
    pub(super) fn start(&mut self, i: usize) {
        self.base[i] = self.clock;
    }

    /// After a step call in which the lanes of `mask` stepped and the others
    /// did not (`every`: `mask` is all ones): `truncated` set on those whose
    /// episode reached the limit.
    #[inline]
    pub(super) fn stepped(&mut self, mask: &[u8], every: bool, truncated: &mut [u8]) {
        self.clock += 1;
        if !every {
            // The lanes not stepped keep their count.
            for (b, &m) in self.base.iter_mut().zip(mask) {
                *b += u64::from(m != 1);
            }
        }
        self.elapsed_bound += 1;
        if self.elapsed_bound >= u64::from(self.max_steps) {
            self.time_limit(mask, truncated);
        }
    }

    /// Sets `truncated` on the lanes of `mask` whose episode reached the
    /// limit, and recomputes the bound.
    #[cold]
    #[inline(never)]
    fn time_limit(&mut self, mask: &[u8], truncated: &mut [u8]) {
        let max = u64::from(self.max_steps);
        let mut bound = 0;
        for ((&b, t), &m) in self.base.iter().zip(truncated).zip(mask) {
            let elapsed = self.clock - b;
            if m == 1 && elapsed >= max {
                *t = 1;
            }
            bound = bound.max(elapsed);
        }
        self.elapsed_bound = bound;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_lane_is_truncated_at_its_own_step_count() {
        let mut c = LaneClock::new(3, 3);
        (0..3).for_each(|i| c.start(i));
        let mut t = [0u8; 3];
        c.stepped(&[1, 1, 1], true, &mut t);
        // Lane 1 sits out a step, lane 2 starts over.
        c.stepped(&[1, 0, 1], false, &mut t);
        c.start(2);
        assert_eq!(t, [0, 0, 0]);
        c.stepped(&[1, 1, 1], true, &mut t);
        assert_eq!(t, [1, 0, 0]);
        let mut t = [0u8; 3];
        c.stepped(&[0, 1, 1], false, &mut t);
        assert_eq!(t, [0, 1, 0]);
        let mut t = [0u8; 3];
        c.stepped(&[0, 0, 1], false, &mut t);
        assert_eq!(t, [0, 0, 1]);
    }
}
