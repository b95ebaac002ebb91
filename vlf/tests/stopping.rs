//! The stopping rule's estimate of the light still to propagate.

use holocave_vlf::State;
use holocave_vlf::bake::tail;

#[test]
fn tail_of_a_geometric_series_is_what_is_left() {
    // Bounce k sends out r_k = r_0 q^k: what later bounces send is r_k q / (1 − q), and
    // bounces 1…k sent r_0 q (1 − q^k) / (1 − q); the tail is their ratio, exactly.
    let (r0, q) = (0.7f64, 0.6f64);
    let r: Vec<f64> = (0..8).map(|k| r0 * q.powi(k)).collect();
    for k in 3..=r.len() {
        let left: f64 = (k..400).map(|j| r0 * q.powi(j as i32)).sum();
        let sent: f64 = r[1..k].iter().sum();
        let t = tail(&r[..k]);
        assert!(
            (t - left / sent).abs() < 1e-9 * t,
            "k {k}: {t} vs {}",
            left / sent
        );
    }
    // Unknown until two bounces are known, or while the light does not fall.
    assert_eq!(tail(&[]), f64::INFINITY);
    assert_eq!(tail(&[0.5, 0.25]), f64::INFINITY);
    assert_eq!(tail(&[0.5, 0.25, 0.3]), f64::INFINITY);
    // Nothing more sent: nothing left.
    assert_eq!(tail(&[0.5, 0.25, 0.0]), 0.0);
    let s = State {
        bounces: 2,
        irradiance: vec![],
        last: vec![],
        tiles: vec![],
        tiles_last: vec![],
        direct: vec![],
        tiles_direct: vec![],
        sky: vec![],
        tiles_sky: vec![],
        caustics: vec![],
        arrived: 1.0,
        residuals: r[..3].to_vec(),
        converged: false,
    };
    assert_eq!(s.tail(), tail(&r[..3]));
    assert_eq!(s.residual(), r[2]);
}
