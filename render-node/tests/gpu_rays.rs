//! The GPU ray engine against the CPU BVH (`cargo test --release -p holocave-render-node
//! --test gpu_rays`), on whatever adapter exists (lavapipe without a GPU): closest hits
//! against `Scene::closest_hit`, any hits against `Scene::occluded`, wall rays made on the
//! GPU against `WallView::ray`.
//!
//! Every ray's answers are compared under the bound of `gpu_rays::rounding`: the same
//! triangle at `t` within it (and `u`, `v` within theirs); where the two name different
//! triangles at one distance (a shared edge, a triangle in two leaves), the GPU's must
//! really meet the ray there; and where one hits and the other does not (or hits farther),
//! the hit must be a graze: within rounding of the widened test's edge, of `t = 0` or of
//! `tmax`. Grazes are counted and must be rare (at most one ray in a thousand, plus one).

use crate::common::room;
use crate::ray_sets;

use glam::{Vec2, Vec3};
use holocave_cave::WallView;
use holocave_render_node::Gpu;
use holocave_render_node::gpu_rays::{GpuRay, GpuRays, MAX_BATCH, Query, rounding};
use holocave_scene::bvh::{Bvh, EDGE_TOLERANCE};
use holocave_scene::ray_sets::uniform2;
use holocave_scene::{Hit, Ray, Scene};
use holocave_vlf::{PixelDirect, Settings, Visibility};
use ray_sets::{camera_view, project_scene, ray_sets as sets_through, sponza};

fn gpu() -> Gpu {
    Gpu::new().expect("a GPU adapter (lavapipe where there is no GPU)")
}

/// Möller–Trumbore in f64, unbounded: `(t, u, v)`, or `None` for a ray in the plane.
fn exact(tri: &[Vec3; 3], ray: &Ray) -> Option<(f64, f64, f64)> {
    let [a, b, c] = tri.map(|p| p.as_dvec3());
    let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let s = o - a;
    let q = s.cross(e1);
    Some((e2.dot(q) / det, s.dot(p) / det, d.dot(q) / det))
}

/// Whether `tri` meets `ray` before `tmax` by the widened test, to within rounding.
fn meets(tri: &[Vec3; 3], ray: &Ray, tmax: f32) -> bool {
    let Some((t, u, v)) = exact(tri, ray) else {
        return false;
    };
    let (dt, du, dv) = rounding(tri, ray, t as f32);
    let (dt, du, dv) = (f64::from(dt), f64::from(du), f64::from(dv));
    let tol = f64::from(EDGE_TOLERANCE);
    u >= -tol - du
        && u <= 1.0 + tol + du
        && v >= -tol - dv
        && u + v <= 1.0 + tol + du + dv
        && t >= -dt
        && t < f64::from(tmax) + dt
}

/// Whether `tri` meets `ray` within rounding of an edge of the widened test, of `t = 0` or
/// of `tmax`: a hit two correct roundings may disagree on.
fn grazes(tri: &[Vec3; 3], ray: &Ray, tmax: f32) -> bool {
    let Some((t, u, v)) = exact(tri, ray) else {
        return false;
    };
    let (dt, du, dv) = rounding(tri, ray, t as f32);
    let (dt, du, dv) = (f64::from(dt), f64::from(du), f64::from(dv));
    let tol = f64::from(EDGE_TOLERANCE);
    let near = |a: f64, b: f64, d: f64| (a - b).abs() <= d;
    meets(tri, ray, tmax)
        && (near(u, -tol, du)
            || near(u, 1.0 + tol, du)
            || near(v, -tol, dv)
            || near(u + v, 1.0 + tol, du + dv)
            || near(t, 0.0, dt)
            || (tmax.is_finite() && near(t, f64::from(tmax), dt)))
}

/// What a comparison found.
#[derive(Debug, Default)]
struct Tally {
    rays: usize,
    /// Both hit the same triangle (or both missed / both occluded).
    agree: usize,
    /// Both hit, different triangles at one distance.
    other_triangle: usize,
    /// One hit where the other did not (or hit farther): grazes.
    grazes: usize,
    /// Disagreements no rounding explains, and the first few described.
    bad: usize,
    examples: Vec<String>,
}

