//! The R low-discrepancy sequences (Roberts 2018): each pixel's light samples and places in
//! the pixel, and the
//! deterministic BSDF samples of the bake's albedo tables.

/// The plastic number and its 3-D analogue: the R sequences' generators.
pub(crate) const R2: f64 = 1.324_717_957_244_746;
pub(crate) const R3: f64 = 1.220_744_084_605_759_5;
/// The 4-D analogue (the positive root of `x⁵ = x + 1`): its first two components place a
/// pixel's estimates in the pixel, a sequence of its own that never runs in step with the
/// lights' R2 and R3 samples.
pub(crate) const R4: f64 = 1.167_303_978_261_418_7;

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

/// Component `c` of the `d`-dimensional R sequence (generator `g`) of pixel `seed`, for a
/// walk that draws the same samples without f64 (a GPU): the pixel's shift in 32-bit fixed
/// point (`⌊shift · 2³²⌉ mod 2³²`) and the step `α · 2⁶⁴` (exact: α's 53 bits). Element
/// `n` is then `shift + ⌊n · step / 2³²⌋ mod 2³²`, in units of 2⁻³², within `n · 2⁻⁵³ +
/// 2⁻³²` of [`r_sequence`]'s before its rounding to f32.
pub(crate) fn r_fixed(g: f64, d: i32, c: i32, seed: u64) -> (u32, u64) {
    let alpha = 1.0 / g.powi(c + 1);
    let shift = hash01(seed, (d * 8 + c) as u64);
    let two32 = (1u64 << 32) as f64;
    (
        (shift * two32).round() as u64 as u32,
        (alpha * two32 * two32) as u64,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fixed-point form draws the f64 form's samples: within two steps of f32 at 1
    /// (the f32 rounding of each, and the fixed point's truncation to 24 bits).
    #[test]
    fn fixed_point_samples_are_the_f64_samples() {
        for seed in [0, 1, 77, 123_456_789, u64::MAX] {
            for c in 0..2 {
                let (shift, step) = r_fixed(R2, 2, c, seed);
                for n in [0u64, 1, 2, 7, 1000, 123_456, 9_999_999] {
                    let steps = ((u128::from(n) * u128::from(step)) >> 32) as u64;
                    let x = shift.wrapping_add(steps as u32);
                    let fixed = (x >> 8) as f32 / (1u32 << 24) as f32;
                    let f64_form = r_sequence(R2, 2, c, n, seed);
                    let off = (fixed - f64_form).abs();
                    // The two may also sit either side of 0 ≡ 1.
                    assert!(
                        off.min(1.0 - off) <= 2.0 * f32::EPSILON,
                        "seed {seed} c {c} n {n}: {fixed} vs {f64_form}"
                    );
                }
            }
        }
    }
}
