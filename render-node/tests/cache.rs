//! The render cache's steps on a tiny image, checked pixel by pixel.

use glam::{Mat4, Vec2, Vec3, Vec4};
use holocave_cave::{Size, WallView};
use holocave_render_node::cache::{GpuPoint, ObjectMove, SampleSurface, ShadowLight, surface_id};
use holocave_render_node::{EyeView, Gpu, NewSample, RenderCache, StepTimes};
use holocave_vlf::Lookup;

const W: u32 = 8;
const H: u32 = 8;

fn view(eye: Vec3) -> EyeView {
    EyeView::looking_at(
        WallView {
            eye,
            pa: Vec3::new(-1.0, 0.0, -1.0),
            pb: Vec3::new(1.0, 0.0, -1.0),
            pc: Vec3::new(-1.0, 2.0, -1.0),
            size: Size::new(W, H),
        },
        0.05,
    )
    .expect("the eye is in front of the wall")
}

fn cache(capacity: u32) -> RenderCache {
    let gpu = Gpu::new().expect("a wgpu adapter (install mesa-vulkan-drivers without a GPU)");
    RenderCache::new(gpu, &[Size::new(W, H)], capacity, 64)
}

/// A sample for pixel (x, y) of `v` at distance `d` along its centre ray.
fn sample(v: &EyeView, x: u32, y: u32, d: f32, rad: f32) -> NewSample {
    sample_on(v, x, y, d, rad, 1)
}

/// The same, on surface `surface`.
fn sample_on(v: &EyeView, x: u32, y: u32, d: f32, rad: f32, surface: u32) -> NewSample {
    let r = v.wall.ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
    NewSample::new(y * W + x, r.origin, r.at(d), d, [rad; 3], surface)
}

fn draw(c: &mut RenderCache, v: &EyeView) -> Vec<u32> {
    c.draw(&[*v], &[8], false, &mut StepTimes::default())
        .remove(0)
}

#[test]
fn a_point_shows_at_its_pixel_and_fills_its_neighbours() {
    let v = view(Vec3::new(0.0, 1.0, 1.0));
    let mut c = cache(256);
    draw(&mut c, &v);
    c.insert(0, &[sample(&v, 1, 1, 2.0, 0.5)]);
    draw(&mut c, &v);
    let img = c.image(0);
    let cov = c.coverage(0);
    assert_eq!(img.at(1, 1), Vec3::splat(0.5));
    assert_eq!(cov[(W + 1) as usize], 1.0);
    // Every 3x3 neighbour is interpolated from it; holes with no point in their 3x3 are
    // filled from it up to four pixels away; pixels farther away stay empty.
    for (x, y) in [(0, 0), (2, 2), (1, 2), (0, 1)] {
        assert_eq!(img.at(x, y), Vec3::splat(0.5), "({x},{y})");
        assert_eq!(cov[(y * W + x) as usize], 0.5);
    }
    for (x, y) in [(3, 1), (1, 5), (5, 5), (4, 0)] {
        assert_eq!(img.at(x, y), Vec3::splat(0.5), "({x},{y})");
        assert_eq!(cov[(y * W + x) as usize], 0.25);
    }
    for (x, y) in [(6, 1), (1, 6), (7, 7)] {
        assert_eq!(img.at(x, y), Vec3::ZERO, "({x},{y})");
        assert_eq!(cov[(y * W + x) as usize], 0.0);
    }
}