impl Tally {
    /// Counts `t`'s rays in this tally too.
    fn add(&mut self, t: Tally) {
        self.rays += t.rays;
        self.agree += t.agree;
        self.other_triangle += t.other_triangle;
        self.grazes += t.grazes;
        self.bad += t.bad;
        self.examples.extend(t.examples);
    }

    fn fail(&mut self, s: String) {
        self.bad += 1;
        if self.examples.len() < 6 {
            self.examples.push(s);
        }
    }

    fn check(self, what: &str) -> Tally {
        self.check_ties(what, 100)
    }

    /// As [`Tally::check`], allowing one ray in `per` (plus one) to name another triangle at
    /// the same distance (each such is checked to meet the ray there): rays aimed straight
    /// at triangles find the coplanar, overlapping ones a scene has (the room has some).
    fn check_ties(self, what: &str, per: usize) -> Tally {
        eprintln!(
            "{what}: {} rays, {} agree, {} other triangle at the same distance, {} grazes, {} bad",
            self.rays, self.agree, self.other_triangle, self.grazes, self.bad
        );
        assert!(
            self.bad == 0,
            "{what}: {} disagreements beyond rounding, e.g. {:#?}",
            self.bad,
            self.examples
        );
        assert!(
            self.grazes <= self.rays / 1000 + 1,
            "{what}: {} grazing disagreements in {} rays",
            self.grazes,
            self.rays
        );
        assert!(
            self.other_triangle <= self.rays / per + 1,
            "{what}: {} rays named another triangle",
            self.other_triangle
        );
        self
    }
}

/// The GPU's closest hits against the CPU's on `rays`.
fn compare_closest(scene: &Scene, rays: &[Ray], tmax: f32, gpu: &[Option<Hit>]) -> Tally {
    assert_eq!(gpu.len(), rays.len());
    let mut tally = Tally {
        rays: rays.len(),
        ..Tally::default()
    };
    for (i, (ray, g)) in rays.iter().zip(gpu).enumerate() {
        let c = scene.closest_hit(ray, tmax);
        let tri = |h: &Hit| scene.triangle(h.triangle);
        match (g, &c) {
            (None, None) => tally.agree += 1,
            (Some(g), Some(c)) if g.triangle == c.triangle => {
                let (dt, du, dv) = rounding(tri(c), ray, c.t);
                if (g.t - c.t).abs() <= dt && (g.u - c.u).abs() <= du && (g.v - c.v).abs() <= dv {
                    tally.agree += 1;
                } else {
                    tally.fail(format!(
                        "ray {i} {ray:?}: GPU {g:?}, CPU {c:?} (bounds {dt}, {du}, {dv})"
                    ));
                }
            }
            (Some(g), Some(c)) => {
                let bound = rounding(tri(g), ray, g.t).0 + rounding(tri(c), ray, c.t).0;
                let nearer = if g.t <= c.t { g } else { c };
                if (g.t - c.t).abs() <= bound && meets(tri(g), ray, tmax) {
                    tally.other_triangle += 1;
                } else if grazes(tri(nearer), ray, tmax) {
                    tally.grazes += 1;
                } else {
                    tally.fail(format!("ray {i} {ray:?}: GPU {g:?}, CPU {c:?}"));
                }
            }
            (Some(h), None) | (None, Some(h)) => {
                if grazes(tri(h), ray, tmax) {
                    tally.grazes += 1;
                } else {
                    tally.fail(format!("ray {i} {ray:?}: GPU {g:?}, CPU {c:?}"));
                }
            }
        }
    }
    tally
}

