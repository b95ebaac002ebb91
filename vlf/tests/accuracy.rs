//! The VLF of the Cornell box (camera "front") against converged path-traced references:
//! the error at the highest setting is within a bound, and it falls as the directions and
//! the line resolution grow.
//!
//! The bound comes from issue 14's figure: the VLF alone within relative MSE 0.01 of a
//! converged render at the default settings, 642 directions (the default lines are 256;
//! the tests hold 642 directions with 128 lines, coarser elements, to the same 0.01). The settings
//! below grow the lines with the directions (N ≈ 5 √l), so the element size and the line
//! spacing shrink like the direction spacing, ∝ 1/√l. Where the irradiance is smooth the
//! drawn error is first order in that spacing (the lines' aliasing, the direction
//! quadrature, next-event noise averaged over the elements a pixel covers), so its
//! square, the MSE, goes as 1/l; a lower setting `l` is held to 0.01 · 642 / l. Where
//! the irradiance jumps (contact shadows, the corners between walls) an element smears
//! the jump over its width, an O(1) error on a band ∝ 1/√l: that part of the MSE falls
//! only as 1/√l, the slowest rate any part should fall at. And one part does not fall:
//! smooth glass is followed along its stronger branch only (`surface::delta_step`), so
//! the diffuse surroundings it reflects are missing from the glass sphere at any
//! setting. The test bounds that floor `F` by the whole error on the pixels that see
//! the glass at the best setting, and requires the rest to fall at least as 1/√l.
//!
//! The reference is the mean of two renders with different seeds. Their own relative MSE
//! against each other is twice a render's noise, so the mean's noise is a quarter of it,
//! `n̂`; it adds to every setting's measured error alike, so the VLF's own error is the
//! measured one less `n̂`.

use crate::common;

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use glam::Vec2;
use holocave_cave::{Size, WallView};
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::film::Image;

use holocave_vlf::{Settings, Visibility};

const SIZE: u32 = 48;
/// Lookups per pixel along each axis: the pixel's mean, as the path tracer's is.
const AA: u32 = 4;

fn cornell() -> Arc<Scene> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell.gltf");
    Arc::new(Scene::load(&path, &LoadOptions::default()).unwrap())
}

fn front(scene: &Scene) -> WallView {
    let cam = scene.cameras.iter().find(|c| c.name == "front").unwrap();
    WallView::through_camera(cam, Size::new(SIZE, SIZE))
}

/// `relative_mse` over the pixels of `mask` only, as a share of the whole image's.
fn relative_mse_over(image: &Image, reference: &Image, mask: &[bool]) -> f64 {
    let mut sum = 0.0f64;
    for ((a, b), m) in image.pixels.iter().zip(&reference.pixels).zip(mask) {
        for c in 0..3 {
            let (a, b) = (f64::from(a[c]), f64::from(b[c]));
            sum += f64::from(u8::from(*m)) * (a - b).powi(2) / (b * b + 0.01);
        }
    }
    sum / (3 * image.pixels.len()) as f64
}

/// Renders the reference (two seeds, `spp` each), bakes and draws each of `settings`
/// (directions, lines), and checks the errors.
fn errors_fall(spp: u32, settings: &[(usize, u32)]) {
    let scene = cornell();
    let view = front(&scene);
    // The pixels whose centre sees the glass sphere first.
    let glass: Vec<bool> = (0..SIZE * SIZE)
        .map(|i| {
            let ray = view.ray(Vec2::new((i % SIZE) as f32 + 0.5, (i / SIZE) as f32 + 0.5));
            scene.closest_hit(&ray, f32::INFINITY).is_some_and(|h| {
                let m = scene.triangle_shading(h.triangle).material;
                scene.materials[m as usize].name == "glass"
            })
        })
        .collect();
    assert!(glass.iter().filter(|g| **g).count() > 50);
    let start = Instant::now();
    let (reference, noise, [a, b]) = common::two_seed_reference(&scene, &view, spp);
    let glass_noise = relative_mse_over(&a, &b, &glass) / 4.0;
    eprintln!(
        "reference: 2 × {spp} spp in {:.1} s, its noise n̂ = {noise:.5}",
        start.elapsed().as_secs_f64()
    );

    let mut table = Vec::new();
    let mut floor = 0.0;
    for &(directions, resolution) in settings {
        let s = Settings {
            directions,
            resolution,
            ..Settings::default()
        };
        let start = Instant::now();
        let (state, stats) = common::bake_quiet(&scene, &s);
        let bake = start.elapsed().as_secs_f64();
        assert!(state.converged && state.tail() < s.tolerance);
        let vis = Visibility::of(scene.clone(), &s);
        let image = vis.render(&view, &state.values(), AA);
        let measured = image.relative_mse(&reference);
        floor = relative_mse_over(&image, &reference, &glass) - glass_noise;
        eprintln!(
            "{:>5} directions {:>4} lines: {:>6} elements, {:>2} bounces, bake {bake:>5.1} s, relative MSE {measured:.5} (less n̂: {:.5}; on the glass less its noise {floor:.5})",
            stats.directions,
            resolution,
            stats.elements,
            state.bounces,
            measured - noise
        );
        table.push((stats.directions as f64, measured));
    }

    let (top_l, top) = *table.last().unwrap();
    let bound = 0.01 * 642.0 / top_l;
    assert!(
        top <= bound,
        "{top_l} directions: relative MSE {top:.5} above {bound:.5}"
    );
    // The reference is converged enough to judge the VLF by: its noise is under a quarter
    // of the VLF's own error at the best setting.
    assert!(
        noise < (top - noise) / 4.0,
        "reference noise {noise:.5} against the VLF's error {:.5}",
        top - noise
    );
    for w in table.windows(2) {
        let ((l0, e0), (l1, e1)) = (w[0], w[1]);
        // Falls: as measured, and less the reference's noise and the glass's floor at
        // least as fast as 1/√l.
        assert!(e1 < e0, "{l0} → {l1} directions: {e0:.5} → {e1:.5}");
        let ratio = (e1 - noise - floor) / (e0 - noise - floor);
        assert!(
            ratio <= (l0 / l1).sqrt(),
            "{l0} → {l1} directions: error less noise and floor falls by {ratio:.3}, not by √({l0}/{l1}) = {:.3}",
            (l0 / l1).sqrt()
        );
    }
}

/// Small settings: about 16 s on two idle cores.
#[test]
fn cornell_error_falls_with_directions_and_lines() {
    errors_fall(1536, &[(42, 32), (92, 48), (162, 64)]);
}

/// Up to the default directions (with half the default lines), where issue 14 asks for
/// relative MSE 0.01.
#[test]
#[ignore = "about a minute on two idle cores (two or more when shared): a 2 × 4096 spp reference and a 642-direction bake"]
fn cornell_within_the_issue_figure_at_642_directions() {
    errors_fall(4096, &[(162, 64), (362, 96), (642, 128)]);
}
