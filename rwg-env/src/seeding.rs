//! numpy-exact random numbers: `SeedSequence`, `PCG64` and `Generator.uniform`.
//!
//! Gymnasium's `env.reset(seed=s)` builds
//! `np.random.Generator(np.random.PCG64(np.random.SeedSequence(s)))` and draws
//! the initial state with `uniform`. This module reproduces those bits, so an
//! rwg episode can be replayed in Python from its seed.
//!
//! gym 0.17.2 (Pendulum-v0) seeded differently: [`gym_np_random`] reproduces
//! its `seeding.np_random`, a SHA-512-hashed seed fed to an MT19937
//! `RandomState`.

use crate::mt19937::Mt19937;
use crate::sha512::sha512;

const MASK32: u64 = 0xFFFF_FFFF;

/// The 32-bit words numpy makes of a non-negative integer: little-endian, at
/// least one word (`0` gives `[0]`).
pub fn int_to_words(mut n: u64, out: &mut Vec<u32>) {
    loop {
        out.push((n & MASK32) as u32);
        n >>= 32;
        if n == 0 {
            break;
        }
    }
}

/// `numpy.random.SeedSequence` with the default pool size of 4 words.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SeedSequence {
    pool: [u32; 4],
}

const INIT_A: u32 = 0x43b0_d7e5;
const MULT_A: u32 = 0x931e_8875;
const INIT_B: u32 = 0x8b51_f9dd;
const MULT_B: u32 = 0x58f3_8ded;
const MIX_MULT_L: u32 = 0xca01_f9dd;
const MIX_MULT_R: u32 = 0x4973_f715;

impl SeedSequence {
    /// `SeedSequence(s)` for an integer seed.
    pub fn new(seed: u64) -> Self {
        // int_to_words without a Vec: resets call this once per episode.
        let words = [seed as u32, (seed >> 32) as u32];
        let n = if words[1] == 0 { 1 } else { 2 };
        Self::from_words(&words[..n])
    }

    /// `SeedSequence([a, b, ...])` for a list of integers.
    pub fn from_ints(ints: &[u64]) -> Self {
        let mut w = Vec::with_capacity(ints.len() * 2);
        for &i in ints {
            int_to_words(i, &mut w);
        }
        Self::from_words(&w)
    }

    /// A sequence from its entropy as 32-bit words (numpy's coerced entropy).
    pub fn from_words(entropy: &[u32]) -> Self {
        let mut hash_const = INIT_A;
        let mut hashmix = |v: u32| -> u32 {
            let mut v = v ^ hash_const;
            hash_const = hash_const.wrapping_mul(MULT_A);
            v = v.wrapping_mul(hash_const);
            v ^ (v >> 16)
        };
        let mix = |x: u32, y: u32| -> u32 {
            let r = MIX_MULT_L
                .wrapping_mul(x)
                .wrapping_sub(MIX_MULT_R.wrapping_mul(y));
            r ^ (r >> 16)
        };
        let mut pool = [0u32; 4];
        for (i, p) in pool.iter_mut().enumerate() {
            *p = hashmix(entropy.get(i).copied().unwrap_or(0));
        }
        for i_src in 0..4 {
            for i_dst in 0..4 {
                if i_src != i_dst {
                    let h = hashmix(pool[i_src]);
                    pool[i_dst] = mix(pool[i_dst], h);
                }
            }
        }
        for &e in entropy.iter().skip(4) {
            for p in pool.iter_mut() {
                let h = hashmix(e);
                *p = mix(*p, h);
            }
        }
        SeedSequence { pool }
    }

    /// `generate_state(n, np.uint32)`.
    pub fn generate_u32(&self, out: &mut [u32]) {
        let mut hash_const = INIT_B;
        for (i, o) in out.iter_mut().enumerate() {
            let mut v = self.pool[i % 4] ^ hash_const;
            hash_const = hash_const.wrapping_mul(MULT_B);
            v = v.wrapping_mul(hash_const);
            *o = v ^ (v >> 16);
        }
    }

    /// `generate_state(N, np.uint64)`: pairs of words, low word first.
    pub fn generate_u64<const N: usize>(&self) -> [u64; N] {
        let mut words = [0u32; 64];
        assert!(2 * N <= words.len());
        self.generate_u32(&mut words[..2 * N]);
        let mut out = [0u64; N];
        for (i, o) in out.iter_mut().enumerate() {
            *o = words[2 * i] as u64 | ((words[2 * i + 1] as u64) << 32);
        }
        out
    }
}

/// numpy's `PCG64` bit generator (128-bit LCG, XSL-RR output).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Pcg64 {
    state: u128,
    inc: u128,
}

const PCG_MULT: u128 = 0x2360_ED05_1FC6_5DA4_4385_DF64_9FCC_F645;

impl Pcg64 {
    /// `PCG64(SeedSequence(seed))`.
    pub fn from_seed(seed: u64) -> Self {
        Self::from_seed_sequence(&SeedSequence::new(seed))
    }

    /// `PCG64(seed_sequence)`.
    pub fn from_seed_sequence(ss: &SeedSequence) -> Self {
        let v: [u64; 4] = ss.generate_u64();
        let initstate = ((v[0] as u128) << 64) | v[1] as u128;
        let initseq = ((v[2] as u128) << 64) | v[3] as u128;
        let mut g = Pcg64 {
            state: 0,
            inc: (initseq << 1) | 1,
        };
        g.advance();
        g.state = g.state.wrapping_add(initstate);
        g.advance();
        g
    }

    #[inline(always)]
    fn advance(&mut self) {
        self.state = self.state.wrapping_mul(PCG_MULT).wrapping_add(self.inc);
    }