/// The GPU's occluders against the CPU's occlusion on `rays`.
fn compare_occluded(scene: &Scene, rays: &[Ray], tmax: f32, gpu: &[Option<u32>]) -> Tally {
    assert_eq!(gpu.len(), rays.len());
    let mut tally = Tally {
        rays: rays.len(),
        ..Tally::default()
    };
    let mut hits = Vec::new();
    for (i, (ray, g)) in rays.iter().zip(gpu).enumerate() {
        let c = scene.occluded(ray, tmax);
        match (g, c) {
            (None, false) => tally.agree += 1,
            (Some(id), true) => {
                if meets(scene.triangle(*id), ray, tmax) {
                    tally.agree += 1;
                } else {
                    tally.fail(format!(
                        "ray {i} {ray:?}: GPU names triangle {id}, not on it"
                    ));
                }
            }
            (Some(id), false) => {
                if grazes(scene.triangle(*id), ray, tmax) {
                    tally.grazes += 1;
                } else {
                    tally.fail(format!("ray {i} {ray:?}: GPU occluded by {id}, CPU not"));
                }
            }
            (None, true) => {
                scene.all_hits(ray, tmax, &mut hits);
                if hits
                    .iter()
                    .all(|h| grazes(scene.triangle(h.triangle), ray, tmax))
                {
                    tally.grazes += 1;
                } else {
                    tally.fail(format!("ray {i} {ray:?}: CPU occluded ({hits:?}), GPU not"));
                }
            }
        }
    }
    tally
}

/// Rays from points scattered through `scene`'s bounds in directions over the sphere,
/// and the six axis directions written with `-0.0` components, from the bounds' centre.
fn scattered_rays(scene: &Scene, n: usize) -> Vec<Ray> {
    let (lo, hi) = scene.bounds();
    let mut rays: Vec<Ray> = (0..n as u64)
        .map(|i| {
            let (a, b) = uniform2(3 * i + 1_000_000);
            let (c, _) = uniform2(3 * i + 1_000_001);
            let (u, v) = uniform2(3 * i + 1_000_002);
            let origin = lo + (hi - lo) * Vec3::new(a, b, c);
            let z = 1.0 - 2.0 * u;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * v;
            Ray::new(origin, Vec3::new(r * phi.cos(), r * phi.sin(), z))
        })
        .collect();
    let centre = (lo + hi) * 0.5;
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            let mut d = Vec3::splat(-0.0);
            d[axis] = sign;
            rays.push(Ray::new(centre, d));
        }
    }
    rays
}

/// A ray at every `stride`-th triangle of `scene`: from a little off its face (on either
/// side, in turn) straight at its centroid. Every triangle that is there is hit by its own
/// ray unless something lies in the gap; a triangle lost on the way to the GPU is not.
fn aimed_rays(scene: &Scene, stride: usize) -> Vec<Ray> {
    (0..scene.triangle_count() as u32)
        .step_by(stride)
        .map(|i| {
            let [a, b, c] = *scene.triangle(i);
            let centre = (a + b + c) / 3.0;
            let size = (b - a).length().max((c - a).length());
            let n = scene.face_normal(i) * if i % 2 == 0 { 1.0 } else { -1.0 };
            Ray::new(centre + n * (0.01 * size), -n)
        })
        .collect()
}