#[test]
fn the_nearer_point_wins_and_a_point_far_behind_its_neighbours_is_culled() {
    let v = view(Vec3::new(0.0, 1.0, 1.0));
    let mut c = cache(256);
    draw(&mut c, &v);
    // A wall of near points at distance 2, one pixel with only a far point at 5 behind,
    // and one pixel with both (the near one must win).
    let mut s = Vec::new();
    for y in 0..H {
        for x in 0..W {
            if (x, y) != (4, 4) {
                s.push(sample(&v, x, y, 2.0, 1.0));
            }
        }
    }
    // The far point was traced from 1 cm aside (reprojected: a ray from this eye might
    // have been stopped by what is in front of it).
    let aside = view(v.eye() + Vec3::new(0.01, 0.0, 0.0));
    let far = v.wall.ray(Vec2::new(4.5, 4.5)).at(5.0);
    let d = (far - aside.eye()).length();
    s.push(NewSample::new(4 * W + 4, aside.eye(), far, d, [9.0; 3], 1));
    c.insert(0, &s);
    draw(&mut c, &v);
    // The far point's pixel is culled and interpolated.
    let img = c.image(0);
    assert_eq!(c.coverage(0)[(4 * W + 4) as usize], 0.5);
    assert_eq!(img.at(4, 4), Vec3::splat(1.0));
    // A point traced from this very eye is never culled: its ray hit nothing nearer.
    let mut c2 = cache(256);
    draw(&mut c2, &v);
    let mut s2: Vec<NewSample> = s[..s.len() - 1].to_vec();
    s2.push(sample(&v, 4, 4, 5.0, 9.0));
    c2.insert(0, &s2);
    draw(&mut c2, &v);
    assert_eq!(c2.coverage(0)[(4 * W + 4) as usize], 1.0);
    assert_eq!(c2.image(0).at(4, 4), Vec3::splat(9.0));
    // A pixel with a near and a far point shows the near one (the far one is traced from
    // aside: from the same eye it would be averaged into the pixel's point).
    let p = v.wall.ray(Vec2::new(2.5, 2.5)).at(6.0);
    let d = (p - aside.eye()).length();
    c.insert(
        0,
        &[NewSample::new(2 * W + 2, aside.eye(), p, d, [7.0; 3], 1)],
    );
    draw(&mut c, &v);
    assert_eq!(c.image(0).at(2, 2), Vec3::splat(1.0));
}

#[test]
fn samples_from_the_same_eye_average_and_the_ray_nearest_the_eye_wins() {
    let eye = Vec3::new(0.0, 1.0, 1.0);
    let v = view(eye);
    let mut c = cache(256);
    draw(&mut c, &v);
    c.insert(0, &[sample(&v, 5, 5, 2.0, 1.0)]);
    draw(&mut c, &v);
    c.insert(0, &[sample(&v, 5, 5, 2.0, 3.0)]);
    draw(&mut c, &v);
    assert_eq!(
        c.image(0).at(5, 5),
        Vec3::splat(2.0),
        "running mean of 1 and 3"
    );

    // A sample of the same point from 10 cm to the side, with another radiance: from the
    // first eye the first point (its ray passed through the eye) still wins...
    let side = view(eye + Vec3::new(0.1, 0.0, 0.0));
    let p = v.wall.ray(Vec2::new(5.5, 5.5)).at(2.0);
    let dir = (p - side.eye()).normalize();
    let d = (p - side.eye()).length();
    c.insert(
        0,
        &[NewSample::new(
            5 * W + 5,
            side.eye(),
            side.eye() + dir * d,
            d,
            [8.0; 3],
            1,
        )],
    );
    draw(&mut c, &v);
    assert_eq!(c.image(0).at(5, 5), Vec3::splat(2.0));
    // ... and from the side eye the new one does.
    let (px, py, _) = side.project(p).unwrap();
    let mut c2 = c;
    c2.draw(&[side], &[8], false, &mut StepTimes::default());
    assert_eq!(c2.image(0).at(px as u32, py as u32), Vec3::splat(8.0));
}