    /// The next 64 random bits.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.advance();
        let s = self.state;
        let x = ((s >> 64) as u64) ^ (s as u64);
        x.rotate_right((s >> 122) as u32)
    }

    /// A double in [0, 1): `(next_u64 >> 11) * 2^-53`.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / 9_007_199_254_740_992.0)
    }

    /// `Generator.uniform(low, high)`: `low + (high - low) * next_f64()`.
    #[inline]
    pub fn uniform(&mut self, low: f64, high: f64) -> f64 {
        low + (high - low) * self.next_f64()
    }
}

/// gym 0.17.2's `seeding.hash_seed(seed)`: the first 8 bytes of
/// SHA-512(`str(seed)`), read as a little-endian integer (gym's
/// `_bigint_from_bytes` packs them into little-endian 32-bit words).
///
/// gym first applies `create_seed`, which reduces an integer modulo 2^64; a
/// `u64` is already reduced.
pub fn gym_hash_seed(seed: u64) -> u64 {
    // str(seed): decimal digits, no allocation.
    let mut buf = [0u8; 20];
    let mut start = buf.len();
    let mut n = seed;
    loop {
        start -= 1;
        buf[start] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    let digest = sha512(&buf[start..]);
    u64::from_le_bytes(digest[..8].try_into().unwrap())
}

/// gym 0.17.2's `seeding.np_random(seed)`: a `np.random.RandomState` seeded
/// with `_int_list_from_bigint(hash_seed(seed))`, the little-endian 32-bit
/// words of the hash without leading zero words (`[0]` for 0).
pub fn gym_np_random(seed: u64) -> Mt19937 {
    let (words, two) = gym_seed_key(seed);
    Mt19937::from_key(&words[..if two { 2 } else { 1 }])
}

/// The key [`gym_np_random`] seeds its `RandomState` with: the two 32-bit
/// words of the hash and whether the key has both (false: only the first,
/// the hash being below 2^32). For [`crate::mt19937::first_outputs_lanes`].
pub fn gym_seed_key(seed: u64) -> ([u32; 2], bool) {
    let h = gym_hash_seed(seed);
    ([h as u32, (h >> 32) as u32], h >> 32 != 0)
}

impl rand_core::RngCore for Pcg64 {
    fn next_u32(&mut self) -> u32 {
        (Pcg64::next_u64(self) >> 32) as u32
    }
    fn next_u64(&mut self) -> u64 {
        Pcg64::next_u64(self)
    }
    fn fill_bytes(&mut self, dst: &mut [u8]) {
        for chunk in dst.chunks_mut(8) {
            let v = Pcg64::next_u64(self).to_le_bytes();
            chunk.copy_from_slice(&v[..chunk.len()]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // Python: hashlib.sha512(str(s).encode()).digest()[:8], little-endian.
    #[test]
    fn gym_hash_seed_matches_python() {
        assert_eq!(gym_hash_seed(0), 547404849 | (309914516 << 32));
        assert_eq!(gym_hash_seed(9), 3626419469 | (134544068 << 32));
        assert_eq!(
            gym_hash_seed(u64::MAX).to_le_bytes(),
            [0x2b, 0x1d, 0x68, 0x02, 0xdd, 0x9b, 0x3d, 0x7f]
        );
    }

    // gym 0.17.2: env.seed(0); env.reset() on Pendulum-v0, i.e.
    // np.random.RandomState([547404849, 309914516]).uniform([-pi, -1], [pi, 1])
    #[test]
    fn gym_np_random_matches_python() {
        let pi = std::f64::consts::PI;
        let mut g = gym_np_random(0);
        assert_eq!(g.uniform(-pi, pi), -2.8000383468574164);
        assert_eq!(g.uniform(-1.0, 1.0), 0.9307818744846408);
    }

    // Values from numpy 2.x:
    //   np.random.SeedSequence(0).generate_state(4, np.uint32)
    #[test]
    fn seed_sequence_matches_numpy() {
        let mut w = [0u32; 4];
        SeedSequence::new(0).generate_u32(&mut w);
        assert_eq!(w, [2968811710, 3677149159, 745650761, 2884920346]);
    }

    // np.random.default_rng(0).random() and .integers(0, 2**64, dtype=np.uint64)
    #[test]
    fn pcg64_matches_numpy() {
        let mut g = Pcg64::from_seed(0);
        assert_eq!(g.next_f64(), 0.6369616873214543);
        let mut g = Pcg64::from_seed(12345);
        assert_eq!(g.next_f64(), 0.22733602246716966);
    }

    // np.random.SeedSequence([1, 2, 3, 4, 5, 2**40]).generate_state(4, np.uint64)
    #[test]
    fn seed_sequence_new_is_from_ints() {
        for seed in [0, 1, 0xffff_ffff, 1 << 32, 0x1234_5678_9abc_def0, u64::MAX] {
            assert_eq!(SeedSequence::new(seed), SeedSequence::from_ints(&[seed]));
        }
    }

    #[test]
    fn seed_sequence_of_many_words_matches_numpy() {
        let v: [u64; 4] = SeedSequence::from_ints(&[1, 2, 3, 4, 5, 1 << 40]).generate_u64();
        assert_eq!(
            v,
            [
                17338791764930575214,
                14038465141270236929,
                6230264265892525628,
                12801595741120722859
            ]
        );
    }

    #[test]
    fn words_of_ints() {
        let mut w = vec![];
        int_to_words(0, &mut w);
        int_to_words(1 << 32, &mut w);
        assert_eq!(w, [0, 0, 1]);
    }
}
