//! Numerical stability of single rays: far away origins, grazing rays, rays exactly
//! along triangle edges and through vertices, `-0.0` direction components, and
//! degenerate input (zero, NaN, infinite). Every sample must have finite, non-negative
//! radiance and a distance that is ≥ 0 or +∞, and nothing may panic.

use crate::common;

use common::*;
use glam::Vec3;
use holocave_scene::Ray;
use holocave_tracer::{TracedRay, Tracer};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

fn assert_sane(s: &TracedRay, what: &str) {
    assert!(
        s.radiance.iter().all(|c| c.is_finite() && *c >= 0.0),
        "{what}: {s:?}"
    );
    assert!(s.distance >= 0.0, "{what}: {s:?}"); // NaN fails this too
    assert!(s.virtual_distance >= s.distance, "{what}: {s:?}");
}

fn stats(samples: &[TracedRay]) -> Stats {
    let mut st = Stats::default();
    samples.iter().for_each(|s| st.add(Vec3::from(s.radiance)));
    st
}

/// Two independent estimates of the same mean agree within z standard errors.
fn assert_same_mean(a: &Stats, b: &Stats, z: f64, what: &str) {
    for c in 0..3 {
        let se = (a.std_error(c).powi(2) + b.std_error(c).powi(2)).sqrt();
        assert!(
            (a.mean(c) - b.mean(c)).abs() <= z * se,
            "{what} ch{c}: {} vs {} (SE {se})",
            a.mean(c),
            b.mean(c)
        );
    }
}

/// Rays from 10 km away into the Cornell box, and the same lines started at the camera:
/// the first hit is the same point (distance longer by 10 km, to 2 mm: two float steps
/// at 1e4 m), and the radiance is the same in distribution (two-sample test on the
/// means, z for 1e-4 over 3 channels, independent seeds). The near origins are computed
/// from the far ones in f64, so both rays lie on one line to 1e-7 m; the tracer must keep
/// that precision although its far origin is only known to 1 mm.
#[test]
fn rays_from_ten_kilometres_away_see_what_near_rays_see() {
    let tracer = tracer(cornell());
    let eye = Vec3::new(0.0, 1.0, 3.4);
    let mut rng = Pcg32::seed_from_u64(3);
    let n = 100_000;
    let mut near = Vec::new();
    let mut far = Vec::new();
    for _ in 0..n {
        // Into the box's opening (x, y in the box, z = 1).
        let t = Vec3::new(
            -0.95 + 1.9 * rng.random::<f32>(),
            0.05 + 1.9 * rng.random::<f32>(),
            1.0,
        );
        let d = (t - eye).normalize();
        let f = eye - d * 1e4;
        near.push(Ray::new((f.as_dvec3() + d.as_dvec3() * 1e4).as_vec3(), d));
        far.push(Ray::new(f, d));
    }
    let (sn, sf) = (tracer.trace(&near, 1), tracer.trace(&far, 2));
    for (a, b) in sn.iter().zip(&sf) {
        assert_sane(a, "near");
        assert_sane(b, "far");
        assert!(
            a.distance.is_finite() && b.distance.is_finite(),
            "{a:?} {b:?}"
        );
        assert!((b.distance - 1e4 - a.distance).abs() < 2e-3, "{a:?} {b:?}");
    }
    assert_same_mean(
        &stats(&sn),
        &stats(&sf),
        z_for_two_sided(1e-4 / 3.0),
        "near/far",
    );

    // And from 10 km in every direction at the sunlit Sponza.
    let scene = load(
        &shared_scene("sponza/Sponza.gltf"),
        Some(project_path("configs/sponza.daylight.toml")),
    );
    let (lo, hi) = scene.bounds();
    let tracer = Tracer::new(scene, Default::default());
    let rays: Vec<Ray> = (0..20_000)
        .map(|_| {
            let t = lo + (hi - lo) * Vec3::new(rng.random(), rng.random(), rng.random());
            let o = t + uniform_sphere(&mut rng) * 1e4;
            Ray::new(o, (t - o).normalize())
        })
        .collect();
    let mut hits = 0;
    for s in tracer.trace(&rays, 3) {
        assert_sane(&s, "sponza from 10 km");
        if s.distance.is_finite() {
            hits += 1;
            assert!(s.distance > 1e4 - (hi - lo).length(), "{s:?}");
        }
    }
    assert!(hits > rays.len() / 2, "{hits} hits");
}