/// The sets of a scene's camera view, the scattered rays (with and without an end), and
/// shadow rays towards a point (ending short of it), closest and any hit.
fn check_scene(name: &str, scene: &Scene, width: u32, height: u32) {
    let gpu = gpu();
    let mut engine = GpuRays::for_scene(&gpu, scene).expect("upload the scene");
    eprintln!(
        "{name}: {} triangles, GPU {}, stack {} entries, tree {} B, triangles {} B",
        scene.triangle_count(),
        gpu.adapter,
        engine.stack_size(),
        engine.scene_bytes().0,
        engine.scene_bytes().1
    );
    let view = camera_view(scene, width, height);
    let sets = sets_through(scene, &view);
    let scattered = scattered_rays(scene, 2000);
    let aimed = aimed_rays(scene, 1);
    let (lo, hi) = scene.bounds();
    let short = 0.3 * lo.distance(hi);
    for (set, rays, tmax) in [
        ("primary", &sets.primary, f32::INFINITY),
        ("diffuse", &sets.diffuse, f32::INFINITY),
        ("scattered", &scattered, f32::INFINITY),
        ("scattered, short", &scattered, short),
        ("aimed", &aimed, f32::INFINITY),
    ] {
        let hits = engine.closest_hits(&gpu, rays, tmax);
        let per = if set == "aimed" { 10 } else { 100 };
        compare_closest(scene, rays, tmax, &hits)
            .check_ties(&format!("{name} {set} closest hit"), per);
        let occluders = engine.occluders(&gpu, rays, tmax);
        compare_occluded(scene, rays, tmax, &occluders).check(&format!("{name} {set} any hit"));
    }
    let sun_rays = engine.occluders(&gpu, &sets.shadow, f32::INFINITY);
    compare_occluded(scene, &sets.shadow, f32::INFINITY, &sun_rays)
        .check(&format!("{name} shadow (sun) any hit"));
    // Towards a lamp at the camera, each ray ending a millimetre short of it.
    let lamp = view.eye;
    for (i, ray) in sets.diffuse.iter().enumerate().step_by(7) {
        let to = lamp - ray.origin;
        let ray = Ray::new(ray.origin, to.normalize());
        let tmax = to.length() - 1e-3;
        let g = engine.occluders(&gpu, &[ray], tmax);
        let t = compare_occluded(scene, &[ray], tmax, &g);
        assert!(t.bad == 0, "{name} lamp ray {i}: {:?}", t.examples);
    }
}

/// The per-pixel direct light's shadow rays of the room's camera view (the sun's, ending
/// nowhere, and the lamp's, each ending at its own point on the lamp), traced in one batch
/// with each ray's own `tmax`, against the CPU.
#[test]
fn the_direct_lights_shadow_rays_are_the_cpus() {
    let scene = std::sync::Arc::new(project_scene("room.gltf"));
    let vis = Visibility::of(scene.clone(), &Settings::default());
    let direct = PixelDirect::new(scene.clone());
    let view = camera_view(&scene, 64, 48);
    // Each pixel's queries, as the render node hands them over (misses: none).
    let per_pixel: Vec<Vec<_>> = vis
        .pixels_and_points(&view)
        .1
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let mut queries = Vec::new();
            if let Some(p) = p {
                for n in 0..4 {
                    direct.queries(p, i as u64, n, &mut queries);
                }
            }
            queries
        })
        .collect();
    let gpu = gpu();
    let mut engine = GpuRays::for_scene(&gpu, &scene).expect("upload the scene");
    let answers = engine.occluders_in(&gpu, &per_pixel, |q| GpuRay::new(&q.ray, q.tmax));
    let queries = per_pixel.concat();
    assert_eq!(answers.len(), queries.len());
    let finite = queries.iter().filter(|q| q.tmax.is_finite()).count();
    assert!(
        finite > 1000 && queries.len() - finite > 1000,
        "{finite} lamp and {} sun rays",
        queries.len() - finite
    );
    let mut tally = Tally::default();
    for (q, a) in queries.iter().zip(&answers) {
        tally.add(compare_occluded(&scene, &[q.ray], q.tmax, &[*a]));
    }
    tally.check("room direct light shadow rays");
}

