//! The glare figures against hand-computed answers on fisheyes with known content.

use std::f64::consts::PI;

use glam::{DVec3, Vec3};
use holocave_glare::figures::evaluate;
use holocave_glare::{Fisheye, GlareError, LuminanceMap, Rules, Threshold};
use holocave_scene::Photometry;
use holocave_tracer::film::Image;

/// A fisheye looking along −Z with +Y up (right is +X).
fn view(n: u32) -> Fisheye {
    Fisheye::new(n, Vec3::ZERO, Vec3::NEG_Z, Vec3::Y).unwrap()
}

/// The luminance `f(d)` at every pixel centre (0 outside the circle).
fn paint(f: &Fisheye, lum: impl Fn(DVec3) -> f64) -> LuminanceMap {
    let l = f.directions().iter().map(|d| d.map_or(0.0, &lum)).collect();
    LuminanceMap::new(f.clone(), l).unwrap()
}

/// The direction `sigma` from the line of sight, `tau` from up towards right (radians).
fn at(f: &Fisheye, sigma: f64, tau: f64) -> DVec3 {
    f.look * sigma.cos() + (f.up * tau.cos() + f.right * tau.sin()) * sigma.sin()
}

/// Ev's relative error on a uniform hemisphere at `n` pixels: the pixels the circle's
/// edge crosses (a band `√2` px wide, `2√2·π·k` sr, where `cos θ ≤ k·√2/2`) give at most
/// `2π³/n²` of `π`… i.e. `2π²/n²` relative; taking each pixel's cosine at its centre errs
/// by at most `k²/4` of its solid angle (the second-order remainder over half a pixel
/// each way, `|d²cos/dx²| ≤ k²`), `π²/(2n²)` relative over the hemisphere.
fn uniform_ev_bound(n: u32) -> f64 {
    2.5 * PI * PI / f64::from(n * n)
}

/// Guth's position index, written out here from the IES equation for the hand values.
fn guth(sigma_deg: f64, tau_deg: f64) -> f64 {
    let t = tau_deg;
    ((35.2 - 0.31889 * t - 1.22 * (-2.0 * t / 9.0).exp()) * 1e-3 * sigma_deg
        + (21.0 + 0.26667 * t - 0.002963 * t * t) * 1e-5 * sigma_deg * sigma_deg)
        .exp()
}

#[test]
fn uniform_hemisphere_gives_pi_l() {
    for n in [64, 128, 201] {
        let f = view(n);
        let l = 300.0;
        let fig = evaluate(&paint(&f, |_| l), &Rules::default()).unwrap();
        let rel = (fig.ev_lux - PI * l).abs() / (PI * l);
        assert!(
            rel < uniform_ev_bound(n),
            "{n}: Ev {} (rel. error {rel:.2e})",
            fig.ev_lux
        );
        assert!(fig.sources.is_empty());
        assert!((fig.average_cd_m2 - l).abs() < 1e-9 * l);
        // No sources: the whole view is background.
        assert!((fig.background_cd_m2 - fig.ev_lux / PI).abs() < 1e-9 * l);
        assert_eq!(fig.ugr, Some(0.0));
    }
}