/// The Cornell box and its eye moved together away from the origin (`holocave compare
/// --offset`): the same rays, moved, see the same light (two-sample test on the means as
/// above). At `offset` metres along x and z.
fn a_moved_box_is_lit_as_at_the_origin(offset: f32) {
    let at_origin = tracer(cornell());
    let moved = project_path("scenes/cornell.gltf");
    let moved = holocave_scene::Scene::load(&moved, &Default::default())
        .and_then(|s| s.transformed(1.0, Vec3::new(offset, 0.0, offset)))
        .expect("the Cornell box, moved");
    let moved = Tracer::new(std::sync::Arc::new(moved), Default::default());
    let eye = Vec3::new(0.0, 1.0, 3.4);
    let mut rng = Pcg32::seed_from_u64(5);
    let (mut here, mut there) = (Vec::new(), Vec::new());
    for _ in 0..100_000 {
        let t = Vec3::new(
            -0.95 + 1.9 * rng.random::<f32>(),
            0.05 + 1.9 * rng.random::<f32>(),
            1.0,
        );
        let d = (t - eye).normalize();
        here.push(Ray::new(eye, d));
        there.push(Ray::new(eye + Vec3::new(offset, 0.0, offset), d));
    }
    let (a, b) = (at_origin.trace(&here, 1), moved.trace(&there, 2));
    b.iter().for_each(|s| assert_sane(s, "moved"));
    assert_same_mean(
        &stats(&a),
        &stats(&b),
        z_for_two_sided(1e-4 / 3.0),
        &format!("at the origin / {offset} m away"),
    );
}

/// A kilometre away (f32 steps of 0.06 mm on the box's vertices): as at the origin.
#[test]
fn a_box_a_kilometre_away_is_lit_as_at_the_origin() {
    a_moved_box_is_lit_as_at_the_origin(1e3);
}

/// 100 km away (f32 steps of 8 mm): as at the origin. New rays start four float steps off
/// their surface there (`surface_epsilon`); a start 1e-4 of the coordinates off, the rule
/// before, put them 10 m away, outside the 2 m box, and lost a quarter of the light.
#[test]
fn a_box_a_hundred_kilometres_away_is_lit_as_at_the_origin() {
    a_moved_box_is_lit_as_at_the_origin(1e5);
}

/// The Cornell walls are Lambertian, so the radiance leaving a point is the same in
/// every direction: rays reaching floor points at 89.9° from the normal (0.1° above the
/// floor) see what rays from straight above see (two-sample test as above). Rays lying
/// in a wall's plane, just above it, and exactly along it are sane.
#[test]
fn grazing_rays() {
    let tracer = tracer(cornell());
    let mut rng = Pcg32::seed_from_u64(5);
    let n = 40_000;
    let mut steep = Vec::new();
    let mut grazing = Vec::new();
    for _ in 0..n {
        // Floor points in the front half of the box, away from the glass sphere's and the
        // mirror box's footprints and shadows' cores.
        let p = Vec3::new(
            -0.9 + 1.8 * rng.random::<f32>(),
            0.0,
            0.75 + 0.2 * rng.random::<f32>(),
        );
        steep.push(Ray::new(p + Vec3::Y * 0.5, -Vec3::Y));
        let d = Vec3::new(
            0.0,
            -(0.1f32.to_radians()).sin(),
            -(0.1f32.to_radians()).cos(),
        );
        grazing.push(Ray::new(p - d * 0.2, d));
    }
    let (a, b) = (tracer.trace(&steep, 11), tracer.trace(&grazing, 12));
    for (s, g) in a.iter().zip(&b) {
        assert_sane(s, "steep");
        assert_sane(g, "grazing");
        assert!(
            (s.distance - 0.5).abs() < 1e-5 && (g.distance - 0.2).abs() < 1e-4,
            "{g:?}"
        );
    }
    assert_same_mean(
        &stats(&a),
        &stats(&b),
        z_for_two_sided(1e-4 / 3.0),
        "steep/grazing",
    );

    // Along the planes of the walls: at heights 0 (in the floor's plane), 1e-7 and 1e-4
    // above the floor, and in the planes of the side and back walls.
    let mut rays = Vec::new();
    for h in [0.0f32, 1e-7, 1e-4, -1e-7] {
        for k in 0..200 {
            let x = -1.0 + 2.0 * k as f32 / 199.0;
            rays.push(Ray::new(Vec3::new(x, h, 1.5), -Vec3::Z));
            rays.push(Ray::new(
                Vec3::new(-1.0 + h, 0.01 + 1.98 * k as f32 / 199.0, 1.5),
                -Vec3::Z,
            ));
            rays.push(Ray::new(
                Vec3::new(x, 0.01 + 1.98 * k as f32 / 199.0, -1.0 + h),
                Vec3::X,
            ));
        }
    }
    for s in tracer.trace(&rays, 13) {
        assert_sane(&s, "in a wall's plane");
    }
}

