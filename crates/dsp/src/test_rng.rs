//! Deterministic pseudo-random numbers for the unit tests (no dependency, the same sequence on
//! every run and target).

/// Linear congruential generator x ← 1 664 525·x + 1 013 904 223 (mod 2³²).
pub struct Lcg(pub u32);

impl Lcg {
    /// The next state.
    pub fn next_u32(&mut self) -> u32 {
        self.0 = self.0.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        self.0
    }

    /// A uniform value in [0, 1) from the top 24 bits of the next state.
    pub fn unit(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 / (1u32 << 24) as f32
    }
}

/// Marsaglia's xorshift64 (13, 7, 17); the state must not be 0.
pub struct XorShift64(pub u64);

impl XorShift64 {
    /// The next state.
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}
