//! The analytic direct-light case: a single floor quad lit by a point light
//! (`KHR_lights_punctual`, radiant intensity `I`) at height `h` above it. The irradiance
//! at a floor point a distance `d` from the light is `I cos θ / d² = I h / d³`; the floor
//! is flat, so it never lights itself and the baked irradiance is the direct light alone.

use crate::common;

use std::sync::Arc;

use glam::Vec3;
use holocave_scene::{Hit, Ray, Scene};
use holocave_vlf::elements::Elements;
use holocave_vlf::view::shade_one;
use holocave_vlf::{Settings, State, Visibility, layout};

const I: f32 = 10.0;
const H: f32 = 1.0;
const RHO: f32 = 0.8;
/// The floor is the square [−2, 2]² of the plane y = 0; its front faces +y.
const HALF: f32 = 2.0;

fn exact(p: Vec3, light: Vec3) -> f32 {
    let d = (light - p).length();
    I * H / (d * d * d)
}

#[test]
fn a_point_light_gives_i_cos_over_d_squared() {
    // a × b = z × x = +y: the floor faces the light.
    let [t0, t1] = common::floor(HALF);
    let light = Vec3::new(0.0, H, 0.0);
    let scene = Arc::new(common::scene(
        "floor",
        &[(t0, 0), (t1, 0)],
        vec![common::lambert("floor", RHO, Vec3::ZERO)],
        vec![common::point_light(light, I)],
    ));
    let settings = Settings {
        directions: 12,
        resolution: 16,
        element_size: Some(0.1),
        direct_samples: 64,
        tolerance: 1e-3,
        max_bounces: 200,
        ..Settings::default()
    };
    let (state, _) = common::bake_quiet(&scene, &settings);
    assert!(state.converged);
    let elements = layout(&scene, &settings);
    // Cells are squares of side s = 4 m / r (r = ⌈√2 · 4 / 0.1⌉ = 57, s = 0.070 m).
    let r = elements.triangles[0].res;
    let s = 2.0 * HALF / r as f32;

    // f = I h / (h² + ρ²)^{3/2} (ρ: the distance along the floor) has its largest second
    // derivative at ρ = 0, |f''| = |f'/ρ| = 3 I / h⁴ = H2, and its largest slope at
    // ρ = h/2, G = 0.859 I / h³. An element's irradiance is the mean of S = 64 samples,
    // one in each cell of an 8 × 8 grid over the element, so against f at its centroid:
    //  - the mean over a cell differs from f at the centroid by at most ½ H2 E|x − c|²,
    //    with E|x − c|² = s²/6 for a square cell and s²/9 for the half cells on the
    //    triangle's diagonal: bias ≤ H2 s²/12 = 0.012 (square), H2 s²/18 (half);
    //  - in a square cell each stratum (side s/8) spreads f by at most G (s/8)/√6, so the
    //    mean's standard deviation is ≤ G s / (8 √(6 S)) = 0.0038;
    //  - a half cell folds the grid's upper half onto its lower half by (a, b) → (1 − a,
    //    1 − b): the strata above the diagonal land whole, but the 8 strata the diagonal
    //    cuts scatter their samples over the whole cell (spread ≤ G s/√2, half the cell's
    //    diameter), so σ ≤ G s √(56/(6·8²) + 8/2) / 64 = 0.032 G s = 0.019.
    //  Each element's tolerance is its bias plus four standard deviations.
    let h2 = 3.0 * I / H.powi(4);
    let g = 0.859 * I / H.powi(3);
    let samples = settings.direct_samples as f32;
    let k = samples.sqrt();
    let sigma_square = g * (s / k) / (6.0 * samples).sqrt();
    let sigma_half = g * s * ((samples - k) / (6.0 * k * k) + k / 2.0).sqrt() / samples;
    let square = h2 * s * s / 12.0 + 4.0 * sigma_square;
    let half = h2 * s * s / 18.0 + 4.0 * sigma_half;
    eprintln!(
        "s {s:.4}, tolerance {square:.4} (square cells), {half:.4} (half cells); peak {:.1}",
        I / (H * H)
    );

    assert_elements_exact(&scene, &elements, &state, light, (square, half));

    // What a viewer sees: ρ/π times the irradiance interpolated bilinearly between cell
    // centres. Between centres of full cells (points at least 1.5 s from the triangle's
    // edges, the quad's diagonal x + z = 0 included) interpolation adds at most
    // (s²/8)(|f_xx| + |f_yy|) ≤ H2 s²/4 = 0.037 to the elements' own error.
    let interp = square + h2 * s * s / 4.0;
    assert_drawn_exact(&scene, &settings, &state, light, (interp, s));
}

/// Every element's irradiance against the exact one at its centre, within `square` (or
/// `half`, for the half cells on a triangle's diagonal); the underside dark.
fn assert_elements_exact(
    scene: &Scene,
    elements: &Elements,
    state: &State,
    light: Vec3,
    (square, half): (f32, f32),
) {
    let r = elements.triangles[0].res;
    let (_, centre) = elements.areas_and_centres(scene);
    let mut worst = 0f32;
    for (t, cells) in elements.triangles.iter().enumerate() {
        let count = holocave_vlf::elements::cells(cells.res);
        for c in 0..count {
            let front = (cells.base(0) + c) as usize;
            let back = (cells.base(1) + c) as usize;
            let (tc, u, v) = centre[front];
            assert_eq!(tc as usize, t);
            let p = scene
                .surface(&Hit {
                    triangle: tc,
                    t: 0.0,
                    u,
                    v,
                })
                .position;
            let e = state.irradiance[front];
            let want = exact(p, light);
            let err = (e[0] - want).abs();
            let (i, j) = ((u * r as f32) as u32, (v * r as f32) as u32);
            let per_element = if i + j == r - 1 { half } else { square };
            worst = worst.max(err / per_element);
            assert!(
                err <= per_element && e[0] == e[1] && e[1] == e[2],
                "element {front} at {p}: {e:?}, exact {want}, tolerance {per_element}"
            );
            // The underside sees no light at all.
            assert_eq!(state.irradiance[back], [0.0; 3], "underside {back} at {p}");
        }
    }
    eprintln!("worst element error {worst:.3} of its tolerance");
}

/// What a viewer sees at points of full cells (at least 1.5 `s` from the triangles'
/// edges) against ρ/π times the exact irradiance, within ρ/π `interp`.
fn assert_drawn_exact(
    scene: &Arc<Scene>,
    settings: &Settings,
    state: &State,
    light: Vec3,
    (interp, s): (f32, f32),
) {
    let eye = Vec3::new(0.3, 2.5, -0.2);
    let vis = Visibility::of(scene.clone(), settings);
    let values = state.values();
    for (x, z) in [
        (0.1, 0.1),
        (0.5, 0.5),
        (-0.3, -0.4),
        (1.0, 1.0),
        (1.5, 0.3),
        (0.3, 1.2),
        (-1.2, -0.3),
        (-0.8, -1.1),
        (1.7, 1.6),
    ] {
        let p = Vec3::new(x, 0.0, z);
        assert!((x + z).abs() / 2f32.sqrt() >= 1.5 * s && HALF - x.abs().max(z.abs()) >= 1.5 * s);
        let ray = Ray::new(eye, (p - eye).normalize());
        let l = shade_one(&vis.lookup(ray), &values);
        let want = RHO / std::f32::consts::PI * exact(p, light);
        let tol = RHO / std::f32::consts::PI * interp;
        assert!(
            (l.x - want).abs() <= tol,
            "at {p}: drawn {l}, exact {want} ± {tol}"
        );
    }
}