/// Targets exactly on the Cornell box's triangle edges: the diagonals shared by the two
/// triangles of the floor and back wall quads, the edges where walls meet, and the
/// corners where three walls meet (all inside the closed part of the box).
fn closed_edge_targets() -> Vec<Vec3> {
    let mut targets = Vec::new();
    // The back wall's diagonal runs from (−1, 0, −1) to (1, 2, −1); the floor's from
    // (−1, 0, 1) to (1, 0, −1).
    for k in 1..40 {
        let t = k as f32 / 40.0;
        targets.push(Vec3::new(-1.0, 0.0, -1.0).lerp(Vec3::new(1.0, 2.0, -1.0), t));
        targets.push(Vec3::new(-1.0, 0.0, 1.0).lerp(Vec3::new(1.0, 0.0, -1.0), t));
    }
    for x in [-1.0f32, 1.0] {
        for y in [0.0f32, 2.0] {
            targets.push(Vec3::new(x, y, -1.0));
        }
        for k in 1..20 {
            let t = k as f32 / 20.0;
            targets.push(Vec3::new(x, 0.0, 1.0 - 2.0 * t));
            targets.push(Vec3::new(x, 2.0 * t, -1.0));
        }
    }
    targets
}

const EDGE_EYE: Vec3 = Vec3::new(0.05, 1.1, 3.4);

