//! The one quantile every figure of the cluster is quoted with: the master's summary
//! (barrier wait, motion-to-photon), `sim`'s skew between the walls' presents, and
//! `compare`'s frame times and fast-motion error. In this crate because the master, the
//! render nodes and `compare` all depend on it, so "p99" means the same thing in each.

use std::time::Duration;

/// The `q` quantile (`0..=1`, clamped) of `values` by linear interpolation between the
/// closest ranks — Hyndman & Fan's definition 7, the default of numpy's `quantile`,
/// pandas' `quantile` and R's `quantile`: with the values sorted `x[0] ≤ … ≤ x[n−1]` and
/// `h = (n − 1)·q`, it is `x[⌊h⌋] + (h − ⌊h⌋)·(x[⌊h⌋+1] − x[⌊h⌋])`. `None` for no values.
/// NaNs sort above every number (`f64::total_cmp`).
pub fn quantile(values: &[f64], q: f64) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let h = (v.len() - 1) as f64 * q.clamp(0.0, 1.0);
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(v.len() - 1);
    Some(v[lo] + (h - lo as f64) * (v[hi] - v[lo]))
}

/// [`quantile`] of durations (to the nanosecond); `None` for none.
pub fn quantile_duration(values: &[Duration], q: f64) -> Option<Duration> {
    let secs: Vec<f64> = values.iter().map(Duration::as_secs_f64).collect();
    quantile(&secs, q).map(Duration::from_secs_f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_are_numpys_default_linear_interpolation() {
        // numpy.quantile([1, 2, 3, 4], q) for q = 0, 0.25, 0.5, 0.75, 0.99, 1.
        let v = [4.0, 1.0, 3.0, 2.0];
        for (q, want) in [
            (0.0, 1.0),
            (0.25, 1.75),
            (0.5, 2.5),
            (0.75, 3.25),
            (0.99, 3.97),
            (1.0, 4.0),
        ] {
            let got = quantile(&v, q).unwrap();
            assert!((got - want).abs() < 1e-12, "q {q}: {got}, not {want}");
        }
        // numpy.quantile(range(1, 101), 0.99) = 99.01; an odd count's median is its middle.
        let hundred: Vec<f64> = (1..=100).map(f64::from).collect();
        assert!((quantile(&hundred, 0.99).unwrap() - 99.01).abs() < 1e-9);
        assert_eq!(quantile(&[5.0, 1.0, 3.0], 0.5), Some(3.0));
        assert_eq!(quantile(&[7.0], 0.99), Some(7.0));
        assert_eq!(quantile(&[], 0.5), None);
        assert_eq!(quantile(&[1.0, 2.0], 1.5), Some(2.0), "q is clamped");
    }

    #[test]
    fn duration_quantiles_are_the_same_rule() {
        let ms = |m: u64| Duration::from_millis(m);
        assert_eq!(
            quantile_duration(&[ms(10), ms(40), ms(20), ms(30)], 0.5),
            Some(ms(25))
        );
        assert_eq!(quantile_duration(&[], 0.5), None);
    }
}
