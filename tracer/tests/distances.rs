//! First-hit and virtual distances: the virtual distance runs on through flat mirrors
//! and flat glass to the first surface that is not a delta reflector, and stops at
//! curved or rough ones.

use crate::common;

use common::*;
use glam::Vec3;
use holocave_scene::{Daylight, Ray};

/// A square in the plane `z = z0`, facing `+Z` if `up`, else `−Z`, half-size `h`.
fn square(z0: f32, h: f32, up: bool) -> Vec<[Vec3; 3]> {
    let (a, b, c, d) = (
        Vec3::new(-h, -h, z0),
        Vec3::new(h, -h, z0),
        Vec3::new(h, h, z0),
        Vec3::new(-h, h, z0),
    );
    if up {
        vec![[a, b, c], [a, c, d]]
    } else {
        vec![[a, c, b], [a, d, c]]
    }
}

#[test]
fn virtual_distance_through_a_flat_mirror_and_flat_glass() {
    let wall = lambert(Vec3::splat(0.5), Vec3::ONE, true);
    let d = Vec3::new(0.3, 0.1, -1.0).normalize();
    let eye = Vec3::new(0.0, 0.0, 1.0);
    let to_z = |z: f32| (eye.z - z) / -d.z; // length along d from the eye to plane z
    // A bounce restarts 1e-4 (1 + |p|) off the surface, shortening the next segment by
    // up to ~1.1e-4 at this angle: the tolerance on virtual distances.
    let tol = 3e-4;
    // A flat mirror at z = 0 and an emitting wall at z = 2 (seen after the bounce).
    let mirror = material(Vec3::ONE, 1.0, 0.0, 0.0);
    let scene = scene_from(
        vec![
            (square(0.0, 10.0, true), mirror),
            (square(2.0, 10.0, false), wall.clone()),
        ],
        Daylight::default(),
    );
    let tracer_ = tracer(scene);
    let s = tracer_.trace(&[Ray::new(eye, d)], 1)[0];
    let first = to_z(0.0);
    assert!((s.distance - first).abs() < 1e-5, "{s:?}");
    // The first hit's material is the mirror's (the first group), not the wall's seen in it;
    // a ray away from both hits nothing.
    assert_eq!(s.material, Some(0), "{s:?}");
    let away = tracer_.trace(&[Ray::new(eye, Vec3::X)], 1)[0];
    assert_eq!((away.material, away.distance), (None, f32::INFINITY));
    // Reflected upwards it travels 2 / |d.z| to the wall.
    assert!(
        (s.virtual_distance - (first + 2.0 / -d.z)).abs() < tol,
        "{s:?}"
    );

    // A rough mirror stops the virtual distance at itself.
    let rough = material(Vec3::ONE, 1.0, 0.5, 0.0);
    let scene = scene_from(
        vec![
            (square(0.0, 10.0, true), rough),
            (square(2.0, 10.0, false), wall.clone()),
        ],
        Daylight::default(),
    );
    let s = tracer(scene).trace(&[Ray::new(eye, d)], 1)[0];
    assert_eq!(s.virtual_distance, s.distance);

    // A flat sheet of smooth glass at z = 0 above an emitting floor at z = −1: the path
    // either reflects (then the virtual distance runs on to the wall at z = 2) or passes
    // (to the floor at z = −1, refracted); either way it runs on past the glass.
    let glass = material(Vec3::ONE, 0.0, 0.0, 1.0);
    let scene = scene_from(
        vec![
            (square(0.0, 10.0, true), glass),
            (square(2.0, 10.0, false), wall.clone()),
            (square(-1.0, 10.0, true), wall),
        ],
        Daylight::default(),
    );
    let rays = vec![Ray::new(eye, d); 2000];
    let mut through = 0;
    for s in tracer(scene).trace(&rays, 3) {
        assert!((s.distance - first).abs() < 1e-5, "{s:?}");
        let reflected = first + 2.0 / -d.z;
        if (s.virtual_distance - reflected).abs() < tol {
            continue;
        }
        // Through the sheet: along the refracted direction to z = −1 (single interface,
        // so the floor is seen inside the glass, at η = 1.5).
        let sin_t = (1.0 - d.z * d.z).sqrt() / 1.5;
        let cos_t = (1.0 - sin_t * sin_t).sqrt();
        assert!(
            (s.virtual_distance - (first + 1.0 / cos_t)).abs() < tol,
            "{s:?}"
        );
        through += 1;
    }
    // Fresnel at this angle reflects ~4%: most rays pass.
    assert!(through > 1800, "{through}");
}

/// The Cornell glass sphere has smooth (interpolated) normals: it is not flat, so the
/// virtual distance stops on it.
#[test]
fn virtual_distance_stops_on_curved_glass() {
    let t = tracer(cornell());
    let eye = Vec3::new(0.45, 0.35, 3.0);
    let s = t.trace(&[Ray::new(eye, -Vec3::Z)], 1)[0];
    // The sphere's front at z = 0.3 + 0.35.
    assert!((s.distance - (3.0 - 0.65)).abs() < 0.01, "{s:?}");
    assert_eq!(s.virtual_distance, s.distance);
}