/// More shadow rays than one batch holds, in groups of 0 to 6 (the batches split between
/// groups): every answer is its own ray's, in order.
#[test]
fn shadow_rays_beyond_one_batch_keep_their_order() {
    let scene = project_scene("room.gltf");
    let rays = scattered_rays(&scene, MAX_BATCH + 3001);
    let mut groups: Vec<Vec<GpuRay>> = Vec::new();
    let mut at = 0;
    while at < rays.len() {
        let take = (groups.len() % 7).min(rays.len() - at);
        let tmax = if groups.len().is_multiple_of(2) {
            0.75
        } else {
            f32::INFINITY
        };
        groups.push(
            rays[at..at + take]
                .iter()
                .map(|r| GpuRay::new(r, tmax))
                .collect(),
        );
        at += take;
    }
    let gpu = gpu();
    let mut engine = GpuRays::for_scene(&gpu, &scene).expect("upload the room");
    let answers = engine.occluders_in(&gpu, &groups, |r| *r);
    let flat = groups.concat();
    assert_eq!(answers.len(), flat.len());
    let mut tally = Tally::default();
    for (tmax, blocked) in [0.75, f32::INFINITY].map(|tmax| {
        let (r, a): (Vec<Ray>, Vec<Option<u32>>) = flat
            .iter()
            .zip(&answers)
            .filter(|(r, _)| r.tmax == tmax)
            .map(|(r, a)| (r.ray(), *a))
            .unzip();
        (tmax, (r, a))
    }) {
        tally.add(compare_occluded(&scene, &blocked.0, tmax, &blocked.1));
    }
    assert!(answers.iter().filter(|a| a.is_some()).count() > flat.len() / 10);
    tally.check("room shadow rays in batches");
}

#[test]
fn gpu_hits_are_the_cpu_hits_in_the_room() {
    check_scene("room", &project_scene("room.gltf"), 48, 32);
}

#[test]
fn gpu_hits_are_the_cpu_hits_in_the_cornell_box() {
    check_scene("cornell", &project_scene("cornell.gltf"), 48, 32);
}

#[test]
fn gpu_hits_are_the_cpu_hits_on_sponzas_ray_sets() {
    let Some(scene) = sponza() else {
        return;
    };
    let gpu = gpu();
    let mut engine = GpuRays::for_scene(&gpu, &scene).expect("upload Sponza");
    // The bench's sets at an eighth of its resolution (1024 × 576) each way: 9,216 primary
    // rays.
    let view = camera_view(&scene, 128, 72);
    let sets = sets_through(&scene, &view);
    eprintln!(
        "Sponza: {} triangles, stack {} entries, tree {} B, triangles {} B; {} primary, {} shadow, {} diffuse rays",
        scene.triangle_count(),
        engine.stack_size(),
        engine.scene_bytes().0,
        engine.scene_bytes().1,
        sets.primary.len(),
        sets.shadow.len(),
        sets.diffuse.len()
    );
    let inf = f32::INFINITY;
    let hits = engine.closest_hits(&gpu, &sets.primary, inf);
    compare_closest(&scene, &sets.primary, inf, &hits).check("Sponza primary closest hit");
    let occluders = engine.occluders(&gpu, &sets.shadow, inf);
    compare_occluded(&scene, &sets.shadow, inf, &occluders).check("Sponza shadow any hit");
    let hits = engine.closest_hits(&gpu, &sets.diffuse, inf);
    compare_closest(&scene, &sets.diffuse, inf, &hits).check("Sponza diffuse closest hit");
    // And one ray at each of its triangles.
    let aimed = aimed_rays(&scene, 1);
    let hits = engine.closest_hits(&gpu, &aimed, inf);
    compare_closest(&scene, &aimed, inf, &hits).check_ties("Sponza aimed closest hit", 10);
    let occluders = engine.occluders(&gpu, &aimed, inf);
    compare_occluded(&scene, &aimed, inf, &occluders).check("Sponza aimed any hit");
}

