//! The 16-bit ray distance code (paper §2.1).
//!
//! Codes `0 .. 2^11` are linear up to the section's size `s` (its diagonal), with step
//! `s / 2^11`; codes from `2^11` up are logarithmic, `d = s × (1 + 2^-11)^(code - 2^11)`, so
//! the step matches the linear one at the border. The largest finite code is
//! [`MAX_FINITE`] (`d ≈ s × 2.6e13`); every code above it means "infinite" (the ray escaped).
//! Rounding to the nearest code bounds the error by half a step: absolute `s × 2^-12` in the
//! linear range and relative `(1 + 2^-11)^½ - 1 ≈ 0.0244 %` in the logarithmic one.
//!
//! Defined codes for every input: negative distances and `-0` encode as 0, denormals round to
//! 0, NaN (no valid hit) and `+Inf` and finite distances beyond the range encode as
//! [`INFINITE`].

/// Codes below this are linear.
pub const LINEAR_CODES: u16 = 1 << 11;
/// The largest code that means a finite distance.
pub const MAX_FINITE: u16 = u16::MAX - 1;
/// The code written for escaped rays; every code above [`MAX_FINITE`] decodes as infinite.
pub const INFINITE: u16 = u16::MAX;

fn log_step() -> f64 {
    (1.0 + 2f64.powi(-11)).ln()
}

/// Encoder/decoder bound to one section size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistanceCode {
    size: f64,
}

impl DistanceCode {
    /// `size` is the section's diagonal length in metres (must be finite and positive; the
    /// section constructor guarantees it).
    pub fn new(size: f64) -> Self {
        Self { size }
    }

    /// The distance that `code` stands for.
    pub fn decode(&self, code: u16) -> f32 {
        if code > MAX_FINITE {
            f32::INFINITY
        } else if code < LINEAR_CODES {
            ((f64::from(code) + 0.5) * self.size / f64::from(LINEAR_CODES)) as f32
        } else {
            (self.size * (f64::from(code - LINEAR_CODES) * log_step()).exp()) as f32
        }
    }

    /// The code nearest to distance `d` (see the module docs for special inputs).
    pub fn encode(&self, d: f32) -> u16 {
        if d.is_nan() {
            return INFINITE;
        }
        let d = f64::from(d);
        if d <= 0.0 {
            return 0;
        }
        let lin = d * f64::from(LINEAR_CODES) / self.size;
        if lin < f64::from(LINEAR_CODES) {
            return lin as u16;
        }
        let c = f64::from(LINEAR_CODES) + ((d / self.size).ln() / log_step()).round();
        // Beyond the last finite code by more than half a step: infinite.
        if c > f64::from(MAX_FINITE) {
            INFINITE
        } else {
            c as u16
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn log_range_relative_error_below_half_permille(size in 0.1f64..100.0, f in 1.0f64..1e12) {
            let c = DistanceCode::new(size);
            let d = (size * f) as f32;
            let back = c.decode(c.encode(d));
            let rel = ((f64::from(back) - f64::from(d)) / f64::from(d)).abs();
            prop_assert!(rel <= 0.0005, "d={d} back={back} rel={rel}");
            // The actual bound is half a logarithmic step (plus f32 rounding).
            prop_assert!(rel <= ((1.0 + 2f64.powi(-11)).sqrt() - 1.0) + 2e-7);
        }

        #[test]
        fn linear_range_absolute_error_half_step(size in 0.1f64..100.0, f in 0.0f64..1.0) {
            let c = DistanceCode::new(size);
            let d = (size * f) as f32;
            let back = c.decode(c.encode(d));
            let step = size / f64::from(LINEAR_CODES);
            // Half a step, plus the decoded distance's rounding to f32 (half an ulp, at
            // most ε/2 of it): a relative margin on the step alone is below an f32 ulp at
            // metres (size 18.3, d 10.78 m failed so).
            let rounding = 0.5 * f64::from(f32::EPSILON) * f64::from(back);
            let err = (f64::from(back) - f64::from(d)).abs();
            prop_assert!(err <= step * 0.5 + rounding, "d={d} back={back} err={err}");
        }

        #[test]
        fn every_finite_code_round_trips(code in 0u16..=MAX_FINITE, size in 0.5f64..20.0) {
            let c = DistanceCode::new(size);
            let back = c.encode(c.decode(code));
            // f32 rounding of huge values can move by one step at most.
            prop_assert!((i32::from(back) - i32::from(code)).abs() <= 1, "{code} -> {back}");
        }
    }

    #[test]
    fn special_inputs_have_defined_codes() {
        let c = DistanceCode::new(2.0);
        assert_eq!(c.encode(0.0), 0);
        assert_eq!(c.encode(-0.0), 0);
        assert_eq!(c.encode(-5.0), 0);
        assert_eq!(c.encode(f32::NEG_INFINITY), 0);
        assert_eq!(c.encode(1e-40), 0, "denormal");
        assert_eq!(c.encode(f32::NAN), INFINITE);
        assert_eq!(c.encode(f32::INFINITY), INFINITE);
        assert_eq!(c.encode(f32::MAX), INFINITE);
        assert_eq!(c.encode(2.0), LINEAR_CODES, "the border: section size");
        assert!(c.decode(MAX_FINITE).is_finite());
        assert!(c.decode(MAX_FINITE) > 2.0 * 1e13);
        assert!(c.decode(INFINITE).is_infinite());
        // Monotone over all codes.
        let mut last = -1.0f32;
        for code in 0..=MAX_FINITE {
            let d = c.decode(code);
            assert!(d >= last, "code {code}");
            last = d;
        }
    }
}
