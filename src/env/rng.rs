//! numpy's randomness, exactly as minigrid 3.2.0 draws a level: `reset(seed=s)` builds
//! `np.random.Generator(np.random.PCG64(np.random.SeedSequence(s)))`, and level generation
//! calls only `integers(low, high)` and `uniform(0, 1)` on it.
//!
//! One draw out of step changes every level after it, so this follows numpy's C code to the
//! bit: SeedSequence's hash pool, PCG64's XSL-RR output (the generator `rand_pcg`'s
//! `Lcg128Xsl64` also implements, but numpy's 32-bit draws differ), the buffered 32-bit draws
//! (a 64-bit draw's high half is kept for the next 32-bit draw, even across 64-bit draws) and
//! Lemire's bounded integers (a range of one value draws nothing). The specification and test
//! vectors are in docs/world.md; `tests/` checks call sequences against numpy itself.

/// PCG64's 128-bit LCG multiplier.
const PCG_MULT: u128 = 0x2360_ed05_1fc6_5da4_4385_df64_9fcc_f645;

const INIT_A: u32 = 0x43b0_d7e5;
const MULT_A: u32 = 0x931e_8875;
const INIT_B: u32 = 0x8b51_f9dd;
const MULT_B: u32 = 0x58f3_8ded;
const MIX_MULT_L: u32 = 0xca01_f9dd;
const MIX_MULT_R: u32 = 0x4973_f715;
const POOL_SIZE: usize = 4;

/// `SeedSequence(seed).generate_state(4, uint64)`: the four words PCG64 is seeded from.
pub fn seed_sequence_state(seed: u64) -> [u64; 4] {
    // The entropy as 32-bit words, least significant first (seed 0 → [0]).
    let entropy: Vec<u32> = if seed >> 32 == 0 {
        vec![seed as u32]
    } else {
        vec![seed as u32, (seed >> 32) as u32]
    };
    let mut hash_const = INIT_A;
    let mut hashmix = |value: u32| -> u32 {
        let mut v = value ^ hash_const;
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
    let mut pool = [0u32; POOL_SIZE];
    for (i, slot) in pool.iter_mut().enumerate() {
        *slot = hashmix(entropy.get(i).copied().unwrap_or(0));
    }
    for src in 0..POOL_SIZE {
        for dst in 0..POOL_SIZE {
            if src != dst {
                let h = hashmix(pool[src]);
                pool[dst] = mix(pool[dst], h);
            }
        }
    }
    // Words past the fourth (never for a u64 seed) would be mixed into all four here.
    let mut hash_b = INIT_B;
    let mut words = [0u32; 8];
    for (i, w) in words.iter_mut().enumerate() {
        let mut v = pool[i % POOL_SIZE] ^ hash_b;
        hash_b = hash_b.wrapping_mul(MULT_B);
        v = v.wrapping_mul(hash_b);
        *w = v ^ (v >> 16);
    }
    std::array::from_fn(|k| u64::from(words[2 * k]) | (u64::from(words[2 * k + 1]) << 32))
}

/// One call of a generator method with its result, for per-call comparisons with Python.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Call {
    /// `integers(low, high)` returned the value.
    Integers(i64, i64, i64),
    /// `uniform(low, high)` returned the value.
    Uniform(f64, f64, f64),
}

/// numpy's `Generator(PCG64(SeedSequence(seed)))`, with the methods level generation uses.
/// Serialises its stream's position (state, increment, buffered half, draw count), not the log:
/// a MiniGrid world whose obstacles draw at every step carries it.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(from = "RngState", into = "RngState")]
pub struct NumpyRng {
    state: u128,
    inc: u128,
    /// The high half of the last 64-bit draw, waiting for the next 32-bit draw.
    buffered: Option<u32>,
    draws: u64,
    log: Option<Vec<Call>>,
}

/// [`NumpyRng`]'s position as four 64-bit halves (JSON numbers hold no 128-bit integer).
#[derive(Clone, serde::Serialize, serde::Deserialize)]
struct RngState {
    state: [u64; 2],
    inc: [u64; 2],
    buffered: Option<u32>,
    draws: u64,
}

impl From<NumpyRng> for RngState {
    fn from(r: NumpyRng) -> Self {
        let halves = |v: u128| [(v >> 64) as u64, v as u64];
        Self {
            state: halves(r.state),
            inc: halves(r.inc),
            buffered: r.buffered,
            draws: r.draws,
        }
    }
}

impl From<RngState> for NumpyRng {
    fn from(s: RngState) -> Self {
        let join = |[hi, lo]: [u64; 2]| (u128::from(hi) << 64) | u128::from(lo);
        Self {
            state: join(s.state),
            // PCG's increment is odd by construction; an even one read from a file is made so.
            inc: join(s.inc) | 1,
            buffered: s.buffered,
            draws: s.draws,
            log: None,
        }
    }
}

