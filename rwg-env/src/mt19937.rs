//! The Mersenne Twister MT19937 behind numpy's legacy `np.random.RandomState`.
//!
//! gym 0.17.2 seeded its environments with a `RandomState` (see
//! [`crate::seeding::gym_np_random`]); this reproduces its `seed`,
//! `random_sample` and `uniform` bit for bit.
//!
//! Why not the `rand_mt` crate: its words equal these for `init_genrand`
//! and for `init_by_array` keys of up to 624 words (tested below), but for
//! longer keys it differs from numpy's `init_by_array`, which runs
//! `max(624, key length)` mixing steps (rand_mt 6.1 gives the same state for
//! a 625-word key as for a 700-word one); and it would add a crate to every
//! plugin's build of `rwg-env` for 60 lines that numpy pins down exactly.

const N: usize = 624;
const M: usize = 397;
const MATRIX_A: u32 = 0x9908_b0df;
const UPPER_MASK: u32 = 0x8000_0000;
const LOWER_MASK: u32 = 0x7fff_ffff;

/// MT19937 with numpy's `RandomState` seeding and double generation.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Mt19937 {
    key: [u32; N],
    pos: usize,
}

impl Mt19937 {
    /// `RandomState(seed)` for an integer seed in `0..2**32` (`init_genrand`).
    pub fn new(seed: u32) -> Self {
        Mt19937 {
            key: genrand_key(seed),
            pos: N,
        }
    }

    /// `RandomState(list)` for a non-empty list of 32-bit words
    /// (`init_by_array`).
    ///
    /// # Panics
    /// If `init_key` is empty (numpy raises `ValueError` there).
    pub fn from_key(init_key: &[u32]) -> Self {
        assert!(!init_key.is_empty(), "MT19937 seed key must not be empty");
        let mut g = Mt19937 {
            key: GENRAND_19650218,
            pos: N,
        };
        let mt = &mut g.key;
        let (mut i, mut j) = (1usize, 0usize);
        for _ in 0..N.max(init_key.len()) {
            mt[i] = (mt[i] ^ (mt[i - 1] ^ (mt[i - 1] >> 30)).wrapping_mul(1_664_525))
                .wrapping_add(init_key[j])
                .wrapping_add(j as u32);
            i += 1;
            j += 1;
            if i >= N {
                mt[0] = mt[N - 1];
                i = 1;
            }
            if j >= init_key.len() {
                j = 0;
            }
        }
        for _ in 0..N - 1 {
            mt[i] = (mt[i] ^ (mt[i - 1] ^ (mt[i - 1] >> 30)).wrapping_mul(1_566_083_941))
                .wrapping_sub(i as u32);
            i += 1;
            if i >= N {
                mt[0] = mt[N - 1];
                i = 1;
            }
        }
        mt[0] = 0x8000_0000;
        g.pos = N;
        g
    }

    /// Regenerates the whole key (the twist).
    fn generate(&mut self) {
        let mt = &mut self.key;
        for k in 0..N - M {
            mt[k] = twist(mt[k], mt[k + 1], mt[k + M]);
        }
        for k in N - M..N - 1 {
            mt[k] = twist(mt[k], mt[k + 1], mt[k + M - N]);
        }
        mt[N - 1] = twist(mt[N - 1], mt[0], mt[M - 1]);
        self.pos = 0;
    }

    /// The next tempered 32-bit output (`genrand_int32`).
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        if self.pos >= N {
            self.generate();
        }
        let y = self.key[self.pos];
        self.pos += 1;
        temper(y)
    }

    /// `random_sample()`: a 53-bit double in [0, 1) made of two outputs
    /// (`genrand_res53`): `((a >> 5) * 2^26 + (b >> 6)) / 2^53`.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        let a = self.next_u32();
        res53(a, self.next_u32())
    }

    /// `RandomState.uniform(low, high)`: `low + (high - low) * random_sample()`.
    #[inline]
    pub fn uniform(&mut self, low: f64, high: f64) -> f64 {
        uniform_res53(low, high, self.next_u32(), self.next_u32())
    }
}

/// `init_genrand(seed)`'s state.
const fn genrand_key(seed: u32) -> [u32; N] {
    let mut key = [0u32; N];
    let mut s = seed;
    let mut i = 0;
    while i < N {
        key[i] = s;
        s = 1_812_433_253u32
            .wrapping_mul(s ^ (s >> 30))
            .wrapping_add(i as u32 + 1);
        i += 1;
    }
    key
}