/// A disc source of luminance `Ls` and half-angle `α` at (σ, τ) on a uniform background
/// `L0`: DGP and UGR as the formulas give them by hand. What the test paints is the
/// pixels whose centres see the disc, so the source's solid angle is theirs (`ω`, each
/// pixel's from the fisheye, checked itself in `fisheye`'s tests) and within the disc's
/// `2π(1 − cos α)` by the pixels its edge crosses; its luminance is exactly `Ls`.
/// Ev = π L0 (within [`uniform_ev_bound`]) + (Ls − L0)·Σ cos θ ω over the disc's pixels;
/// Lb = (Ev − Ls·Σ cos θ ω)/π. The position index is Guth's at the disc's centre; the
/// source's measured position (the mean of its pixels) is within a pixel (k rad) of it,
/// so P is bounded by Guth's at σ ± k, τ ± k/sin σ. The hand DGP and UGR are taken at
/// the corners of those intervals of Ev and P, and the measured ones must lie between.
#[test]
fn one_source_on_a_uniform_background() {
    let n = 256;
    let f = view(n);
    let (l0, ls, alpha): (f64, f64, f64) = (400.0, 20_000.0, 0.1);
    let (sigma, tau) = (25f64.to_radians(), 30f64.to_radians());
    let centre = at(&f, sigma, tau);
    let cos_alpha = alpha.cos();
    let map = paint(&f, |d| if d.dot(centre) >= cos_alpha { ls } else { l0 });
    let fig = evaluate(&map, &Rules::default()).unwrap();
    assert_eq!(fig.sources.len(), 1, "{:?}", fig.sources);
    let s = &fig.sources[0];

    let (omega, cos_omega) = disc_solid_angles(&f, centre, cos_alpha);
    assert!(
        (s.solid_angle_sr - omega).abs() < 1e-12,
        "{} {omega}",
        s.solid_angle_sr
    );
    assert!((s.luminance_cd_m2 - ls).abs() < 1e-9 * ls);
    let k = f.radians_per_pixel();
    let disc = 2.0 * PI * (1.0 - cos_alpha);
    // The disc's edge, 2π sin α / k·(π/2) px long at most, crossed by a band √2 px wide
    // where each px² is at most k² sr.
    let rim = 2.0 * PI * alpha.sin() / k * (PI / 2.0) * 2f64.sqrt() * k * k;
    assert!(
        (omega - disc).abs() < rim,
        "ω {omega}, disc {disc}, rim {rim}"
    );
    assert!(
        s.direction.dot(centre) > (k).cos(),
        "the source is not where it was put"
    );

    let ev_bg = PI * l0;
    let ev_err = uniform_ev_bound(n) * ev_bg;
    let ev_mid = ev_bg + (ls - l0) * cos_omega;
    assert!(
        (fig.ev_lux - ev_mid).abs() <= ev_err,
        "Ev {} against {ev_mid} ± {ev_err}",
        fig.ev_lux
    );

    let (sd, td) = (sigma.to_degrees(), tau.to_degrees());
    let (dk, dt) = (k.to_degrees(), (k / sigma.sin()).to_degrees());
    let ps = guth_at_the_corners(sd, td, dk, dt);
    assert!(
        (s.position_index - guth(sd, td)).abs()
            <= ps
                .iter()
                .map(|p| (p - guth(sd, td)).abs())
                .fold(0.0, f64::max)
    );

    let evs = [ev_mid - ev_err, ev_mid + ev_err];
    let (dgp_range, ugr_range) = hand_dgp_and_ugr_ranges((ls, omega, cos_omega), evs, &ps);
    let ugr = fig.ugr.unwrap();
    eprintln!(
        "Ev {:.1} lx, DGP {:.5} in [{:.5}, {:.5}], UGR {ugr:.3} in [{:.3}, {:.3}], P {:.4}, ω {:.5}",
        fig.ev_lux,
        fig.dgp,
        dgp_range.0,
        dgp_range.1,
        ugr_range.0,
        ugr_range.1,
        s.position_index,
        omega
    );
    // Above 1000 lx: no low-light correction.
    assert!(fig.ev_lux > 1000.0);
    assert!(fig.dgp >= dgp_range.0 - 1e-12 && fig.dgp <= dgp_range.1 + 1e-12);
    assert!(ugr >= ugr_range.0 - 1e-9 && ugr <= ugr_range.1 + 1e-9);
}

/// The solid angle and the cosine-weighted solid angle of the pixels whose centres see
/// the disc about `centre` (those within `cos_alpha` of it).
fn disc_solid_angles(f: &Fisheye, centre: DVec3, cos_alpha: f64) -> (f64, f64) {
    let (mut omega, mut cos_omega) = (0.0, 0.0);
    for y in 0..f.size {
        for x in 0..f.size {
            if let Some(d) = f.pixel_direction(x, y)
                && d.dot(centre) >= cos_alpha
            {
                omega += f.solid_angle(x, y);
                cos_omega += f.solid_angle(x, y) * d.dot(f.look);
            }
        }
    }
    (omega, cos_omega)
}

/// Guth's position index at the four corners of `sd ± dk`, `td ± dt` (degrees) and at
/// their middle.
fn guth_at_the_corners(sd: f64, td: f64, dk: f64, dt: f64) -> Vec<f64> {
    [
        (-1.0, -1.0),
        (-1.0, 1.0),
        (1.0, -1.0),
        (1.0, 1.0),
        (0.0, 0.0),
    ]
    .iter()
    .map(|(a, b)| guth(sd + a * dk, td + b * dt))
    .collect()
}

