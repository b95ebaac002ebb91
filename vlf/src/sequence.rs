//! The R low-discrepancy sequences (Roberts 2018): each pixel's light samples, and the
//! deterministic BSDF samples of the bake's albedo tables.

/// The plastic number and its 3-D analogue: the R sequences' generators.
pub(crate) const R2: f64 = 1.324_717_957_244_746;
pub(crate) const R3: f64 = 1.220_744_084_605_759_5;

/// A pixel's hash, spread over `[0, 1)`.
fn hash01(seed: u64, k: u64) -> f64 {
    let mut z = seed
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(k.wrapping_mul(0xBF58_476D_1CE4_E5B9));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// Element `n` of the `d`-dimensional R sequence (generator `g`), shifted by the pixel's
/// hash; component `c`. In f64: `n · α` keeps its fraction exactly for any frame count a
/// session reaches.
pub(crate) fn r_sequence(g: f64, d: i32, c: i32, n: u64, seed: u64) -> f32 {
    let alpha = 1.0 / g.powi(c + 1);
    let shift = hash01(seed, (d * 8 + c) as u64);
    let x = (shift + n as f64 * alpha).fract();
    // Never 1.0 after rounding to f32 (samplers take [0, 1)).
    (x as f32).min(1.0 - f32::EPSILON / 2.0)
}