/// `init_genrand(19650218)`, where every `init_by_array` starts: computed
/// once, at compile time.
const GENRAND_19650218: [u32; N] = genrand_key(19_650_218);

/// One word of the twist from the words `k`, `k + 1` and `k + M` of the
/// state.
#[inline(always)]
fn twist(a: u32, b: u32, c: u32) -> u32 {
    let y = (a & UPPER_MASK) | (b & LOWER_MASK);
    c ^ (y >> 1) ^ if y & 1 != 0 { MATRIX_A } else { 0 }
}

/// The tempering of `genrand_int32`.
#[inline(always)]
fn temper(mut y: u32) -> u32 {
    y ^= y >> 11;
    y ^= (y << 7) & 0x9d2c_5680;
    y ^= (y << 15) & 0xefc6_0000;
    y ^ (y >> 18)
}

/// `genrand_res53` of the outputs `a` then `b`: `((a >> 5) * 2^26 + (b >> 6)) / 2^53`.
#[inline(always)]
fn res53(a: u32, b: u32) -> f64 {
    let a = (a >> 5) as f64;
    let b = (b >> 6) as f64;
    (a * 67_108_864.0 + b) / 9_007_199_254_740_992.0
}

/// `RandomState.uniform(low, high)` made of the outputs `a` then `b`:
/// `low + (high - low) * random_sample()`.
#[inline(always)]
pub fn uniform_res53(low: f64, high: f64, a: u32, b: u32) -> f64 {
    low + (high - low) * res53(a, b)
}