#[test]
fn a_wall_traced_on_the_gpu_is_the_cpus_wall() {
    // The room seen through a wall: rays made on the GPU (never uploaded), traced there.
    let scene = project_scene("room.gltf");
    let gpu = gpu();
    let mut engine = GpuRays::for_scene(&gpu, &scene).expect("upload the room");
    let cam = camera_view(&scene, 61, 37);
    let view = WallView {
        eye: cam.eye + Vec3::new(0.05, -0.02, 0.03),
        ..cam
    };
    for query in [Query::ClosestHit, Query::AnyHit] {
        let n = engine.trace_wall(&gpu, &view, f32::INFINITY, query);
        assert_eq!(n, 61 * 37);
        let made = engine.read_rays(&gpu, n);
        // The rays: the eye exactly, directions within a few float steps of the CPU's.
        let mut worst = 0.0f32;
        for (i, r) in made.iter().enumerate() {
            let (x, y) = (i as u32 % view.size.width, i as u32 / view.size.width);
            let cpu = view.ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            assert_eq!(Vec3::from(r.origin), cpu.origin, "pixel ({x}, {y})");
            let off = (Vec3::from(r.dir) - cpu.dir).abs().max_element();
            worst = worst.max(off);
            assert!(
                off <= 8.0 * f32::EPSILON,
                "pixel ({x}, {y}): {r:?} vs {cpu:?}"
            );
            assert_eq!(r.tmax, f32::INFINITY);
        }
        eprintln!("wall rays: directions within {worst:e} of the CPU's");
        let rays: Vec<Ray> = made.iter().map(|r| r.ray()).collect();
        match query {
            Query::ClosestHit => {
                let hits = engine.read_hits(&gpu, n);
                compare_closest(&scene, &rays, f32::INFINITY, &hits).check("room wall closest");
                assert!(hits.iter().flatten().count() > (n as usize) / 2);
            }
            Query::AnyHit => {
                let o = engine.read_occluders(&gpu, n);
                compare_occluded(&scene, &rays, f32::INFINITY, &o).check("room wall any hit");
            }
        }
    }
}

#[test]
fn negative_zeros_bad_rays_and_tmax_on_a_quad() {
    // A unit square at z = 0 (two triangles) and a second one at z = −2.
    let (a, b, c, d) = (Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y);
    let mut tris = vec![[a, b, c], [a, c, d]];
    tris.extend(tris.clone().iter().map(|t| t.map(|p| p - 2.0 * Vec3::Z)));
    let bvh = Bvh::build(&tris);
    let gpu = gpu();
    let mut engine = GpuRays::new(&gpu, &bvh).unwrap();
    let down = Vec3::new(-0.0, -0.0, -1.0);
    let rays = [
        Ray::new(Vec3::new(0.25, 0.6, 1.0), down),
        Ray::new(Vec3::new(0.7, 0.2, 1.0), down),
        Ray::new(Vec3::new(0.5, 0.5, 1.0), Vec3::ZERO),
        Ray::new(Vec3::new(0.5, 0.5, 1.0), Vec3::new(f32::NAN, 0.0, -1.0)),
        Ray::new(Vec3::new(0.5, 0.5, 1.0), Vec3::INFINITY),
        Ray::new(Vec3::new(f32::INFINITY, 0.5, 1.0), down),
        Ray::new(Vec3::new(0.5, 0.5, -1.0), Vec3::new(0.0, -0.0, 1.0)),
        Ray::new(Vec3::new(1.5, 0.5, 1.0), down),
    ];
    for tmax in [f32::INFINITY, 0.999, 1.001, 2.5, f32::NAN] {
        let hits = engine.closest_hits(&gpu, &rays, tmax);
        let occluded = engine.occluded(&gpu, &rays, tmax);
        for (i, ray) in rays.iter().enumerate() {
            let cpu = bvh.closest_hit(ray, tmax);
            assert_eq!(
                hits[i].map(|h| h.triangle),
                cpu.map(|h| h.triangle),
                "ray {i}, {tmax}"
            );
            if let (Some(g), Some(c)) = (hits[i], cpu) {
                assert!((g.t - c.t).abs() <= 1e-6, "ray {i}: {g:?} vs {c:?}");
                assert!((g.u - c.u).abs() <= 1e-6 && (g.v - c.v).abs() <= 1e-6);
            }
            assert_eq!(occluded[i], bvh.occluded(ray, tmax), "ray {i}, tmax {tmax}");
        }
    }
    // The first two rays hit at t = 1 through -0.0 components; the bad rays nothing.
    let hits = engine.closest_hits(&gpu, &rays, f32::INFINITY);
    assert!(hits[0].is_some() && hits[1].is_some() && hits[6].is_some());
    assert!(hits[2..6].iter().all(|h| h.is_none()) && hits[7].is_none());
}