/// The least and greatest DGP and UGR the hand formulas give for a source of luminance
/// `ls`, solid angle `omega` and cosine-weighted solid angle `cos_omega`, over every pair
/// of `evs` and `ps`.
fn hand_dgp_and_ugr_ranges(
    (ls, omega, cos_omega): (f64, f64, f64),
    evs: [f64; 2],
    ps: &[f64],
) -> ((f64, f64), (f64, f64)) {
    // Wienold & Christoffersen's coefficients, written out here so that a wrong one in
    // the library fails.
    let dgp_hand = |ev: f64, p: f64| {
        5.87e-5 * ev + 9.18e-2 * (1.0 + ls * ls * omega / (ev.powf(1.87) * p * p)).log10() + 0.16
    };
    let ugr_hand = |ev: f64, p: f64| {
        let lb = (ev - ls * cos_omega) / PI;
        8.0 * (0.25 / lb * ls * ls * omega / (p * p)).log10()
    };
    let mut dgp_range = (f64::INFINITY, f64::NEG_INFINITY);
    let mut ugr_range = (f64::INFINITY, f64::NEG_INFINITY);
    for ev in evs {
        for &p in ps {
            let (d, u) = (dgp_hand(ev, p), ugr_hand(ev, p));
            dgp_range = (dgp_range.0.min(d), dgp_range.1.max(d));
            ugr_range = (ugr_range.0.min(u), ugr_range.1.max(u));
        }
    }
    (dgp_range, ugr_range)
}

/// A source on the line of sight has P = 1 (its pixels are symmetric about the centre,
/// so their mean position is the centre to rounding).
#[test]
fn position_index_is_one_on_the_line_of_sight() {
    let f = view(128);
    let map = paint(&f, |d| {
        if d.dot(f.look) >= 0.05f64.cos() {
            10_000.0
        } else {
            100.0
        }
    });
    let fig = evaluate(&map, &Rules::default()).unwrap();
    assert_eq!(fig.sources.len(), 1);
    assert!(
        (fig.sources[0].position_index - 1.0).abs() < 1e-9,
        "{}",
        fig.sources[0].position_index
    );
}

/// Below 1000 lx DGP is multiplied by `e^(0.024 Ev − 4)/(1 + e^(0.024 Ev − 4))`: at
/// about 100 lx (no sources) `(0.16 + 5.87e-5·100)·0.16798 = 0.02786`; without the
/// correction `0.16587`; from 1000 lx none.
#[test]
fn low_light_correction() {
    let f = view(128);
    let bound = uniform_ev_bound(128);
    for (ev, corrected) in [(100.0, true), (2000.0, false)] {
        let fig = evaluate(&paint(&f, |_| ev / PI), &Rules::default()).unwrap();
        let plain = 0.16 + 5.87e-5 * fig.ev_lux;
        let e = (0.024 * fig.ev_lux - 4.0).exp();
        let hand = if corrected {
            plain * e / (1.0 + e)
        } else {
            plain
        };
        assert!((fig.ev_lux - ev).abs() < bound * ev);
        assert!(
            (fig.dgp - hand).abs() < 1e-12,
            "{ev} lx: {} against {hand}",
            fig.dgp
        );
        let off = Rules {
            low_light: false,
            ..Rules::default()
        };
        let fig = evaluate(&paint(&f, |_| ev / PI), &off).unwrap();
        assert!((fig.dgp - plain).abs() < 1e-12);
    }
    let fig = evaluate(&paint(&f, |_| 100.0 / PI), &Rules::default()).unwrap();
    assert!((fig.dgp - 0.02786).abs() < 1e-4, "{}", fig.dgp);
}

/// Two small discs whose nearest pixels are `gap` radians apart: evalglare merges source
/// pixels with `2·angle ≤ 0.2`, so a gap of 0.06 rad makes one source, 0.15 rad (under
/// 0.2 but over 0.1) and 0.3 rad two. The pixels are 0.006 rad here, so the gaps between
/// pixel centres are the nominal ones within 0.02 rad, far from the 0.1 rad limit.
#[test]
fn adjacent_blobs_merge_and_separate_ones_do_not() {
    let f = view(512);
    let r: f64 = 0.03;
    for (gap, expect) in [(0.06, 1), (0.15, 2), (0.3, 2)] {
        let half = r + gap / 2.0;
        let a = at(&f, half, PI / 2.0);
        let b = at(&f, half, -PI / 2.0);
        let map = paint(&f, |d| {
            if d.dot(a) >= r.cos() || d.dot(b) >= r.cos() {
                8000.0
            } else {
                50.0
            }
        });
        let fig = evaluate(&map, &Rules::default()).unwrap();
        assert_eq!(fig.sources.len(), expect, "gap {gap}");
        let total: f64 = fig.sources.iter().map(|s| s.solid_angle_sr).sum();
        let per = 2.0 * PI * (1.0 - r.cos());
        assert!(
            (total - 2.0 * per).abs() < 0.1 * per,
            "gap {gap}: {total} against {}",
            2.0 * per
        );
    }
}

