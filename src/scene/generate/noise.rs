//! Seeded 2D value noise and its fractal sum, for the voxel terrain.

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Value noise on a 256-periodic integer lattice: random values at lattice
/// points, blended with a smoothstep. Same seed, same field on every platform
/// (ChaCha8 is specified bit for bit).
pub struct ValueNoise {
    perm: [u8; 512],
    values: [f32; 256],
}

impl ValueNoise {
    pub fn new(seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut p: Vec<u8> = (0..=255).collect();
        p.shuffle(&mut rng);
        let values = std::array::from_fn(|_| rng.random::<f32>());
        let perm = std::array::from_fn(|i| p[i & 255]);
        Self { perm, values }
    }

    fn lattice(&self, x: i32, y: i32) -> f32 {
        let h = self.perm[(self.perm[(x & 255) as usize] as usize + (y & 255) as usize) & 511];
        self.values[h as usize]
    }

    /// Noise in [0, 1] at `(x, y)`, one lattice cell per unit.
    pub fn sample(&self, x: f32, y: f32) -> f32 {
        let (fx, fy) = (x.floor(), y.floor());
        let (ix, iy) = (fx as i32, fy as i32);
        let smooth = |t: f32| t * t * (3.0 - 2.0 * t);
        let (tx, ty) = (smooth(x - fx), smooth(y - fy));
        let a = self.lattice(ix, iy) + (self.lattice(ix + 1, iy) - self.lattice(ix, iy)) * tx;
        let b = self.lattice(ix, iy + 1) + (self.lattice(ix + 1, iy + 1) - self.lattice(ix, iy + 1)) * tx;
        a + (b - a) * ty
    }

    /// Fractal sum of `octaves` octaves (each twice the frequency and half the
    /// amplitude of the last), normalised back to [0, 1].
    pub fn fbm(&self, x: f32, y: f32, octaves: u32) -> f32 {
        let (mut sum, mut amp, mut freq, mut total) = (0.0, 1.0, 1.0, 0.0);
        for o in 0..octaves {
            // Offset each octave so that lattice points do not line up.
            let shift = o as f32 * 17.31;
            sum += amp * self.sample(x * freq + shift, y * freq - shift);
            total += amp;
            amp *= 0.5;
            freq *= 2.0;
        }
        sum / total
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_is_seeded_bounded_and_continuous() {
        let (a, b, c) = (ValueNoise::new(7), ValueNoise::new(7), ValueNoise::new(8));
        let mut differs = false;
        for i in 0..200 {
            let (x, y) = (i as f32 * 0.37, i as f32 * 0.21);
            let v = a.fbm(x, y, 4);
            assert!((0.0..=1.0).contains(&v));
            assert_eq!(v, b.fbm(x, y, 4));
            differs |= v != c.fbm(x, y, 4);
            assert!((a.sample(x, y) - a.sample(x + 1e-3, y)).abs() < 0.01);
        }
        assert!(differs, "different seeds must give different fields");
    }
}
