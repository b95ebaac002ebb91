use glam::{Vec2, Vec3};
use holocave_cave::{Size, WallView};
use holocave_tracer::bsdf::Bsdf;

use super::*;

/// A 3 × 2 m screen at z = −1.5 seen from `eye`, 48 × 32 pixels.
fn view(eye: Vec3) -> WallView {
    WallView {
        eye,
        pa: Vec3::new(-1.5, 0.0, -1.5),
        pb: Vec3::new(1.5, 0.0, -1.5),
        pc: Vec3::new(-1.5, 2.0, -1.5),
        size: Size {
            width: 48,
            height: 32,
        },
    }
}

/// What each pixel of `v` sees: the wall at z = −3 (triangle 0) and, where given, a
/// square panel at z = −2 (triangle 1) between x and y in `panel`.
fn points(v: &WallView, panel: Option<[f32; 2]>) -> Vec<Option<DirectPoint>> {
    let w = v.size.width as usize;
    (0..v.size.area())
        .map(|i| {
            let ray = v.ray(Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5));
            let at = |z: f32| ray.origin + ray.dir * ((z - ray.origin.z) / ray.dir.z);
            let near = at(-2.0);
            let on_panel = panel.is_some_and(|[a, b]| {
                (a..=b).contains(&near.x) && (a + 1.0..=b + 1.0).contains(&near.y)
            });
            let (triangle, position) = if on_panel { (1, near) } else { (0, at(-3.0)) };
            Some(DirectPoint {
                triangle,
                position,
                normal: Vec3::Z,
                shading_normal: Vec3::Z,
                wo: -ray.dir,
                bsdf: Bsdf::new(&Default::default()),
                weight: Vec3::ONE,
                albedo: Vec3::ONE,
                surfaces: Vec3::ZERO,
                reflected: None,
                span: [Vec3::X * 0.01, Vec3::Y * 0.01],
                gathered: false,
            })
        })
        .collect()
}

fn staggered(v: &WallView) -> Vec<u8> {
    (0..v.size.area()).map(|i| stagger(v, i)).collect()
}

/// How far from the centre of pixel `j` of `v` the point `p` lies, in pixels along x or
/// along y, whichever is more.
fn off_centre(v: &WallView, p: Vec3, j: usize) -> f64 {
    let (x, y) = v
        .project((p - v.eye).as_dvec3())
        .expect("in front of the eye");
    let w = v.size.width as usize;
    let (cx, cy) = ((j % w) as f64 + 0.5, (j / w) as f64 + 0.5);
    (x - cx).abs().max((y - cy).abs())
}

/// An eye moving 2 cm sideways: each carried point lies in the pixel that carries it
/// (within half a pixel of its centre), and
/// about an eighth of the view is drawn anew (the eighth at its age limit, and the view's
/// edge), not all of it.
#[test]
fn a_moving_eye_carries_most_pixels_each_to_the_pixel_its_point_lies_in() {
    let (a, b) = (
        view(Vec3::new(0.0, 1.6, 0.0)),
        view(Vec3::new(0.02, 1.6, 0.0)),
    );
    let seen = points(&a, None);
    let carried = carry(&a, &b, (&seen, &staggered(&a)), |_| DIFFUSE_AGE);
    for (j, f) in carried.from.iter().enumerate() {
        if let Some(i) = f {
            let p = seen[*i as usize].expect("a point").position;
            let off = off_centre(&b, p, j);
            assert!(
                off <= 1.0,
                "pixel {j} carries pixel {i}'s point {off} pixels away"
            );
        }
    }
    let share = carried.drawn() as f32 / b.size.area() as f32;
    assert!(
        (0.1..0.2).contains(&share),
        "{:.0} % of the pixels drawn anew",
        share * 100.0
    );
}

/// Carried on and on (the eye moving a little each frame), no pixel goes longer than its
/// age limit without being drawn anew: the diffuse ones within 8 frames, the
/// view-dependent ones within 2.
#[test]
fn no_pixel_is_carried_past_its_age_limit() {
    let mut from = view(Vec3::new(0.0, 1.6, 0.0));
    let mut seen = points(&from, None);
    let mut ages = staggered(&from);
    let n = from.size.area();
    // Bands of the wall 25 cm wide whose light depends on the eye's direction.
    let glossy = |p: &Option<DirectPoint>| (p.unwrap().position.x * 4.0).floor() as i32 % 2 == 0;
    let mut since = vec![0u8; n];
    for frame in 1..=20 {
        let to = view(Vec3::new(0.003 * frame as f32, 1.6, 0.0));
        let now = points(&to, None);
        let c = carry(&from, &to, (&seen, &ages), |i| age_limit(glossy(&seen[i])));
        // What each pixel shows is what it carried, where it carried one.
        let shown: Vec<_> = (0..n)
            .map(|j| c.from[j].map_or(now[j], |i| seen[i as usize]))
            .collect();
        since = (0..n)
            .map(|j| c.from[j].map_or(0, |i| since[i as usize] + 1))
            .collect();
        for j in 0..n {
            let limit = if glossy(&shown[j]) {
                GLOSSY_AGE
            } else {
                DIFFUSE_AGE
            };
            assert!(
                since[j] < limit,
                "frame {frame}: pixel {j} carried {} frames",
                since[j]
            );
        }
        (from, seen, ages) = (to, shown, c.ages);
    }
}

/// A panel in front of the wall, the eye moving 10 cm: every pixel carries the surface
/// it sees (where both the panel's and the wall's points land in one, the panel's); the
/// wall newly seen beside the panel and the view's edge are drawn anew, and so is each
/// pixel beside which another pixel carries the other surface (the outline).
#[test]
fn outlines_and_what_comes_into_sight_are_drawn_anew() {
    let panel = Some([-0.3, 0.3]);
    let (a, b) = (
        view(Vec3::new(0.0, 1.6, 0.0)),
        view(Vec3::new(0.1, 1.6, 0.0)),
    );
    let (seen, now) = (points(&a, panel), points(&b, panel));
    let carried = carry(&a, &b, (&seen, &vec![0; a.size.area()]), |_| DIFFUSE_AGE);
    let w = b.size.width as usize;
    let surface = |j: usize| carried.from[j].map(|i| seen[i as usize].unwrap().triangle);
    for (j, truth) in now.iter().enumerate() {
        let Some(was) = surface(j) else { continue };
        assert_eq!(
            was,
            truth.unwrap().triangle,
            "pixel {j} carries another surface"
        );
        let beside = [j.wrapping_sub(1), j + 1, j.wrapping_sub(w), j + w];
        let other = beside
            .iter()
            .any(|&k| k < b.size.area() && surface(k).is_some_and(|t| t != was));
        assert!(!other, "pixel {j} on the panel's outline carried");
    }
    let drawn = carried.drawn();
    assert!(
        drawn > 0 && drawn < b.size.area() / 3,
        "{drawn} pixels drawn anew"
    );
}

/// A view of another screen, or of another size, carries nothing.
#[test]
fn another_screen_carries_nothing() {
    let a = view(Vec3::new(0.0, 1.6, 0.0));
    let mut b = view(Vec3::new(0.0, 1.6, 0.0));
    b.pa.x -= 0.1;
    let seen = points(&a, None);
    let carried = carry(&a, &b, (&seen, &staggered(&a)), |_| DIFFUSE_AGE);
    assert_eq!(carried.drawn(), b.size.area());
}