/// The first `W` outputs (`genrand_int32`) of `RandomState(key)` for `L`
/// keys of one or two words at once: lane `l`'s key is `keys[l][0]` if
/// `two[l]` is false, else `keys[l]`. The same words as
/// [`Mt19937::from_key`] then `W` calls of [`Mt19937::next_u32`].
///
/// `init_by_array` is a chain of about 1250 dependent multiply-xor steps
/// per key; here the `L` chains advance together (the state is held lane by
/// lane, so each step is one vector operation over the lanes), and only the
/// `W` words asked for are twisted (`W <= 227`, so they need only words of
/// the seeded state).
pub fn first_outputs_lanes<const L: usize, const W: usize>(
    keys: &[[u32; 2]; L],
    two: &[bool; L],
) -> [[u32; W]; L] {
    const { assert!(W <= N - M, "at most N - M words") };
    let mut mt = [[0u32; L]; N];
    for (row, &b) in mt.iter_mut().zip(&GENRAND_19650218) {
        *row = [b; L];
    }
    // Step t of the first loop adds key[j] + j, j = t mod (key length).
    let mut add = [[0u32; L]; 2];
    for l in 0..L {
        add[0][l] = keys[l][0];
        add[1][l] = if two[l] {
            keys[l][1].wrapping_add(1)
        } else {
            keys[l][0]
        };
    }
    let mut i = 1;
    for t in 0..N {
        let prev = mt[i - 1];
        let a = &add[t & 1];
        let cur = &mut mt[i];
        for l in 0..L {
            cur[l] =
                (cur[l] ^ (prev[l] ^ (prev[l] >> 30)).wrapping_mul(1_664_525)).wrapping_add(a[l]);
        }
        i += 1;
        if i >= N {
            mt[0] = mt[N - 1];
            i = 1;
        }
    }
    for _ in 0..N - 1 {
        let prev = mt[i - 1];
        let cur = &mut mt[i];
        for l in 0..L {
            cur[l] = (cur[l] ^ (prev[l] ^ (prev[l] >> 30)).wrapping_mul(1_566_083_941))
                .wrapping_sub(i as u32);
        }
        i += 1;
        if i >= N {
            mt[0] = mt[N - 1];
            i = 1;
        }
    }
    mt[0] = [0x8000_0000; L];
    let mut out = [[0u32; W]; L];
    for k in 0..W {
        for l in 0..L {
            out[l][k] = temper(twist(mt[k][l], mt[k + 1][l], mt[k + M][l]));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `rand_mt` crate (a dev-dependency only) gives the same words for
    /// `init_genrand` and `init_by_array` seeding with keys of up to 624
    /// words, across several twists (see the module docs for longer keys).
    #[test]
    fn same_bits_as_the_rand_mt_crate() {
        for seed in [0u32, 1, 5489, 0xdead_beef, u32::MAX] {
            let mut ours = Mt19937::new(seed);
            let mut theirs = rand_mt::Mt::new(seed);
            for i in 0..2000 {
                assert_eq!(ours.next_u32(), theirs.next_u32(), "seed {seed}, word {i}");
            }
        }
        let long: Vec<u32> = (0..700u32).map(|i| i.wrapping_mul(2_654_435_761)).collect();
        for key in [
            &[0u32][..],
            &[1, 2],
            &[0x123, 0x234, 0x345, 0x456],
            &long[..624],
        ] {
            let mut ours = Mt19937::from_key(key);
            let mut theirs = rand_mt::Mt::new_with_key(key.iter().copied());
            for i in 0..2000 {
                assert_eq!(
                    ours.next_u32(),
                    theirs.next_u32(),
                    "key of {} words, word {i}",
                    key.len()
                );
            }
        }
    }

    // np.random.RandomState(5489).randint(0, 2**32, size=3, dtype=np.uint32)
    // (also the reference MT19937 output for the default seed).
    #[test]
    fn int_seed_matches_numpy() {
        let mut g = Mt19937::new(5489);
        let v: Vec<u32> = (0..3).map(|_| g.next_u32()).collect();
        assert_eq!(v, [3499211612, 581869302, 3890346734]);
    }

    // np.random.RandomState([547404849, 309914516]): get_state() key, the
    // first raw outputs, then random_sample().
    #[test]
    fn key_seed_matches_numpy() {
        let g = Mt19937::from_key(&[547404849, 309914516]);
        assert_eq!(&g.key[..3], &[2147483648, 2629026387, 2478113671]);
        assert_eq!(g.key[623], 196887160);
        let mut g = g;
        let v: Vec<u32> = (0..3).map(|_| g.next_u32()).collect();
        assert_eq!(v, [233474672, 1047681358, 4146322502]);
        assert_eq!(g.next_f64(), 0.2284548404268245);
    }

    /// The lanes give `from_key`'s first outputs, for keys of one and two
    /// words mixed in one call.
    #[test]
    fn first_outputs_lanes_match_from_key() {
        let mut s: u64 = 0x1234_5678_9abc_def0;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 32) as u32
        };
        for round in 0..200 {
            let mut keys = [[0u32; 2]; 16];
            let mut two = [false; 16];
            for l in 0..16 {
                keys[l] = [next(), next()];
                two[l] = (round + l) % 3 != 0;
            }
            if round == 0 {
                keys[0] = [0, 0];
                keys[1] = [u32::MAX, u32::MAX];
            }
            let got: [[u32; 227]; 16] = first_outputs_lanes(&keys, &two);
            for l in 0..16 {
                let key = if two[l] { &keys[l][..] } else { &keys[l][..1] };
                let mut g = Mt19937::from_key(key);
                for (k, &w) in got[l].iter().enumerate() {
                    assert_eq!(w, g.next_u32(), "key {key:?}, word {k}");
                }
            }
        }
        // np.random.RandomState([547404849, 309914516]) as above.
        let got: [[u32; 3]; 1] = first_outputs_lanes(&[[547404849, 309914516]], &[true]);
        assert_eq!(got[0], [233474672, 1047681358, 4146322502]);
    }

    #[test]
    fn short_and_long_keys_match_numpy() {
        // np.random.RandomState([0])
        let mut g = Mt19937::from_key(&[0]);
        assert_eq!([g.next_u32(), g.next_u32()], [3626764237, 1654615998]);
        // np.random.RandomState([123]).random_sample() twice
        let mut g = Mt19937::from_key(&[123]);
        assert_eq!(g.next_f64(), 0.052363598850944326);
        assert_eq!(g.next_f64(), 0.08718667752263232);
        // np.random.RandomState(list(range(1000))): a key longer than the
        // state; the 700th random_sample crosses two twists.
        let key: Vec<u32> = (0..1000).collect();
        let mut g = Mt19937::from_key(&key);
        assert_eq!([g.next_u32(), g.next_u32()], [4012946933, 3615799318]);
        let mut g = Mt19937::from_key(&key);
        let x = (0..700).map(|_| g.next_f64()).last().unwrap();
        assert_eq!(x, 0.04907009344695634);
    }
}