/// The per-pixel direct light's rays made on the GPU from the wall's first hits kept there
/// (`ShadowMaker`) — towards the punctual lights and the sun's disc from the samples'
/// indices alone, towards the area lamp's points and the sky's directions from the aims
/// the CPU drew — answer as the CPU's own rays of the same samples do: each pixel's made
/// rays against `Scene::occluded` of the ray the CPU makes for that light or sample. A
/// made ray differs from the CPU's by a few float steps of its direction and point (the
/// GPU's `sin`, `cos`, `sqrt`, fused multiply-adds, a 24-bit sample; an aimed ray by its
/// point alone), so answers may differ only for rays that graze an edge: at most one in
/// a thousand, plus one. Each answer's bit is found here from the layout the shader
/// states (punctual lights, then the sun's samples, then the aims in order). Twice: a
/// pixel's first three estimates at its point, and a later one moved within the pixel
/// (made from the barycentrics the CPU sends).
#[test]
fn shadow_rays_made_on_the_gpu_are_the_cpus() {
    use holocave_render_node::gpu_rays::ShadowMaker;
    use holocave_vlf::{DirectPoint, MadeFrom};
    let scene = std::sync::Arc::new(room::room_with_punctual_lights());
    let vis = Visibility::of(scene.clone(), &Settings::default());
    // The sky per pixel too: a sky sample and a BSDF sample of the sky an estimate.
    let direct = PixelDirect::new(scene.clone()).with_sky(true);
    let view = camera_view(&scene, 96, 64);
    let points = vis.pixels_and_points(&view).1;
    let gpu = gpu();
    let mut engine = GpuRays::for_scene(&gpu, &scene).expect("upload the scene");
    let mut maker = ShadowMaker::new(&gpu, &engine, &scene).expect("a maker of the room's lights");
    let n = engine.trace_wall(&gpu, &view, f32::INFINITY, Query::ClosestHit);
    let hits = engine.read_hits(&gpu, n);
    let mut kept = None;
    engine.keep_hits(&gpu, n, &mut kept);
    let engine = engine;
    let at_first_hit: Vec<bool> = (points.iter().zip(&hits))
        .map(|(p, h)| matches!((p, h), (Some(p), Some(h)) if p.triangle == h.triangle))
        .collect();
    let mut check = |points: &[Option<DirectPoint>], estimates: std::ops::Range<u64>| {
        let per_pixel: Vec<Vec<_>> = (points.iter().zip(&at_first_hit))
            .enumerate()
            .map(|(i, (p, &first))| {
                let mut queries = Vec::new();
                if let (Some(p), true) = (p, first) {
                    for e in estimates.clone() {
                        direct.queries(p, i as u64, e, &mut queries);
                    }
                }
                queries
            })
            .collect();
        let from: Vec<MadeFrom> = (points.iter().zip(&at_first_hit))
            .enumerate()
            .map(|(i, (p, &first))| match p {
                Some(p) if first && estimates.end - estimates.start == 1 => {
                    match direct.within_pixel(p, i as u64, estimates.start) {
                        Some((_, at)) => MadeFrom::Moved(at),
                        None => MadeFrom::FirstHit,
                    }
                }
                _ if first => MadeFrom::FirstHit,
                _ => MadeFrom::Sent,
            })
            .collect();
        let moved = from
            .iter()
            .filter(|f| matches!(f, MadeFrom::Moved(_)))
            .count();
        let on_gpu = (&engine, kept.as_ref().unwrap(), &gpu);
        let counts = made_as_the_cpus(&scene, &mut maker, on_gpu, &per_pixel, &from);
        (counts, moved)
    };
    // A pixel's first three estimates at its point (the sun's samples 0 to 7 or so,
    // three of the lamp, six of the sky).
    let at_point: Vec<Option<DirectPoint>> = (points.iter())
        .map(|p| {
            p.map(|p| DirectPoint {
                span: [Vec3::ZERO; 2],
                ..p
            })
        })
        .collect();
    let (counts, moved) = check(&at_point, 0..3);
    assert_made_as_the_cpus(counts);
    assert_eq!(moved, 0);
    // Three later estimates, one at a time, each moved within the pixel.
    let seen = at_first_hit.iter().filter(|&&f| f).count();
    let mut later = MadeCounts::default();
    for e in 3..6 {
        let (counts, moved) = check(&points, e..e + 1);
        assert!(
            moved * 2 > seen,
            "{moved} of {seen} pixels' estimates moved"
        );
        for k in 0..4 {
            later.rays[k] += counts.rays[k];
            later.blocked[k] += counts.blocked[k];
        }
        later.differ += counts.differ;
    }
    assert_made_as_the_cpus(later);
}

