//! Ward's RGBE shared-exponent colour (paper §2.1, Table 1; Ward, "Real Pixels", 1991).
//!
//! Four bytes: three 8-bit mantissas and one exponent byte shared by the channels, biased
//! by 128. The largest channel keeps 8 significant bits; smaller channels lose precision
//! relative to it, so the error bound is stated relative to the largest channel: every
//! channel decodes within `2^-8 × max(r, g, b)` of its input.
//!
//! Every `f32` input maps to a defined code: negative and NaN channels count as 0 (radiance
//! is never negative), `+Inf` and values beyond the format's range saturate at the largest
//! code, and colours whose largest channel is below `2^-128` (deep denormals) become black.

/// An encoded colour: `[r, g, b, e]`.
pub type Rgbe = [u8; 4];

/// The largest value a channel can take after decoding: mantissa 255 at exponent byte 255.
pub const RGBE_MAX: f32 = 255.5 * (1u128 << 119) as f32;

/// Splits `v > 0` into `m × 2^e` with `m ∈ [0.5, 1)`, like C's `frexp`. Works in `f64`, where
/// every `f32` (denormals included) is normal.
fn frexp(v: f64) -> (f64, i32) {
    let bits = v.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i32 - 1022;
    let mantissa = f64::from_bits((bits & !(0x7ffu64 << 52)) | (1022u64 << 52));
    (mantissa, exp)
}

fn sanitize(c: f32) -> f64 {
    if c.is_nan() || c <= 0.0 {
        0.0
    } else {
        // The largest encodable mantissa is 255 at exponent 127 (byte 255).
        f64::from(c).min(255.0 * 2f64.powi(119))
    }
}

/// Encodes linear RGB radiance.
pub fn encode(rgb: [f32; 3]) -> Rgbe {
    let c = rgb.map(sanitize);
    let v = c[0].max(c[1]).max(c[2]);
    if v < 2f64.powi(-128) {
        return [0; 4];
    }
    let (m, e) = frexp(v);
    // m × 256 / v maps the largest channel into [128, 256).
    let scale = m * 256.0 / v;
    let byte = |x: f64| (x * scale).min(255.0) as u8;
    [byte(c[0]), byte(c[1]), byte(c[2]), (e + 128) as u8]
}

/// Decodes to linear RGB; each mantissa decodes to the centre of its step.
pub fn decode(code: Rgbe) -> [f32; 3] {
    if code[3] == 0 {
        return [0.0; 3];
    }
    let f = 2f64.powi(i32::from(code[3]) - 128 - 8);
    [0, 1, 2].map(|i| ((f64::from(code[i]) + 0.5) * f) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn check_bound(rgb: [f32; 3]) {
        let back = decode(encode(rgb));
        let max = rgb.iter().cloned().fold(0.0f32, f32::max);
        for i in 0..3 {
            let err = (f64::from(back[i]) - f64::from(rgb[i])).abs();
            assert!(
                err <= 2f64.powi(-8) * f64::from(max) * (1.0 + 1e-6),
                "{rgb:?} -> {back:?}: channel {i} error {err}"
            );
        }
    }

    proptest! {
        #[test]
        fn relative_error_bounded_by_max_channel(
            r in 0.0f32..1.0, g in 0.0f32..1.0, b in 0.0f32..1.0, exp in -120i32..120
        ) {
            let s = 2f32.powi(exp);
            check_bound([r * s, g * s, b * s]);
        }

        #[test]
        fn round_trip_of_codes_is_exact(r in 0u8..=255, g in 0u8..=255, b in 0u8..=255, e in 1u8..=255) {
            // A canonical code has its largest mantissa in [128, 256).
            let m = r.max(g).max(b);
            prop_assume!(m >= 128);
            prop_assert_eq!(encode(decode([r, g, b, e])), [r, g, b, e]);
        }
    }

    #[test]
    fn special_inputs_have_defined_codes() {
        assert_eq!(encode([0.0; 3]), [0; 4]);
        assert_eq!(encode([-1.0, -0.0, f32::NEG_INFINITY]), [0; 4]);
        assert_eq!(encode([f32::NAN; 3]), [0; 4]);
        assert_eq!(
            encode([1e-45, 0.0, 0.0]),
            [0; 4],
            "deepest denormal is black"
        );
        // A denormal above 2^-128 is still represented.
        let d = 2f32.powi(-127);
        check_bound([d, 0.0, 0.0]);
        assert_eq!(encode([f32::INFINITY, 0.0, 0.0]), [255, 0, 0, 255]);
        assert_eq!(encode([f32::MAX; 3]), [255, 255, 255, 255]);
        assert_eq!(decode([255, 255, 255, 255])[0], RGBE_MAX);
        let mixed = encode([f32::NAN, 1.0, f32::INFINITY]);
        assert_eq!(mixed[0], 0);
        check_bound([1.0, 0.5, 0.25]);
    }
}