#[test]
fn replacement_takes_the_oldest_point_of_a_group() {
    let v = view(Vec3::new(0.0, 1.0, 1.0));
    // One group of 8 points: the ninth sample must replace the oldest (the first).
    let mut c = cache(8);
    assert_eq!(c.capacity(), 8);
    draw(&mut c, &v);
    for i in 0..9u32 {
        c.insert(0, &[sample(&v, i % W, i / W + 2, 2.0, i as f32 + 1.0)]);
        draw(&mut c, &v); // ages every point by one frame
    }
    let mut rads: Vec<f32> = c.points().iter().map(|p| p.rad[0]).collect();
    rads.sort_by(f32::total_cmp);
    assert_eq!(rads, vec![2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
}

#[test]
fn dithering_chooses_about_the_budget_and_empty_pixels_first() {
    let v = view(Vec3::new(0.0, 1.0, 1.0));
    let gpu = Gpu::new().expect("a wgpu adapter");
    let mut c = RenderCache::new(gpu, &[Size::new(64, 64)], 8192, 4096);
    let v64 = EyeView::looking_at(
        WallView {
            size: Size::new(64, 64),
            ..v.wall
        },
        0.05,
    )
    .expect("the eye is in front of the wall");
    let chosen = c
        .draw(&[v64], &[500], false, &mut StepTimes::default())
        .remove(0);
    let n = chosen.len() as f64;
    assert!((n - 500.0).abs() < 50.0, "{n} chosen for a budget of 500");
    let mut sorted = chosen.clone();
    sorted.sort();
    sorted.dedup();
    assert_eq!(sorted.len(), chosen.len(), "each pixel chosen once");

    // Every pixel but a 16x16 hole gets a point traced from this eye (which has nothing
    // left to gain there: age 0, no miss, priority 0; a pixel with no point of its own
    // has at least 1). Asked for fewer samples than the hole has pixels, the eye spends
    // them all on the hole.
    let hole = |p: u32| (24..40).contains(&(p % 64)) && (24..40).contains(&(p / 64));
    let filled: Vec<NewSample> = (0..64 * 64u32)
        .filter(|&p| !hole(p))
        .map(|p| {
            let r = v64
                .wall
                .ray(Vec2::new((p % 64) as f32 + 0.5, (p / 64) as f32 + 0.5));
            NewSample::new(p, r.origin, r.at(2.0), 2.0, [0.5; 3], 1)
        })
        .collect();
    c.insert(0, &filled);
    let chosen = c
        .draw(&[v64], &[128], false, &mut StepTimes::default())
        .remove(0);
    let cov = c.coverage(0);
    assert!(
        (0..64 * 64u32).all(|p| hole(p) != (cov[p as usize] == 1.0)),
        "the points fill exactly the pixels outside the hole"
    );
    // The dither's tiles round by up to a sample each; at most 9 (3x3) touch the hole.
    assert!(
        chosen.len() + 9 >= 128,
        "{} pixels chosen for a budget of 128",
        chosen.len()
    );
    let outside: Vec<(u32, u32)> = chosen
        .iter()
        .filter(|&&p| !hole(p))
        .map(|&p| (p % 64, p / 64))
        .collect();
    assert!(
        outside.is_empty(),
        "{} of {} chosen pixels already have a fresh point while empty ones wait: \
         {outside:?}",
        outside.len(),
        chosen.len()
    );
}

#[test]
fn a_changed_colour_from_another_eye_ages_the_points_around_it() {
    let v = view(Vec3::new(0.0, 1.0, 1.0));
    let mut c = cache(256);
    draw(&mut c, &v);
    // A wall of points at radiance 1, each of two samples from this eye.
    let wall: Vec<NewSample> = (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .map(|(x, y)| sample(&v, x, y, 2.0, 1.0))
        .collect();
    c.insert(0, &wall);
    draw(&mut c, &v);
    c.insert(0, &wall);
    draw(&mut c, &v);
    let ages = |c: &RenderCache| -> Vec<f32> {
        let mut a: Vec<f32> = c
            .points()
            .iter()
            .filter(|p| p.pos[3] < 1e6)
            .map(|p| p.pos[3])
            .collect();
        a.sort_by(f32::total_cmp);
        a
    };
    assert!(ages(&c).iter().all(|&a| a <= 1.0));
    // A sample of pixel (4, 4) from 5 cm aside, ten times brighter: its 3x3 neighbourhood
    // ages by 16 frames (the centre's own point is then replaced or refreshed).
    let aside = v.eye() + Vec3::new(0.05, 0.0, 0.0);
    let p = v.wall.ray(Vec2::new(4.5, 4.5)).at(2.0);
    let d = (p - aside).length();
    c.insert(0, &[NewSample::new(4 * W + 4, aside, p, d, [10.0; 3], 1)]);
    let a = ages(&c);
    let aged = a.iter().filter(|&&x| x >= 16.0).count();
    assert_eq!(aged, 9, "ages {a:?}");
}

#[test]
fn background_points_ask_for_samples_at_a_thirty_second_of_the_priority() {
    use holocave_render_node::cache::BACKGROUND;
    let v = view(Vec3::new(0.0, 1.0, 1.0));
    let mut c = cache(256);
    draw(&mut c, &v);
    // Left half: a surface 2 m away; right half: rays that escaped the scene.
    let s: Vec<NewSample> = (0..W * H)
        .map(|p| match (p % W, p / W) {
            (x, y) if x < W / 2 => sample(&v, x, y, 2.0, 0.5),
            (x, y) => sample_on(&v, x, y, 1000.0, 0.5, BACKGROUND),
        })
        .collect();
    c.insert(0, &s);
    // Ages grow by one a frame (new points show age 0 in their first frame); both kinds
    // of point are the same age throughout.
    draw(&mut c, &v);
    for frames in 2..=40 {
        draw(&mut c, &v);
        let pr = c.priority_image(0);
        let scene = pr.at(1, 4).x;
        let sky = pr.at(6, 4).x;
        assert!(
            scene > 0.0,
            "frame {frames}: a scene point asks for nothing"
        );
        // Same age, rays from this very eye (no miss term): exactly 1/32 of the priority.
        assert!(
            (sky * 32.0 - scene).abs() <= 1e-5 * scene,
            "frame {frames}: scene {scene}, background {sky}"
        );
    }
    // Old points saturate at 1; old background at 1/32.
    let pr = c.priority_image(0);
    assert_eq!(pr.at(1, 4).x, 1.0);
    assert_eq!(pr.at(6, 4).x, 1.0 / 32.0);
}

#[test]
fn a_lambertian_sample_joins_the_point_from_a_far_eye_and_another_does_not() {
    // A point of pixel (4, 4) made from this eye (radiance 1), then a sample of the same
    // place on the same surface from 30 cm aside (beyond the 2 cm within which any
    // surface's samples may join) with radiance 3: marked view-independent it joins the
    // point (one point, the mean 2 of two samples); unmarked it becomes a point of its own.
    let v = view(Vec3::new(0.0, 1.0, 1.0));
    let aside = v.eye() + Vec3::new(0.3, 0.0, 0.0);
    let p = v.wall.ray(Vec2::new(4.5, 4.5)).at(2.0);
    let far = NewSample::new(4 * W + 4, aside, p, (p - aside).length(), [3.0; 3], 1);
    let mut points = Vec::new();
    for sample in [far.view_independent(), far] {
        let mut c = cache(256);
        draw(&mut c, &v);
        c.insert(0, &[self::sample(&v, 4, 4, 2.0, 1.0)]);
        draw(&mut c, &v);
        c.insert(0, &[sample]);
        let mut valid: Vec<[f32; 2]> = (c.points().iter())
            .filter(|p| p.pos[3] < 1e6)
            .map(|p| [p.rad[0], p.rad[3]])
            .collect();
        valid.sort_by(|a, b| a[0].total_cmp(&b[0]));
        points.push(valid);
    }
    assert_eq!(
        points[0],
        [[2.0, 2.0]],
        "marked: radiance and count of the points"
    );
    assert_eq!(points[1], [[1.0, 1.0], [3.0, 1.0]], "unmarked");
}

/// A sample of `surface` at `position`, seen from `v`'s eye through pixel `pixel`.
fn sample_at(v: &EyeView, pixel: u32, position: Vec3, rad: f32, surface: u32) -> NewSample {
    let d = (position - v.eye()).length();
    NewSample::new(pixel, v.eye(), position, d, [rad; 3], surface)
}

#[test]
fn points_on_a_moved_object_move_with_it_and_its_shadows_are_dropped() {
    // An object (a sphere of 10 cm around `at`) moves 50 cm along x under a sun straight
    // above. Its point moves by the same translation (ray origin too), keeps one
    // sample's weight and asks first to be resampled; a static point under it where it
    // was and one where it is now are dropped; one aside is kept as it was.
    let v = view(Vec3::new(0.0, 1.0, 1.0));
    let at = v.wall.ray(Vec2::new(3.5, 0.5)).at(2.5);
    let shift = Vec3::new(0.5, 0.0, 0.0);
    let on_object = surface_id(2, SampleSurface::Object(0));
    let under_before = at - Vec3::new(0.0, 0.6, 0.0);
    let under_after = under_before + shift;
    let aside = at + Vec3::new(0.25, -0.6, 0.0);
    let mut c = cache(256);
    draw(&mut c, &v);
    c.insert(0, &[sample_at(&v, 3, at, 1.0, on_object)]);
    draw(&mut c, &v);
    c.insert(
        0,
        &[
            sample_at(&v, 3, at, 3.0, on_object),
            sample_at(&v, 10, under_before, 1.0, 1),
            sample_at(&v, 20, under_after, 1.0, 1),
            sample_at(&v, 30, aside, 1.0, 1),
        ],
    );
    let valid = |c: &RenderCache| -> Vec<GpuPoint> {
        (c.points().into_iter())
            .filter(|p| p.pos[3] < 1e6)
            .collect()
    };
    let before = valid(&c);
    assert_eq!(before.len(), 4, "{before:?}");
    let object_point = |ps: &[GpuPoint]| {
        *ps.iter()
            .find(|p| p.origin[3].to_bits() == on_object)
            .expect("the object's point")
    };
    let was = object_point(&before);
    assert_eq!(was.rad[3], 2.0, "two samples averaged");
    c.move_objects(
        &[ObjectMove::new(
            0,
            Mat4::from_translation(shift),
            at.extend(0.1),
            (at + shift).extend(0.1),
        )],
        &[ShadowLight::distant(Vec3::Y, 0.0047)],
    );
    let after = valid(&c);
    assert_eq!(
        after.len(),
        2,
        "the two points under the object dropped: {after:?}"
    );
    let moved = object_point(&after);
    let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-5;
    assert!(
        close(Vec4::from(moved.pos).truncate(), at + shift),
        "{moved:?}"
    );
    assert!(
        close(Vec4::from(moved.origin).truncate(), v.eye() + shift),
        "{moved:?}"
    );
    assert_eq!(moved.rad[0], 2.0, "its radiance kept");
    assert_eq!(moved.rad[3], 1.0, "worth one sample");
    assert!(
        moved.pos[3] >= 32.0,
        "aged to the highest priority: {moved:?}"
    );
    let kept = after.iter().find(|p| p.origin[3].to_bits() == 1).unwrap();
    assert!(close(Vec4::from(kept.pos).truncate(), aside), "{kept:?}");
    assert_eq!(
        *kept,
        *before
            .iter()
            .find(|p| p.origin[3].to_bits() == 1 && close(Vec4::from(p.pos).truncate(), aside))
            .unwrap()
    );
}

#[test]
fn a_point_blends_only_where_the_pixel_sees_the_same_object() {
    // The light field gives 1 everywhere, worth one sample; a static point of radiance 3
    // shows at pixel (4, 4) and a point on object 0 of radiance 5 at (2, 2). Where the
    // pixel sees what the point lies on, the two blend; where it sees another (the object
    // over the room's point, the room over the object's point), the light field alone
    // shows.
    let v = view(Vec3::new(0.0, 1.0, 1.0));
    let mut c = cache(256);
    c.set_vlf(&[[1.0; 3]], 1.0).unwrap();
    let lookups = |objects: [u32; 2]| -> Vec<Lookup> {
        (0..W * H)
            .map(|i| Lookup {
                base: 0,
                res: 1,
                weight: [1.0; 3],
                object: match i {
                    36 => objects[0],
                    18 => objects[1],
                    _ => 0,
                },
                ..Lookup::NONE
            })
            .collect()
    };
    c.set_lookups(0, &lookups([0, 1]));
    draw(&mut c, &v);
    c.insert(
        0,
        &[
            sample(&v, 4, 4, 2.0, 3.0),
            sample_on(&v, 2, 2, 2.0, 5.0, surface_id(1, SampleSurface::Object(0))),
        ],
    );
    let shown = |c: &mut RenderCache, objects: [u32; 2]| {
        c.set_lookups(0, &lookups(objects));
        draw(c, &v);
        let img = c.image(0);
        (img.at(4, 4).x, img.at(2, 2).x)
    };
    // n = 1 sample discounted by its age (64 / (64 + age)), age at most a frame or two.
    let (room, object) = shown(&mut c, [0, 1]);
    assert!(room > 1.9 && room <= 2.0, "{room}");
    assert!(object > 2.9 && object <= 3.0, "{object}");
    assert_eq!(shown(&mut c, [1, 0]), (1.0, 1.0));
    assert_eq!(shown(&mut c, [2, 2]), (1.0, 1.0));
}

#[test]
fn a_sample_of_an_object_never_joins_a_point_of_the_room_from_the_same_eye() {
    // A converged point of the wall at pixel (4, 4); then an object moves in front of it
    // and a sample from the same eye hits the object, nearer: it becomes a point of its
    // own (the object's), and the wall's point keeps its samples.
    let v = view(Vec3::new(0.0, 1.0, 1.0));
    let mut c = cache(256);
    for _ in 0..4 {
        draw(&mut c, &v);
        c.insert(0, &[sample(&v, 4, 4, 2.0, 1.0)]);
    }
    draw(&mut c, &v);
    c.insert(
        0,
        &[sample_on(
            &v,
            4,
            4,
            1.0,
            5.0,
            surface_id(1, SampleSurface::Object(0)),
        )],
    );
    let mut valid: Vec<[f32; 2]> = (c.points().iter())
        .filter(|p| p.pos[3] < 1e6)
        .map(|p| [p.rad[0], p.rad[3]])
        .collect();
    valid.sort_by(|a, b| a[0].total_cmp(&b[0]));
    assert_eq!(
        valid,
        [[1.0, 4.0], [5.0, 1.0]],
        "radiance and count of the points"
    );
}

/// The light field's worth per pixel follows how the pixel's own samples spread
/// (`cache/shade_field.wgsl`, `pixel_prior`). The field gives 1 everywhere, worth `prior` = 10
/// samples where a sample's variance over `μ² + 0.01` is the display's `spread` (0.25).
/// Pixel (4, 4) takes eight samples of 3 (variance 0), pixel (2, 2) eight alternating 1
/// and 5 (mean 3, unbiased variance 4 · 8/7); each pixel's variance is pooled with the
/// display's, worth 8 degrees of freedom against its own 7:
/// `k = prior · (8 · spread · s + 7 · v) / (15 · spread · s)`, `s = 3² + 0.01`. So the
/// agreeing pixel shows more of its samples (k 5.3) than the scattered one (k 14.8); with
/// one `k` both would show `(10 + 8 · 3) / 18`.
#[test]
fn the_field_gives_way_sooner_where_a_pixels_samples_agree() {
    let v = view(Vec3::new(0.0, 1.0, 1.0));
    let mut c = cache(256);
    let (prior, spread) = (10.0f32, 0.25f32);
    c.set_vlf(&[[1.0; 3]], prior).unwrap();
    c.set_vlf_prior(prior, spread);
    let lookups: Vec<Lookup> = (0..W * H)
        .map(|_| Lookup {
            base: 0,
            res: 1,
            weight: [1.0; 3],
            ..Lookup::NONE
        })
        .collect();
    c.set_lookups(0, &lookups);
    let n = 8;
    for j in 0..n {
        draw(&mut c, &v);
        let scattered = if j % 2 == 0 { 1.0 } else { 5.0 };
        c.insert(
            0,
            &[sample(&v, 4, 4, 2.0, 3.0), sample(&v, 2, 2, 2.0, scattered)],
        );
    }
    c.set_lookups(0, &lookups);
    draw(&mut c, &v);
    let img = c.image(0);
    let s = 9.01f32;
    let k = |variance: f32| prior * (8.0 * spread * s + 7.0 * variance) / (15.0 * spread * s);
    // n samples discounted by their age (64 / (64 + age)), age at most a frame or two.
    let shown = |k: f32, n: f32| (k + n * 3.0) / (k + n);
    let within = |got: f32, k: f32| {
        let (a, b) = (shown(k, n as f32 * 64.0 / 66.0), shown(k, n as f32));
        got >= a.min(b) - 1e-4 && got <= a.max(b) + 1e-4
    };
    let (agreeing, scattered) = (img.at(4, 4).x, img.at(2, 2).x);
    let (ka, kb) = (k(0.0), k(4.0 * 8.0 / 7.0));
    assert!(
        within(agreeing, ka),
        "agreeing samples: shown {agreeing}, k {ka} gives {}",
        shown(ka, n as f32)
    );
    assert!(
        within(scattered, kb),
        "scattered samples: shown {scattered}, k {kb} gives {}",
        shown(kb, n as f32)
    );
}

/// A point whose samples from one eye hit two surfaces (a pixel across an emitter's edge:
/// a wall at 2 m, radiance 1, and a lamp 5 cm nearer, radiance 9) stands for that pixel
/// seen from there. From that eye it shows as the pixel's mean; from 30 cm aside a
/// view-independent sample of the lamp at the very place it keeps does not join it, and
/// where it projects among that eye's own points 5 % farther it hides none of them. (A
/// lamp-edge point taken over by the other eye of a still head showed the lamp's light
/// in a ceiling pixel of the Cornell box.)
#[test]
fn a_point_mixing_two_surfaces_stands_only_for_its_own_pixel() {
    let (wall, lamp) = (1, 2);
    let v = view(Vec3::new(0.0, 1.0, 1.0));
    let mixed = |c: &mut RenderCache| {
        draw(c, &v);
        let s = sample_on(&v, 4, 4, 2.0, 1.0, wall).view_independent();
        c.insert(0, &[s]);
        draw(c, &v);
        let s = sample_on(&v, 4, 4, 1.95, 9.0, lamp).view_independent();
        c.insert(0, &[s]);
        draw(c, &v);
    };
    let mut c = cache(256);
    mixed(&mut c);
    assert_eq!(c.image(0).at(4, 4), Vec3::splat(5.0), "the pixel's mean");

    let aside = view(v.eye() + Vec3::new(0.3, 0.0, 0.0));
    let at = v.wall.ray(Vec2::new(4.5, 4.5)).at(1.95);
    let (px, py, depth) = aside.project(at).expect("in view aside");
    let (px, py) = (px as u32, py as u32);
    c.draw(&[aside], &[8], false, &mut StepTimes::default());
    assert_eq!(
        c.image(0).at(px, py),
        Vec3::splat(5.0),
        "shown where nothing else is"
    );
    let lamp_aside = sample_at(&aside, py * W + px, at, 9.0, lamp).view_independent();
    c.insert(0, &[lamp_aside]);
    let mut points: Vec<[f32; 2]> = (c.points().iter())
        .filter(|p| p.pos[3] < 1e6)
        .map(|p| [p.rad[0], p.rad[3]])
        .collect();
    points.sort_by(|a, b| a[0].total_cmp(&b[0]));
    assert_eq!(
        points,
        [[5.0, 2.0], [9.0, 1.0]],
        "radiance and count of the points"
    );

    let mut c = cache(256);
    mixed(&mut c);
    let behind = sample_on(&aside, px, py, 1.05 * depth, 0.5, wall).view_independent();
    c.draw(&[aside], &[8], false, &mut StepTimes::default());
    c.insert(0, &[behind]);
    c.draw(&[aside], &[8], false, &mut StepTimes::default());
    assert_eq!(
        c.image(0).at(px, py),
        Vec3::splat(0.5),
        "the eye's own point shows"
    );
}