/// Rays made on the GPU and answered on the CPU: to punctual lights, the sun, the lamp and
/// the sky; how many the CPU finds blocked; how many the two answer otherwise.
#[derive(Clone, Copy, Default)]
struct MadeCounts {
    rays: [usize; 4],
    blocked: [usize; 4],
    differ: usize,
}

/// Enough rays of each kind, blocked and not, to tell; the answers differing at most
/// once in a thousand, plus one.
fn assert_made_as_the_cpus(c: MadeCounts) {
    let MadeCounts {
        rays,
        blocked,
        differ,
    } = c;
    eprintln!(
        "made shadow rays: {} to punctual lights ({} blocked), {} to the sun ({} blocked), \
         {} to the lamp ({} blocked), {} to the sky ({} blocked); \
         {differ} answered otherwise than the CPU's",
        rays[0], blocked[0], rays[1], blocked[1], rays[2], blocked[2], rays[3], blocked[3]
    );
    for k in 0..4 {
        assert!(
            rays[k] > 1000 && blocked[k] > 100 && rays[k] - blocked[k] > 100,
            "{rays:?} rays, {blocked:?} blocked: too few of either to tell"
        );
    }
    let total: usize = rays.iter().sum();
    assert!(differ <= total / 1000 + 1, "{differ} differ");
}

/// Checks the rays `maker` makes of each pixel's `queries` from where `from` says against
/// the CPU's answers to the queries (see `shadow_rays_made_on_the_gpu_are_the_cpus`).
fn made_as_the_cpus(
    scene: &Scene,
    maker: &mut holocave_render_node::gpu_rays::ShadowMaker,
    (engine, kept, gpu): (&GpuRays, &holocave_render_node::gpu_rays::KeptHits, &Gpu),
    per_pixel: &[Vec<holocave_vlf::ShadowQuery>],
    from: &[holocave_vlf::MadeFrom],
) -> MadeCounts {
    use holocave_vlf::{Sampled, made_rays};
    let lights = scene.lights.len() as u32;
    let (plans, aims) = made_rays(per_pixel, from, lights);
    let masks = maker.trace(gpu, engine, kept, &plans, &aims);
    assert_eq!(masks.len(), per_pixel.len());
    let (mut rays, mut blocked, mut differ) = ([0usize; 4], [0usize; 4], 0);
    for ((queries, plan), mask) in per_pixel.iter().zip(&plans).zip(&masks) {
        let mut aimed = 0;
        for q in queries {
            let (bit, kind) = match q.light {
                Sampled::Punctual(i) => (i, 0),
                Sampled::Sun(k) => (lights + (k - u64::from(plan.first_sun)) as u32, 1),
                light => {
                    aimed += 1;
                    let kind = if light == Sampled::Area { 2 } else { 3 };
                    (lights + plan.suns + aimed - 1, kind)
                }
            };
            assert!(bit < 32, "a pixel's rays all fit in its answer");
            let cpu = scene.occluded(&q.ray, q.tmax);
            rays[kind] += 1;
            blocked[kind] += usize::from(cpu);
            differ += usize::from(cpu != (mask & (1 << bit) != 0));
        }
    }
    // Every one of them made: none left to send.
    assert_eq!(
        plans.iter().map(|m| m.aimed as usize).sum::<usize>(),
        rays[2] + rays[3]
    );
    MadeCounts {
        rays,
        blocked,
        differ,
    }
}