impl NumpyRng {
    /// The generator `reset(seed=seed)` builds.
    pub fn new(seed: u64) -> Self {
        let s = seed_sequence_state(seed);
        let initstate = (u128::from(s[0]) << 64) | u128::from(s[1]);
        let initseq = (u128::from(s[2]) << 64) | u128::from(s[3]);
        let mut rng = Self {
            state: 0,
            inc: (initseq << 1) | 1,
            buffered: None,
            draws: 0,
            log: None,
        };
        rng.step();
        rng.state = rng.state.wrapping_add(initstate);
        rng.step();
        rng
    }

    /// Starts recording every `integers` / `uniform` call (see [`Self::take_log`]).
    pub fn record(&mut self) {
        self.log = Some(Vec::new());
    }

    /// The calls recorded since [`Self::record`].
    pub fn take_log(&mut self) -> Vec<Call> {
        self.log.take().unwrap_or_default()
    }

    /// The LCG state and increment (numpy's `bit_generator.state`), for test vectors.
    pub fn state(&self) -> (u128, u128) {
        (self.state, self.inc)
    }

    /// How many calls of `integers` / `uniform` drew at least one number (a diagnostic: it
    /// lets a test say where two streams part).
    pub fn calls(&self) -> u64 {
        self.draws
    }

    #[inline]
    fn step(&mut self) {
        self.state = self.state.wrapping_mul(PCG_MULT).wrapping_add(self.inc);
    }

