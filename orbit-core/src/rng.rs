//! Counter-based random numbers (Philox4x32-10, Salmon et al. 2011) keyed by
//! `(seed, env, stream)`: every env and every consumer (reset event, command, noise) draws from
//! its own sequence, so results never depend on the order in which envs are processed or on how
//! many other envs exist. The same generator is cheap to run inside a GPU kernel.

/// Philox4x32 round multipliers and Weyl key increments.
const M0: u32 = 0xD251_1F53;
const M1: u32 = 0xCD9E_8D57;
const W0: u32 = 0x9E37_79B9;
const W1: u32 = 0xBB67_AE85;

/// Philox4x32-10 block function: encrypts a 128-bit counter under a 64-bit key.
pub fn philox4x32(ctr: [u32; 4], key: [u32; 2]) -> [u32; 4] {
    let (mut c, mut k) = (ctr, key);
    for round in 0..10 {
        if round > 0 {
            k = [k[0].wrapping_add(W0), k[1].wrapping_add(W1)];
        }
        let p0 = u64::from(M0) * u64::from(c[0]);
        let p1 = u64::from(M1) * u64::from(c[2]);
        c = [
            ((p1 >> 32) as u32) ^ c[1] ^ k[0],
            p1 as u32,
            ((p0 >> 32) as u32) ^ c[3] ^ k[1],
            p0 as u32,
        ];
    }
    c
}

/// Well-known stream ids, so independent consumers never share a sequence.
pub mod streams {
    /// Reset events.
    pub const RESET: u32 = 1;
    /// Command resampling.
    pub const COMMAND: u32 = 2;
    /// Observation noise.
    pub const NOISE: u32 = 3;
    /// Interval events.
    pub const INTERVAL: u32 = 4;
    /// Startup randomisation.
    pub const STARTUP: u32 = 5;
    /// Policy exploration / learner sampling.
    pub const POLICY: u32 = 6;
    /// Random initial episode lengths (training's staggered start), one stream per env; the
    /// learner's own streams are 16–18.
    pub const EPISODE_LENGTH: u32 = 19;
}

/// The random sequence of one `(seed, env, stream)`; each draw advances a 64-bit counter.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EnvRng {
    key: [u32; 2],
    env: u32,
    stream: u32,
    block: u64,
    buf: [u32; 4],
    used: usize,
}

impl EnvRng {
    /// The sequence for `(seed, env, stream)`, starting at draw 0.
    pub fn new(seed: u64, env: u32, stream: u32) -> Self {
        Self {
            key: [seed as u32, (seed >> 32) as u32],
            env,
            stream,
            block: 0,
            buf: [0; 4],
            used: 4,
        }
    }

    /// The next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        if self.used == 4 {
            let ctr = [
                self.block as u32,
                (self.block >> 32) as u32,
                self.env,
                self.stream,
            ];
            self.buf = philox4x32(ctr, self.key);
            self.block += 1;
            self.used = 0;
        }
        self.used += 1;
        self.buf[self.used - 1]
    }

    /// Uniform in `[0, 1)` with 24 bits of resolution.
    pub fn uniform(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform_range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.uniform()
    }

    /// Standard normal sample (Box–Muller).
    pub fn normal(&mut self) -> f32 {
        let u1 = 1.0 - self.uniform(); // (0, 1]
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Known-answer tests from the Random123 distribution (kat_vectors, philox4x32_10).
    #[test]
    fn philox_known_answers() {
        assert_eq!(
            philox4x32([0, 0, 0, 0], [0, 0]),
            [0x6627_e8d5, 0xe169_c58d, 0xbc57_ac4c, 0x9b00_dbd8]
        );
        assert_eq!(
            philox4x32([u32::MAX; 4], [u32::MAX; 2]),
            [0x408f_276d, 0x41c8_3b0e, 0xa20b_c7c6, 0x6d54_51fd]
        );
        assert_eq!(
            philox4x32(
                [0x243f_6a88, 0x85a3_08d3, 0x1319_8a2e, 0x0370_7344],
                [0xa409_3822, 0x299f_31d0]
            ),
            [0xd16c_fe09, 0x94fd_cceb, 0x5001_e420, 0x2412_6ea1]
        );
    }

    #[test]
    fn streams_are_independent_of_draw_order() {
        let mut a = EnvRng::new(42, 3, streams::RESET);
        let seq: Vec<u32> = (0..10).map(|_| a.next_u32()).collect();
        // Drawing from other envs in between changes nothing.
        let mut b = EnvRng::new(42, 3, streams::RESET);
        let mut other = EnvRng::new(42, 4, streams::RESET);
        let seq2: Vec<u32> = (0..10)
            .map(|_| {
                other.next_u32();
                b.next_u32()
            })
            .collect();
        assert_eq!(seq, seq2);
        let mut c = EnvRng::new(42, 3, streams::COMMAND);
        assert_ne!(seq[0], c.next_u32());
    }

    #[test]
    fn uniform_and_normal_moments() {
        let mut r = EnvRng::new(7, 0, 0);
        let n = 200_000;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let u = f64::from(r.uniform());
            assert!((0.0..1.0).contains(&u));
            s += u;
            s2 += u * u;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        // Standard error of the mean is 0.29/sqrt(n) ≈ 6.5e-4; allow 5 sigma.
        assert!((mean - 0.5).abs() < 3.3e-3, "mean {mean}");
        assert!((var - 1.0 / 12.0).abs() < 2e-3, "var {var}");
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let x = f64::from(r.normal());
            s += x;
            s2 += x * x;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        assert!(mean.abs() < 0.012, "normal mean {mean}");
        assert!((var - 1.0).abs() < 0.02, "normal var {var}");
    }
}