/// Camera rays exactly through triangle edges and vertices give sane samples; a ray that
/// hits does so at its target or in front of it (the mirror box and sphere may stand in
/// the way), never behind. Rays through the corners of the light, a quad hanging free
/// below the ceiling, may hit it or pass it to the ceiling. (Whether a ray may slip
/// through a closed edge is the scene's intersector's business: see the ignored test
/// below.)
#[test]
fn rays_along_edges_and_through_vertices() {
    let tracer = tracer(cornell());
    let scene = tracer.scene();
    let targets = closed_edge_targets();
    let rays: Vec<Ray> = targets
        .iter()
        .map(|t| Ray::new(EDGE_EYE, (*t - EDGE_EYE).normalize()))
        .collect();
    let samples = tracer.trace(&rays, 21);
    let mut wrong = Vec::new();
    let mut hits = 0;
    for ((s, t), r) in samples.iter().zip(&targets).zip(&rays) {
        assert_sane(s, "edge ray");
        let d = (*t - EDGE_EYE).length();
        if s.distance.is_finite() {
            hits += 1;
            let blocked = scene.closest_hit(r, d * (1.0 - 1e-4)).is_some();
            if s.distance > d * (1.0 + 1e-5) || (!blocked && (s.distance - d).abs() > 1e-4 * d) {
                wrong.push(format!("target {t}: {s:?} (expected {d})"));
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    assert!(
        hits * 10 >= rays.len() * 9,
        "only {hits} of {} edge rays hit",
        rays.len()
    );
    let light_corners: Vec<Ray> = [
        (-0.25f32, -0.25f32),
        (-0.25, 0.25),
        (0.25, -0.25),
        (0.25, 0.25),
    ]
    .iter()
    .map(|&(x, z)| Ray::new(EDGE_EYE, (Vec3::new(x, 1.98, z) - EDGE_EYE).normalize()))
    .collect();
    for s in tracer.trace(&light_corners, 22) {
        assert_sane(&s, "light corner");
        assert!(s.distance.is_finite());
    }
}

/// Rays through the edges two triangles share never escape a closed box: the scene's
/// intersector widens its barycentric bounds (`holocave_scene::bvh::EDGE_TOLERANCE`)
/// because Möller–Trumbore in f32 alone is not watertight (a ray from (0.05, 1.1, 3.4) to
/// the floor point (−0.25, 0, 0.25) got u = −9e-8 in one triangle, v = −1.8e-7 in the
/// other, and missed both).
#[test]
fn rays_through_closed_edges_never_leak() {
    let scene = cornell();
    let mut leaks = Vec::new();
    for t in closed_edge_targets() {
        let d = (t - EDGE_EYE).normalize();
        // The ray as given, and as the tracer renormalises it.
        for dir in [d, d.normalize()] {
            if scene
                .closest_hit(&Ray::new(EDGE_EYE, dir), f32::INFINITY)
                .is_none()
            {
                leaks.push(format!("{t} ({dir})"));
            }
        }
    }
    assert!(
        leaks.is_empty(),
        "rays escaped through edges: {}",
        leaks.join(", ")
    );
}

/// `-0.0` in a direction must not change anything: obvhs misses every hit for such
/// rays unless the scene turns it into +0.0. Bit-for-bit the same sample as with +0.0.
#[test]
fn negative_zero_direction_components() {
    let tracer = tracer(cornell());
    let cases = [
        // (origin, direction with zeros, distance to the wall it hits)
        (Vec3::new(0.3, 0.7, 3.4), Vec3::new(0.0, 0.0, -1.0), 4.4),
        (Vec3::new(0.3, 1.5, 0.8), Vec3::new(0.0, -1.0, 0.0), 1.5),
        (Vec3::new(0.3, 1.5, 0.2), Vec3::new(-1.0, 0.0, 0.0), 1.3),
        (Vec3::new(-0.3, 1.5, 0.2), Vec3::new(1.0, 0.0, 0.0), 1.3),
    ];
    for (o, d, dist) in cases {
        let plus = tracer.trace_serial(&[Ray::new(o, d)], 9)[0];
        assert!((plus.distance - dist).abs() < 1e-5, "{plus:?}");
        for mask in 0..8u32 {
            let mut dm = d;
            for axis in 0..3 {
                if mask & (1 << axis) != 0 && dm[axis] == 0.0 {
                    dm[axis] = -0.0;
                }
            }
            let s = tracer.trace_serial(&[Ray::new(o, dm)], 9)[0];
            assert_eq!(
                s.radiance.map(f32::to_bits),
                plus.radiance.map(f32::to_bits),
                "{dm:?}"
            );
            assert_eq!(s.distance.to_bits(), plus.distance.to_bits(), "{dm:?}");
        }
    }
}

/// Zero, NaN and infinite directions, NaN or infinite origins: no radiance, infinite
/// distance. Directions that are finite but tiny (subnormal) or huge mean the same as
/// their normalised selves.
#[test]
fn degenerate_rays() {
    let tracer = tracer(cornell());
    let o = Vec3::new(0.3, 0.7, 3.4);
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    let bad = [
        Ray::new(o, Vec3::ZERO),
        Ray::new(o, Vec3::new(-0.0, -0.0, -0.0)),
        Ray::new(o, Vec3::new(nan, 0.0, -1.0)),
        Ray::new(o, Vec3::splat(nan)),
        Ray::new(o, Vec3::new(0.0, 0.0, -inf)),
        Ray::new(o, Vec3::new(inf, -inf, 1.0)),
        Ray::new(Vec3::new(nan, 0.7, 3.4), Vec3::NEG_Z),
        Ray::new(Vec3::new(0.3, inf, 3.4), Vec3::NEG_Z),
        Ray::new(Vec3::splat(-inf), Vec3::ONE),
    ];
    for (i, s) in tracer.trace(&bad, 1).iter().enumerate() {
        assert_eq!(s.radiance, [0.0; 3], "{:?}", bad[i]);
        assert_eq!(s.distance, f32::INFINITY, "{:?}", bad[i]);
        assert_eq!(s.virtual_distance, f32::INFINITY, "{:?}", bad[i]);
    }
    let unit = tracer.trace_serial(&[Ray::new(o, Vec3::NEG_Z)], 4)[0];
    for scale in [1e-40f32, 1e-30, 1e30, 3e38] {
        let s = tracer.trace_serial(&[Ray::new(o, Vec3::NEG_Z * scale)], 4)[0];
        assert_eq!(s, unit, "direction scaled by {scale}");
    }
    // Far-away and huge origins pointing anywhere: sane.
    let mut rng = Pcg32::seed_from_u64(2);
    let rays: Vec<Ray> = (0..2000)
        .map(|i| {
            let r = [1e6f32, 1e12, 1e20, 3e38][i % 4];
            Ray::new(uniform_sphere(&mut rng) * r, uniform_sphere(&mut rng))
        })
        .collect();
    for s in tracer.trace(&rays, 5) {
        assert_sane(&s, "huge origin");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, failure_persistence: None, ..ProptestConfig::default() })]

    /// Any bit patterns at all for origin and direction: a sane sample, no panic.
    #[test]
    fn arbitrary_rays_are_sane(o in prop::array::uniform3(any::<u32>()), d in prop::array::uniform3(any::<u32>()),
                               near in prop::array::uniform3(-3.0f32..3.0), dn in prop::array::uniform3(-1.0f32..1.0)) {
        thread_local! {
            static TRACER: Tracer = tracer(cornell());
        }
        TRACER.with(|t| {
            let wild = Ray::new(Vec3::from(o.map(f32::from_bits)), Vec3::from(d.map(f32::from_bits)));
            let tame = Ray::new(Vec3::from(near), Vec3::from(dn));
            let mixed = Ray::new(Vec3::from(near), Vec3::from(d.map(f32::from_bits)));
            for s in t.trace_serial(&[wild, tame, mixed], 1) {
                assert_sane(&s, "proptest");
            }
        });
    }
}