    /// A raw 64-bit draw: step, then XSL-RR of the new state.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.step();
        let s = self.state;
        let x = ((s >> 64) as u64) ^ (s as u64);
        x.rotate_right((s >> 122) as u32)
    }

    /// numpy's 32-bit draw: the low half of a fresh 64-bit draw, or the kept high half.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        if let Some(v) = self.buffered.take() {
            return v;
        }
        let n = self.next_u64();
        self.buffered = Some((n >> 32) as u32);
        n as u32
    }

    /// `integers(low, high)` (int64, `high` exclusive), Lemire's method as numpy draws it.
    /// `high <= low` is a caller's bug; it returns `low` (numpy raises).
    #[inline]
    pub fn integers(&mut self, low: i64, high: i64) -> i64 {
        let v = self.integers_unlogged(low, high);
        if self.log.is_some() {
            self.log_call(Call::Integers(low, high, v));
        }
        v
    }

    #[cold]
    fn log_call(&mut self, call: Call) {
        if let Some(log) = &mut self.log {
            log.push(call);
        }
    }

    /// Inlined into the rejection loops of level generation, which draw small ranges by the
    /// dozen per level: only the common path (a range below 2³², one draw accepted) is here.
    #[inline]
    fn integers_unlogged(&mut self, low: i64, high: i64) -> i64 {
        if high <= low {
            return low;
        }
        let rng = (high - low - 1) as u64;
        if rng == 0 {
            return low;
        }
        self.draws += 1;
        match u32::try_from(rng) {
            Ok(rng) if rng != u32::MAX => {
                let excl = rng + 1;
                let m = u64::from(self.next_u32()) * u64::from(excl);
                let m = if (m as u32) < excl {
                    self.lemire_u32_retry(m, rng)
                } else {
                    m
                };
                low + (m >> 32) as i64
            }
            _ => self.integers_wide(low, rng),
        }
    }

    /// Lemire's rejection for a 32-bit range whose first product fell in the low band.
    #[cold]
    fn lemire_u32_retry(&mut self, mut m: u64, rng: u32) -> u64 {
        let excl = rng + 1;
        let threshold = (u32::MAX - rng) % excl;
        while (m as u32) < threshold {
            m = u64::from(self.next_u32()) * u64::from(excl);
        }
        m
    }

    /// A range of 2³² values or more: whole 32-bit draws, or Lemire's method on 64 bits.
    #[cold]
    fn integers_wide(&mut self, low: i64, rng: u64) -> i64 {
        if rng == u64::from(u32::MAX) {
            return low + i64::from(self.next_u32());
        }
        if rng == u64::MAX {
            return low.wrapping_add(self.next_u64() as i64);
        }
        let excl = rng + 1;
        let mut m = u128::from(self.next_u64()) * u128::from(excl);
        let mut left = m as u64;
        if left < excl {
            let threshold = (u64::MAX - rng) % excl;
            while left < threshold {
                m = u128::from(self.next_u64()) * u128::from(excl);
                left = m as u64;
            }
        }
        low.wrapping_add((m >> 64) as i64)
    }

    /// `integers(low, high)` for indices and coordinates (`0 <= low < high`).
    #[inline]
    pub fn below(&mut self, low: usize, high: usize) -> usize {
        self.integers(low as i64, high as i64) as usize
    }

    /// numpy's `random_interval(max)`: a value in `0..=max` by masking 32-bit draws (64-bit
    /// ones above 2³² − 1) to the smallest covering power of two and rejecting what exceeds.
    pub fn random_interval(&mut self, max: u64) -> u64 {
        if max == 0 {
            return 0;
        }
        let mut mask = max;
        for shift in [1, 2, 4, 8, 16, 32] {
            mask |= mask >> shift;
        }
        if u32::try_from(max).is_ok() {
            loop {
                let v = u64::from(self.next_u32()) & mask;
                if v <= max {
                    return v;
                }
            }
        }
        loop {
            let v = self.next_u64() & mask;
            if v <= max {
                return v;
            }
        }
    }

    /// `Generator.shuffle(list)` of a Python list: Fisher–Yates from the end, each swap with
    /// `random_interval(i)` (not Lemire's `integers`).
    pub fn shuffle<T>(&mut self, items: &mut [T]) {
        if items.len() > 1 {
            self.draws += 1;
        }
        for i in (1..items.len()).rev() {
            let j = self.random_interval(i as u64) as usize;
            items.swap(i, j);
        }
    }

    /// `uniform(a, b)`: `a + (b − a) · ((next64 >> 11) · 2⁻⁵³)`.
    pub fn uniform(&mut self, a: f64, b: f64) -> f64 {
        self.draws += 1;
        let unit = (self.next_u64() >> 11) as f64 * (1.0 / 9_007_199_254_740_992.0);
        let v = a + (b - a) * unit;
        if self.log.is_some() {
            self.log_call(Call::Uniform(a, b, v));
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// numpy 2.x: `g = Generator(PCG64(SeedSequence(5))); x = list(range(10)); g.shuffle(x)`,
    /// then `g.integers(0, 100)`, a shuffle of `[0, 1, 2]` and `g.integers(0, 1000)`.
    #[test]
    fn shuffle_of_a_list_matches_numpy() {
        let mut rng = NumpyRng::new(5);
        let mut x: Vec<u32> = (0..10).collect();
        rng.shuffle(&mut x);
        assert_eq!(x, [7, 6, 1, 3, 2, 4, 0, 9, 5, 8]);
        assert_eq!(rng.integers(0, 100), 40);
        let mut y = [0, 1, 2];
        rng.shuffle(&mut y);
        assert_eq!(y, [0, 1, 2]);
        assert_eq!(rng.integers(0, 1000), 1);
    }

    #[test]
    fn the_stream_position_round_trips_through_json() {
        let mut rng = NumpyRng::new(9);
        rng.next_u32();
        let back: NumpyRng = serde_json::from_str(&serde_json::to_string(&rng).unwrap()).unwrap();
        assert_eq!(back, rng);
        let (mut a, mut b) = (rng, back);
        assert_eq!(a.integers(0, 1 << 40), b.integers(0, 1 << 40));
    }

    /// numpy 2.4: `PCG64(SeedSequence(0)).state` and its first three `random_raw()`.
    #[test]
    fn seed_zero_matches_numpy() {
        let mut g = NumpyRng::new(0);
        assert_eq!(
            g.state(),
            (
                0x1aa1_b534_5996_452d_0958_5eb7_a695_61e3,
                0x418d_dadb_3af7_1a82_5881_33bc_4478_73a9
            )
        );
        assert_eq!(g.next_u64(), 0xa30f_ebcf_d9c2_825f);
        assert_eq!(g.next_u64(), 0x4510_bdf8_82d9_d721);
        assert_eq!(g.next_u64(), 0x0a7d_3da9_4ecd_e8b8);
    }

    #[test]
    fn a_range_of_one_value_draws_nothing() {
        let mut a = NumpyRng::new(7);
        let mut b = NumpyRng::new(7);
        assert_eq!(a.integers(3, 4), 3);
        assert_eq!(a.calls(), 0);
        assert_eq!(a.integers(0, 10), b.integers(0, 10));
    }

    #[test]
    fn thirty_two_bit_draws_keep_the_high_half_across_64_bit_draws() {
        let mut a = NumpyRng::new(1);
        let mut raw = NumpyRng::new(1);
        let first = raw.next_u64();
        let second = raw.next_u64();
        assert_eq!(a.next_u32(), first as u32);
        // A 64-bit draw in between does not drop the kept half.
        assert_eq!(a.next_u64(), second);
        assert_eq!(a.next_u32(), (first >> 32) as u32);
    }
}