/// Peak extraction: a source's pixels at or above 50 000 cd/m² become a source of their
/// own (the sun in a window), the rest stays one source; without extraction, one.
#[test]
fn peaks_are_split_off() {
    let f = view(256);
    let c = at(&f, 0.4, 0.5);
    let map = paint(&f, |d| {
        let cos = d.dot(c);
        if cos >= 0.02f64.cos() {
            6.0e4
        } else if cos >= 0.2f64.cos() {
            8000.0
        } else {
            100.0
        }
    });
    let fig = evaluate(&map, &Rules::default()).unwrap();
    assert_eq!(fig.sources.len(), 2);
    assert!(
        fig.sources
            .iter()
            .any(|s| s.peak && (s.luminance_cd_m2 / 6.0e4 - 1.0).abs() < 1e-12)
    );
    assert!(
        fig.sources
            .iter()
            .any(|s| !s.peak && (s.luminance_cd_m2 / 8000.0 - 1.0).abs() < 1e-12)
    );
    let whole = evaluate(
        &map,
        &Rules {
            peak_limit: None,
            ..Rules::default()
        },
    )
    .unwrap();
    assert_eq!(whole.sources.len(), 1);
    // One source of the mean luminance glares less than the two it is made of (the sum
    // of L²ω over parts is at least the whole's, by Cauchy–Schwarz): DGP drops.
    assert!(whole.dgp < fig.dgp, "{} {}", whole.dgp, fig.dgp);
}

/// The threshold: absolute (2000 cd/m², the default) or a factor of the mean luminance.
#[test]
fn threshold_rules() {
    let f = view(64);
    let c = at(&f, 0.3, 0.0);
    let map = paint(&f, |d| {
        if d.dot(c) >= 0.1f64.cos() {
            1500.0
        } else {
            100.0
        }
    });
    assert!(
        evaluate(&map, &Rules::default())
            .unwrap()
            .sources
            .is_empty()
    );
    let five = Rules {
        threshold: Threshold::from_evalglare(5.0).unwrap(),
        ..Rules::default()
    };
    let fig = evaluate(&map, &five).unwrap();
    assert_eq!(fig.sources.len(), 1);
    assert!((fig.threshold_cd_m2 - 5.0 * fig.average_cd_m2).abs() < 1e-9);
    assert_eq!(
        Threshold::from_evalglare(2000.0).unwrap(),
        Threshold::Absolute(2000.0)
    );
    assert!(Threshold::from_evalglare(-1.0).is_err());
}

#[test]
fn bad_input_is_an_error_naming_it() {
    assert!(matches!(
        Fisheye::new(0, Vec3::ZERO, Vec3::NEG_Z, Vec3::Y),
        Err(GlareError::EmptyImage { .. })
    ));
    let f = view(8);
    let mut l = vec![1.0; 64];
    l[8 * 3 + 5] = f64::NAN;
    let e = LuminanceMap::new(f.clone(), l).unwrap_err();
    assert!(e.to_string().contains("pixel (5, 3)"), "{e}");
    let mut l = vec![1.0; 64];
    l[2] = -1.0;
    assert!(matches!(
        LuminanceMap::new(f.clone(), l),
        Err(GlareError::BadPixel { x: 2, y: 0, .. })
    ));
    assert!(matches!(
        LuminanceMap::new(f.clone(), vec![1.0; 63]),
        Err(GlareError::WrongCount { .. })
    ));
    let p = Photometry::default();
    let e = LuminanceMap::from_radiance(f.clone(), &Image::new(0, 0), &p).unwrap_err();
    assert!(matches!(e, GlareError::SizeMismatch { .. }), "{e}");
    let mut img = Image::new(8, 8);
    img.pixels[9] = glam::Vec3::new(f32::NAN, 0.0, 0.0);
    let e = LuminanceMap::from_radiance(f.clone(), &img, &p).unwrap_err();
    assert!(e.to_string().contains("pixel (1, 1)"), "{e}");
    let map = LuminanceMap::new(f, vec![1.0; 64]).unwrap();
    for r in [-0.1, 0.0, 0.6, f64::NAN] {
        let bad = Rules {
            search_radius: r,
            ..Rules::default()
        };
        assert!(
            matches!(evaluate(&map, &bad), Err(GlareError::BadRules(_))),
            "{r}"
        );
    }
    let bad = Rules {
        peak_limit: Some(-1.0),
        ..Rules::default()
    };
    assert!(matches!(evaluate(&map, &bad), Err(GlareError::BadRules(_))));
}
