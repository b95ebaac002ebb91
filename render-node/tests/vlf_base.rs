//! The Virtual Light Field under the render cache (issue 14): the GPU's lookup equals the
//! CPU's; a cold start shows the lit scene from its first frame (not black), close to the
//! converged image; and a still viewer still converges to the path-traced image.

use crate::common;

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use glam::{Vec2, Vec3};
use holocave_cave::{Size, WallView};
use holocave_render_node::gpu_rays::Rays;
use holocave_render_node::gpu_rays::surfaces::SceneSurfaces;
use holocave_render_node::{EyeView, Gpu, PixelTracer, RenderCache, VlfBase, WallDisplay};
use holocave_scene::{
    Encoding, Hit, LoadOptions, Ray, Scene, SceneParts, Texture, TextureRef, TriangleShading,
};
use holocave_tracer::{TraceSettings, Tracer, render::render};
use holocave_vlf::surface::towards_table;
use holocave_vlf::{Lookup, Settings, view::shade};

fn cornell() -> Arc<Scene> {
    Arc::new(common::cornell())
}

/// The README's view: the front wall of a CAVE framing the box.
fn wall(size: u32) -> WallView {
    common::front_wall(common::EYE, size)
}

/// A coarse bake (92 directions, 64 lines): enough for what the lookups do.
fn coarse() -> Settings {
    Settings {
        directions: 92,
        resolution: 64,
        ..Settings::default()
    }
}

/// Bakes `scene` with `settings` into a file in `dir` and opens it as a node does.
fn baked(scene: &Arc<Scene>, settings: &Settings, dir: &std::path::Path) -> VlfBase {
    let path = dir.join("cornell.vlf");
    common::write_field(scene, *settings, &path);
    VlfBase::open(&path, scene.clone()).expect("open the light field")
}

/// The Cornell box with its white walls made a glossy metal (GGX α = 0.09): most of the
/// view is drawn from directional radiance tiles.
fn glossy_cornell() -> Arc<Scene> {
    let mut scene = common::cornell();
    let white = scene
        .materials
        .iter()
        .position(|m| m.name == "white")
        .expect("the white walls");
    scene.materials[white].metallic = 1.0;
    scene.materials[white].roughness = 0.3;
    Arc::new(scene)
}

#[test]
fn the_gpu_lookup_equals_the_cpu_lookup() {
    let gpu = Gpu::new().expect("a wgpu adapter (install mesa-vulkan-drivers without a GPU)");
    // The box as it is (diffuse elements, the mirror and glass followed), and with glossy
    // walls (tiles read in the direction towards the eye).
    for (name, scene) in [("cornell", cornell()), ("glossy cornell", glossy_cornell())] {
        let dir = tempfile::tempdir().unwrap();
        let settings = coarse();
        let base = baked(&scene, &settings, dir.path());
        let size = 48;
        let view = EyeView::looking_at(wall(size), 0.05).unwrap();
        let lookups = base.lookups(0, &view);
        let cpu = shade(&lookups, base.values());
        let glossy = lookups.iter().filter(|l| l.tile != u32::MAX).count();
        if name == "cornell" {
            assert_eq!(glossy, 0, "no tiles in the plain box");
        } else {
            assert!(glossy > lookups.len() / 4, "{glossy} glossy pixels");
        }

        let n = size * size;
        let mut cache = RenderCache::new(gpu.clone(), &[Size::new(size, size)], n, n);
        cache.set_vlf(base.values(), 64.0).unwrap();
        cache.set_lookups(0, &lookups);
        let image = cache.vlf_image(0).expect("a light field is set");
        // The same f32 operations in the same order on both sides; a GPU may fuse a
        // multiply-add, which changes the last bits: a few ulps of the value.
        for (g, c) in image.pixels.iter().zip(&cpu) {
            let tol = 1e-5 * c.abs().max_element() + 1e-7;
            assert!(
                (*g - *c).abs().max_element() <= tol,
                "{name}: GPU {g} against CPU {c}"
            );
        }
        assert!(cpu.iter().any(|c| c.max_element() > 0.0), "the view is lit");
        eprintln!(
            "{name}: GPU and CPU lookups agree on {} pixels ({glossy} from glossy tiles)",
            cpu.len()
        );
    }
}

/// The first frame of a cold start is within 0.02 of the converged image (instead of
/// black), and a still viewer then converges to the path-traced reference: the light
/// field is a prior worth k samples, so the samples take over as they accumulate and end
/// closer to the reference than the light field with the direct light's own means does
/// over as many frames.
#[test]
fn a_cold_start_shows_the_light_field_and_a_still_viewer_converges() {
    const SIZE: u32 = 64;
    const FIRST_FRAME: f64 = 0.02;
    const TARGET: f64 = 0.01;
    // Four times the paths a pixel that averaging alone needs for the still-viewer test's
    // target (`tests/still_viewer.rs`: 670), one a pixel and frame: with the exact direct
    // light, the light field's picture is already as close to the reference as 1,340
    // paths a pixel are (their own noise; 0.00364 against the field's 0.00366), and the
    // samples take over beyond that (0.00255 at 2,680). A frame budget: the same on any
    // machine.
    const MAX_FRAMES: u32 = 2680;
    let scene = cornell();
    let tracer = Arc::new(Tracer::new(scene.clone(), TraceSettings::default()));
    let wall = wall(SIZE);
    let t = Instant::now();
    let reference = render(&tracer, &wall, 4096, 7, &|| {});
    eprintln!("reference: 4096 spp in {:.1} s", t.elapsed().as_secs_f64());
    let dir = tempfile::tempdir().unwrap();
    let t = Instant::now();
    // Half the default resolution (a quarter of the lines): a quarter of the bake time.
    let settings = Settings {
        resolution: 128,
        ..Settings::default()
    };
    let base = baked(&scene, &settings, dir.path());
    eprintln!(
        "bake (642 directions, 128 lines): {:.1} s",
        t.elapsed().as_secs_f64()
    );

    let gpu = Gpu::new().expect("a wgpu adapter (install mesa-vulkan-drivers without a GPU)");
    let n = SIZE * SIZE;
    let base = Arc::new(base);
    let display_of = |samples: u32| {
        let cache = RenderCache::new(gpu.clone(), &[Size::new(SIZE, SIZE)], n + n / 4, n);
        WallDisplay::new(cache, PixelTracer::new(tracer.clone(), 1), samples)
            .with_vlf(
                base.clone(),
                holocave_render_node::light_field::DEFAULT_PRIOR_SAMPLES,
            )
            .unwrap()
    };
    let mut display = display_of(n / 16);
    let view = EyeView::looking_at(wall, 0.05).unwrap();

    display.frame(&[view], false);
    let first = display.cache.image(0).relative_mse(&reference);
    eprintln!("first frame: relative MSE {first:.5}");
    assert!(
        first < FIRST_FRAME,
        "the first frame of a cold start is {first:.5} from the reference (needs < {FIRST_FRAME})"
    );

    // More samples per frame now, as the still-viewer test does.
    display.samples_per_eye = n;
    let start = Instant::now();
    let mut frame = 1u32;
    let mut err = first;
    while frame < MAX_FRAMES {
        display.frame(&[view], false);
        frame += 1;
        if frame.is_multiple_of(16) {
            err = display.cache.image(0).relative_mse(&reference);
            eprintln!(
                "frame {frame}: {:.1} s, relative MSE {err:.5}",
                start.elapsed().as_secs_f64()
            );
        }
    }
    // The light field and the direct light alone, as many frames.
    let mut field = display_of(0);
    for _ in 0..frame {
        field.frame(&[view], false);
    }
    let field_err = field.cache.image(0).relative_mse(&reference);
    eprintln!("the light field and the direct light alone after {frame} frames: {field_err:.5}");
    if let Ok(dir) = std::env::var("HOLOCAVE_TEST_OUT") {
        let dir = PathBuf::from(dir);
        let exposure = reference.auto_exposure();
        let img = display.cache.image(0);
        common::write_image(&dir, "vlf-still", &img, exposure);
    }
    assert!(
        err < TARGET.min(field_err),
        "relative MSE {err:.5} after {frame} frames; needs below {TARGET} and the light field's {field_err:.5}"
    );
}

#[test]
fn first_hits_on_the_gpu_draw_the_cpus_light_field() {
    // `--rays gpu` against `--rays cpu`: the Cornell box (the rays on through its mirror
    // and glass traced on the GPU too, in batches), with and without the per-pixel direct
    // light (its shadow rays traced on the GPU too).
    let gpu = Gpu::new().expect("a wgpu adapter (install mesa-vulkan-drivers without a GPU)");
    let scene = cornell();
    let dir = tempfile::tempdir().unwrap();
    let settings = coarse();
    let cpu = baked(&scene, &settings, dir.path());
    let on_gpu = VlfBase::open(&dir.path().join("cornell.vlf"), scene.clone())
        .unwrap()
        .with_rays(&gpu, Rays::Gpu)
        .unwrap();
    assert!(on_gpu.rays_on_gpu() && !cpu.rays_on_gpu());
    let view = EyeView::looking_at(wall(64), 0.05).unwrap();
    for direct in [false, true] {
        let (cpu, on_gpu) = (
            VlfBase::open(&dir.path().join("cornell.vlf"), scene.clone())
                .unwrap()
                .with_direct(direct),
            VlfBase::open(&dir.path().join("cornell.vlf"), scene.clone())
                .unwrap()
                .with_direct(direct)
                .with_rays(&gpu, Rays::Gpu)
                .unwrap(),
        );
        let a = shade(&cpu.lookups(0, &view), cpu.values());
        let b = shade(&on_gpu.lookups(0, &view), on_gpu.values());
        // One 8-bit step of the brightest pixel, for each pixel's every channel.
        let peak = a.iter().map(|p| p.max_element()).fold(0.0f32, f32::max);
        let step = peak / 255.0;
        let off = a
            .iter()
            .zip(&b)
            .filter(|(a, b)| (**a - **b).abs().max_element() > step)
            .count();
        eprintln!(
            "direct {direct}: {off} of {} pixels differ by more than one step",
            a.len()
        );
        // A pixel whose ray grazes an edge may see the other triangle (the gpu_rays tests
        // bound those to one ray in a thousand). The per-pixel direct light's one-frame
        // estimate draws its samples by the hit point's bits: where the GPU's barycentrics
        // differ from the CPU's by an ulp (99 of these 4096 pixels, the same triangle at the
        // same t) it takes other samples, another estimate of the same light (4 pixels
        // differ here, all so).
        let allowed = if direct {
            a.len() / 200
        } else {
            a.len() / 1000
        } + 1;
        assert!(off <= allowed, "{off} pixels differ");
    }
}

/// The two eyes of a wall keep their own running means of the direct light: drawn in turn
/// from a still head, every pixel of each eye that sees a point holds one more estimate a
/// frame after its first ones. (When one eye took the other's means each frame, they were
/// carried across the eyes' parallax: a pixel's mean grew by two a frame, or started again
/// where the eyes see different points.)
#[test]
fn each_eye_keeps_its_own_means() {
    let scene = cornell();
    let dir = tempfile::tempdir().unwrap();
    let base = baked(&scene, &coarse(), dir.path()).with_settling(None);
    let size = 32;
    let eyes: Vec<EyeView> = [-0.032f32, 0.032]
        .iter()
        .map(|&dx| {
            let mut w = wall(size);
            w.eye.x += dx;
            EyeView::looking_at(w, 0.05).unwrap()
        })
        .collect();
    let frames = 8;
    for _ in 0..frames {
        for (eye, view) in eyes.iter().enumerate() {
            base.lookups(eye, view);
        }
    }
    // The box has a lamp: two estimates at a new point, then one a frame.
    let expected = 2 + (frames - 1);
    for (eye, view) in eyes.iter().enumerate() {
        let held = base
            .estimates_held(eye, &view.wall)
            .expect("the eye's means");
        let seen = held.iter().filter(|&&n| n > 0).count();
        assert!(
            seen > held.len() / 2,
            "eye {eye}: {seen} pixels see a point"
        );
        let off: Vec<u32> = held
            .iter()
            .copied()
            .filter(|&n| n > 0 && n != expected)
            .collect();
        assert!(
            off.is_empty(),
            "eye {eye}: {} of {seen} pixels hold other than {expected} estimates: {:?}",
            off.len(),
            &off[..off.len().min(8)]
        );
    }
}

/// A still viewer of glossy walls whose lobe is narrower than their tiles resolve (the
/// Cornell box's walls a metal of GGX α 0.09, widened to 0.26 at this bake): the first
/// frame shows the tiles' reflections; frames 1 to 32 add the walls' own lobes' reflection
/// of the room beyond the tiles' (`Visibility::sharpened_reflection`), each from new
/// directions, and the pixels show their mean; after that none is drawn and the mean is
/// kept. Every pixel that sees a widened tile holds as many frames' as have passed, up to
/// 32 and 32 after; one that sees a glossy surface too small for a tile (drawn as its
/// mirror) one more, up to 33: from then on its surface is drawn again as it was (the
/// view is still) with its reflection's mean. (That the mean is the frames' is
/// `a_still_pixels_reflections_are_the_mean_of_its_frames`, in the crate.)
#[test]
fn a_still_viewer_sees_the_glossy_walls_sharpened_and_keeps_their_mean() {
    let scene = glossy_cornell();
    let dir = tempfile::tempdir().unwrap();
    let base = baked(&scene, &coarse(), dir.path());
    let view = EyeView::looking_at(wall(32), 0.05).unwrap();
    base.lookups(0, &view);
    for frame in 1..=40u32 {
        base.lookups(0, &view);
        let held = base
            .reflections_held(0, &view.wall)
            .expect("the eye's means");
        let (tiles, mirrors) = (frame.min(32), (frame + 1).min(33));
        let sharpened = held.iter().filter(|&&n| n == tiles).count();
        assert!(
            sharpened > held.len() / 4,
            "frame {frame}: {sharpened} of {} pixels hold {tiles} frames",
            held.len()
        );
        let other: Vec<u32> = (held.iter().copied())
            .filter(|&n| n != 0 && n != tiles && n != mirrors)
            .collect();
        assert!(
            other.is_empty(),
            "frame {frame}: pixels hold {:?} frames",
            &other[..other.len().min(8)]
        );
    }
}

/// Gather samples with their rays traced on the GPU (`--rays gpu`: the eye rays' first
/// hits, the bounces', every shadow ray, each batch in one round trip) are the CPU's
/// samples: the Cornell box, whose mirror and glass are followed on the CPU from the
/// GPU's hits and whose lamp is sampled over the mirror too.
#[test]
fn gathers_traced_on_the_gpu_are_the_cpus() {
    let gpu = Gpu::new().expect("a wgpu adapter (install mesa-vulkan-drivers without a GPU)");
    let scene = cornell();
    let dir = tempfile::tempdir().unwrap();
    let cpu = baked(&scene, &coarse(), dir.path());
    let on_gpu = VlfBase::open(&dir.path().join("cornell.vlf"), scene.clone())
        .unwrap()
        .with_rays(&gpu, Rays::Gpu)
        .unwrap();
    let view = wall(32);
    let rays: Vec<Ray> = (0..4)
        .flat_map(|k| {
            (0..view.size.width * view.size.height).map(move |i| {
                let jitter = Vec2::new(0.25 + 0.5 * (k % 2) as f32, 0.25 + 0.5 * (k / 2) as f32);
                let pixel = Vec2::new((i % view.size.width) as f32, (i / view.size.width) as f32);
                view.ray(pixel + jitter)
            })
        })
        .collect();
    let (a, b) = (cpu.gather(&rays, 7), on_gpu.gather(&rays, 7));
    assert_eq!(a.len(), b.len());
    let lit = a.iter().filter(|g| g.radiance.max_element() > 0.0).count();
    // The box fills two thirds of the wall.
    assert!(lit > rays.len() / 2, "{lit} of {} samples lit", rays.len());
    // Where every ray of a sample (the eye ray, the bounce, about four shadow rays) met
    // the same triangles, the two differ only by the hits' rounding (a few float steps of
    // a position, far below 1e-4 of the light); a ray that grazes an edge may meet another
    // triangle (the gpu_rays tests bound those to one ray in a thousand): at most six
    // such samples in a thousand.
    let differ = |x: Vec3, y: Vec3| (x - y).abs().max_element() > 1e-4 * x.max(y).max_element();
    let off = (a.iter().zip(&b))
        .filter(|(x, y)| {
            differ(x.radiance, y.radiance)
                || x.material != y.material
                || (x.distance - y.distance).abs() > 1e-4 * x.distance.max(1.0)
        })
        .count();
    eprintln!("{off} of {} gathers differ", rays.len());
    assert!(off <= rays.len() * 6 / 1000 + 1, "{off} gathers differ");
}

/// `--rays gpu` against `--rays cpu` in the sunlit room with punctual lights and an area
/// lamp, whose direct light's rays the GPU makes from the wall's first hits (towards the
/// area lamp from the points the CPU drew; those of points beyond mirrors and glass sent):
/// the same wall, frame after frame, within one 8-bit step but where a ray grazes an edge.
#[test]
fn shadow_rays_made_on_the_gpu_draw_the_cpus_walls() {
    let gpu = Gpu::new().expect("a wgpu adapter (install mesa-vulkan-drivers without a GPU)");
    let scene = Arc::new(common::room::room_with_punctual_lights());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("room.vlf");
    common::write_field(&scene, coarse(), &path);
    let cpu = VlfBase::open(&path, scene.clone()).unwrap();
    let on_gpu = (VlfBase::open(&path, scene.clone()).unwrap())
        .with_rays(&gpu, Rays::Gpu)
        .unwrap();
    assert!(cpu.direct_per_pixel() && on_gpu.rays_on_gpu());
    let cam = scene.cameras.first().expect("the room's camera");
    let view = EyeView::looking_at(WallView::through_camera(cam, Size::new(80, 60)), 0.05).unwrap();
    for frame in 0..3 {
        let a = shade(&cpu.lookups(0, &view), cpu.values());
        let b = shade(&on_gpu.lookups(0, &view), on_gpu.values());
        let peak = a.iter().map(|p| p.max_element()).fold(0.0f32, f32::max);
        let step = peak / 255.0;
        let off = (a.iter().zip(&b))
            .filter(|(a, b)| (**a - **b).abs().max_element() > step)
            .count();
        eprintln!(
            "frame {frame}: {off} of {} pixels differ by more than one step",
            a.len()
        );
        // As above: grazing rays (one in a thousand of each pixel's six or so).
        assert!(
            off <= a.len() / 200 + 1,
            "frame {frame}: {off} pixels differ"
        );
    }
}

/// The Cornell box with texture coordinates (each vertex's `x + z` and `y − z`, 2.3 times a
/// metre: tiled, negative and past one) and textures on its white walls (sRGB, 16 × 8
/// texels of scattered colours) and its red wall (linear, 5 × 3, its metallic-roughness
/// texture too): a base colour that varies inside each texel and wraps at the texture's
/// edges; its green wall a rough dielectric (glTF's specular layer over the base), whose
/// albedo changes with the view.
fn textured_cornell() -> Arc<Scene> {
    let box_ = common::cornell();
    let n = box_.triangle_count() as u32;
    let positions: Vec<[Vec3; 3]> = (0..n).map(|i| *box_.triangle(i)).collect();
    let shading = (0..n)
        .map(|i| TriangleShading {
            uvs: box_
                .triangle(i)
                .map(|p| Vec2::new(p.x + p.z, p.y - p.z) * 2.3),
            ..*box_.triangle_shading(i)
        })
        .collect();
    let scattered = |w: u32, h: u32, seed: u32| -> Vec<[u8; 4]> {
        (0..w * h)
            .map(|k| {
                let x = (k + seed).wrapping_mul(2_654_435_761);
                [(x >> 24) as u8, (x >> 16) as u8, (x >> 8) as u8, 255]
            })
            .collect()
    };
    let textures = vec![
        Texture::new(
            "scattered".into(),
            16,
            8,
            scattered(16, 8, 1),
            Encoding::Srgb,
        ),
        Texture::new("linear".into(), 5, 3, scattered(5, 3, 7), Encoding::Linear),
    ];
    let mut materials = box_.materials.clone();
    for (name, texture) in [("white", 0), ("red", 1)] {
        let m = (materials.iter_mut().find(|m| m.name == name)).expect("the box's material");
        m.base_color_texture = Some(TextureRef { texture });
    }
    // Its metallic and roughness read from a texture too: an albedo per texel, so the
    // CPU sends its weights.
    let red = (materials.iter_mut().find(|m| m.name == "red")).expect("the red wall");
    red.metallic_roughness_texture = Some(TextureRef { texture: 1 });
    let green = (materials.iter_mut().find(|m| m.name == "green")).expect("the green wall");
    (green.metallic, green.roughness, green.specular) = (0.0, 1.0, 1.0);
    let parts = SceneParts {
        name: "textured cornell".into(),
        positions,
        shading,
        materials,
        textures,
        lights: box_.lights.clone(),
        cameras: box_.cameras.clone(),
        daylight: box_.daylight.clone(),
        ..Default::default()
    };
    Arc::new(Scene::from_parts(parts, std::path::Path::new("textured_cornell.gltf")).unwrap())
}

/// How far the GPU's weight of a composed lookup may be from the CPU's (`surfaces.rs`):
/// the texture coordinates interpolated with fused multiply-adds (3 ε of the largest
/// coordinate `s`), moving a texel position by `w · 3 ε s + 2 ε w` in a texture `w` texels
/// wide, and the colour by as much (a texel step is at most 1); the shading normal and the
/// ray's direction (normalised, the division and square root 2.5 ulp each) moving the
/// view's cosine by 64 ε, so the table's position by 31 times that, the albedo by that
/// times its largest step `table_step`; 8 ε of rounding in the table's blend; all over π.
/// It takes the base colour factors and the tables' `b` at most 1 (glTF's factors are),
/// and an eye and screen within a few metres of the origin (the GPU makes the pixel rays
/// from the screen's corners; far from the origin their rounding grows with the
/// coordinates).
fn weight_bound(scene: &Scene, table_step: f32) -> f32 {
    let eps = f32::EPSILON;
    let s = (0..scene.triangle_count() as u32)
        .flat_map(|i| scene.triangle_shading(i).uvs)
        .fold(0.0f32, |m, uv| m.max(uv.abs().max_element()));
    let texels =
        (scene.textures.iter()).fold(0.0f32, |m, t| m.max(t.width().max(t.height()) as f32));
    let colour = 2.0 * (texels * 3.0 * eps * s + 2.0 * eps * texels) + 8.0 * eps;
    (colour + 31.0 * 64.0 * eps * table_step + 8.0 * eps) * std::f32::consts::FRAC_1_PI
}

/// The largest change between two steps of any of `scene`'s materials' albedo tables.
fn largest_table_step(scene: &Scene) -> f32 {
    (scene.materials.iter())
        .map(|m| towards_table(&m.params(&scene.textures, Vec2::ZERO)))
        .flat_map(|t| {
            t.windows(2)
                .map(|w| ((w[1].0 - w[0].0).abs() + (w[1].1 - w[0].1).abs()).max_element())
                .collect::<Vec<_>>()
        })
        .fold(0.0, f32::max)
}

/// With the rays on the GPU, the lookups the render cache receives are composed there from
/// the wall's first hits (element and barycentrics from the hit, the weight from the
/// material data on the GPU, the emitted light sent; mirrors, glass, tiles sent whole):
/// bit for bit the lookups the CPU makes of the same frame but for the weights, which are
/// within [`weight_bound`], in the room (its sun and lamps), the Cornell box (mirror,
/// glass, area lamp), the box with glossy walls (tiles) and the box with textures.
#[test]
fn lookups_composed_from_the_gpus_hits_are_the_cpus() {
    let gpu = Gpu::new().expect("a wgpu adapter (install mesa-vulkan-drivers without a GPU)");
    let room = Arc::new(common::room::room_with_punctual_lights());
    let room_view =
        WallView::through_camera(room.cameras.first().expect("a camera"), Size::new(64, 48));
    let textured = textured_cornell();
    let surfaces = SceneSurfaces::new(&gpu, &textured).expect("the box's surfaces fit");
    let red = (textured.materials.iter())
        .position(|m| m.name == "red")
        .expect("the red wall") as u32;
    for i in 0..textured.triangle_count() as u32 {
        let hit = Hit {
            t: 1.0,
            triangle: i,
            u: 0.0,
            v: 0.0,
        };
        let on_cpu = textured.triangle_shading(i).material == red;
        assert_eq!(surfaces.shades(&hit), !on_cpu, "triangle {i}");
    }
    for (name, scene, wall) in [
        ("room", room, room_view),
        ("cornell", cornell(), wall(48)),
        ("glossy cornell", glossy_cornell(), wall(48)),
        ("textured cornell", textured, wall(48)),
    ] {
        composed_as_the_cpus(&gpu, name, &scene, wall);
    }
}
/// Draws two frames of `wall` in `scene` (a coarse bake of its own) with the lookups made
/// on the CPU and composed on the GPU, and asserts that they are the same but for the
/// weights, which are within [`weight_bound`].
fn composed_as_the_cpus(gpu: &Gpu, name: &str, scene: &Arc<Scene>, wall: WallView) {
    let bound = weight_bound(scene, largest_table_step(scene));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cornell.vlf");
    drop(baked(scene, &coarse(), dir.path()));
    let open = || {
        (VlfBase::open(&path, scene.clone()).unwrap())
            .with_rays(gpu, Rays::Gpu)
            .unwrap()
    };
    let (on_cpu, on_gpu) = (open(), open());
    let view = EyeView::looking_at(wall, 0.05).unwrap();
    let n = wall.size.width * wall.size.height;
    let mut cache = RenderCache::new(gpu.clone(), &[wall.size], n, n);
    cache.set_vlf(on_gpu.values(), 64.0).unwrap();
    for frame in 0..2 {
        let cpu = on_cpu.lookups(0, &view);
        let here = (on_gpu.draw_lookups(0, &view, &mut cache)).expect("composed on the GPU");
        let buffer = cache.lookups_buffer(0).expect("a light field is set");
        let bytes = gpu.read(buffer, buffer.size());
        let composed: &[Lookup] = bytemuck::cast_slice(&bytes[..cpu.len() * 64]);
        let but_weight = |l: &Lookup| Lookup {
            weight: [0.0; 3],
            ..*l
        };
        let differ = (cpu.iter().zip(composed))
            .filter(|(a, b)| {
                bytemuck::bytes_of(&but_weight(a)) != bytemuck::bytes_of(&but_weight(b))
            })
            .count();
        let apart = (cpu.iter().zip(composed))
            .map(|(a, b)| {
                (Vec3::from(a.weight) - Vec3::from(b.weight))
                    .abs()
                    .max_element()
            })
            .fold(0.0f32, f32::max);
        let elements = (cpu.iter())
            .filter(|l| l.base != u32::MAX && l.tile == u32::MAX)
            .count();
        eprintln!(
            "{name}, frame {frame}: {differ} of {} lookups differ but for the weight \
             ({elements} on elements, {here} weighed on the GPU); weights at most {apart:e} \
             apart (bound {bound:e})",
            cpu.len()
        );
        // All but the edges' pixels (and the red wall's of the textured box).
        assert!(here > elements / 2, "{name}: {here} weighed on the GPU");
        assert!(
            elements > cpu.len() / 4,
            "{name}: {elements} element lookups"
        );
        assert_eq!(differ, 0, "{name}, frame {frame}");
        assert!(
            apart <= bound,
            "{name}, frame {frame}: weights {apart:e} apart"
        );
    }
}

/// Sponza's own textures (21 base colour textures, 1024 and 2048 texels a side, sRGB) read
/// on the GPU for the composed lookups' weights, as in
/// [`lookups_composed_from_the_gpus_hits_are_the_cpus`], through its camera.
#[test]
fn lookups_composed_on_sponza_weigh_its_textures_as_the_cpu() {
    let Some(path) = common::require::shared("scenes/sponza/Sponza.gltf") else {
        return;
    };
    let sponza = Scene::load(&path, &LoadOptions::default()).expect("load Sponza");
    let gpu = Gpu::new().expect("a wgpu adapter (install mesa-vulkan-drivers without a GPU)");
    let camera = sponza.cameras.first().expect("Sponza's camera");
    let view = WallView::through_camera(camera, Size::new(64, 48));
    composed_as_the_cpus(&gpu, "sponza", &Arc::new(sponza), view);
}

/// A light field whose rays are on one device draws into a render cache on another (a
/// node that opened two) by sending its lookups whole: no buffer of one device is bound on
/// the other (two devices opened apart may compare equal as `wgpu::Device`s).
#[test]
fn lookups_drawn_into_a_cache_on_another_device_are_sent_whole() {
    let (rays_gpu, cache_gpu) = (
        Gpu::new().expect("a wgpu adapter (install mesa-vulkan-drivers without a GPU)"),
        Gpu::new().expect("a second device"),
    );
    assert!(!rays_gpu.same_device(&cache_gpu) && rays_gpu.same_device(&rays_gpu.clone()));
    let scene = cornell();
    let dir = tempfile::tempdir().unwrap();
    drop(baked(&scene, &coarse(), dir.path()));
    let base = (VlfBase::open(&dir.path().join("cornell.vlf"), scene.clone()).unwrap())
        .with_rays(&rays_gpu, Rays::Gpu)
        .unwrap();
    let view = EyeView::looking_at(wall(32), 0.05).unwrap();
    let mut cache = RenderCache::new(cache_gpu.clone(), &[Size::new(32, 32)], 1024, 1024);
    cache.set_vlf(base.values(), 64.0).unwrap();
    base.draw_lookups(0, &view, &mut cache);
    let buffer = cache.lookups_buffer(0).expect("a light field is set");
    let bytes = cache_gpu.read(buffer, buffer.size());
    let drawn: &[Lookup] = bytemuck::cast_slice(&bytes[..1024 * 64]);
    let lit = drawn.iter().filter(|l| l.base != u32::MAX).count();
    assert!(lit > 256, "{lit} lookups on elements arrived");
}

/// Gathers kept in the field (`VlfBase::keep_gathers`): the gathers of a still view, kept
/// in the elements they land on, hold what the field's remainder holds — its caustics
/// left out, which the walls take per pixel — so what the field shows from 15 cm away (as
/// after the head moved, where a screen's samples are left behind) stays as close to the
/// path-traced reference; and the render cache shades the kept values as the CPU does once
/// they are uploaded (`RenderCache::update_vlf_values`). Each pixel's direct light
/// averaged over 64 frames on both sides, so that what differs is the field's remainder.
#[test]
fn gathers_kept_in_the_field_show_from_another_eye() {
    const SIZE: u32 = 32;
    let gpu = Gpu::new().expect("a wgpu adapter (install mesa-vulkan-drivers without a GPU)");
    let scene = cornell();
    let dir = tempfile::tempdir().unwrap();
    let base = baked(&scene, &coarse(), dir.path());
    assert!(
        base.keep_gathers(16.0),
        "a field whose remainder is drawn keeps gathers"
    );
    let seen = wall(SIZE);
    for k in 0..64u32 {
        let rays: Vec<Ray> = (0..SIZE * SIZE)
            .map(|i| {
                let j = (i * 7 + k * 13) % 16;
                let o = Vec2::new((j % 4) as f32 + 0.5, (j / 4) as f32 + 0.5) / 4.0;
                seen.ray(Vec2::new((i % SIZE) as f32, (i / SIZE) as f32) + o)
            })
            .collect();
        base.gather(&rays, u64::from(k));
    }
    let mut kept = None;
    base.with_kept_values(|v, changed| kept = Some((v.to_vec(), changed.to_vec())));
    let (kept, changed) = kept.expect("the gathers changed the field");

    let moved = WallView {
        eye: seen.eye + Vec3::new(0.15, -0.05, 0.0),
        ..seen
    };
    let view = EyeView::looking_at(moved, 0.05).unwrap();
    let mut lookups = base.lookups(0, &view);
    for _ in 1..64 {
        lookups = base.lookups(0, &view);
    }
    let tracer = Tracer::new(scene.clone(), TraceSettings::default());
    let reference = render(&tracer, &moved, 4096, 7, &|| {});
    let image = |values: &[[f32; 3]]| {
        let mut im = holocave_tracer::film::Image::new(SIZE, SIZE);
        im.pixels = shade(&lookups, values);
        im
    };
    let (field, with_kept) = (
        image(base.values()).relative_mse(&reference),
        image(&kept).relative_mse(&reference),
    );
    eprintln!(
        "from 15 cm away, against 4096 spp: the field {field:.5}, with the gathers kept {with_kept:.5}"
    );
    // With the caustics per pixel this coarse field is already near the reference
    // (0.0370 before them, 0.0084 now), and the kept gathers add their noise (2 % here);
    // kept with their caustics as well, which the walls also take per pixel, they were
    // 23 % worse. The vlf crate's test (`tests/gather.rs`) holds their gain where the
    // field is wrong.
    assert!(
        with_kept < 1.1 * field,
        "kept {with_kept:.5}, the field {field:.5}"
    );

    let n = SIZE * SIZE;
    let mut cache = RenderCache::new(gpu, &[Size::new(SIZE, SIZE)], n, n);
    cache.set_vlf(base.values(), 64.0).unwrap();
    cache.update_vlf_values(&kept, &changed);
    cache.set_lookups(0, &lookups);
    let on_gpu = cache.vlf_image(0).expect("a light field is set");
    let cpu = shade(&lookups, &kept);
    for (g, c) in on_gpu.pixels.iter().zip(&cpu) {
        let tol = 1e-5 * c.abs().max_element() + 1e-7;
        assert!(
            (*g - *c).abs().max_element() <= tol,
            "GPU {g} against CPU {c}"
        );
    }
}

/// One composition of a wall's radiance (`holocave_vlf::wall_pass`): along the same ray
/// with the same sample sequence, glare's fisheye, `compare`'s measure of the field
/// (`VlfBase::field_radiance`) and `vlf view`'s pass give the same radiance, bit for bit;
/// and `vlf view` at one ray a pixel (`WallPass::render`) is the wall's first frame with
/// its rays on the CPU, bit for bit. The Cornell box takes every stage: the lamp's direct
/// light per pixel, caustics through the glass and over the mirror, the surfaces seen in
/// the mirror, edges. Seen to fail against glare drawing the lookup and the direct light
/// alone (without the tile albedo and caustics), and against a wall that leaves the
/// caustics out.
#[test]
fn glare_compare_vlf_view_and_the_wall_draw_one_radiance() {
    use holocave_vlf::view::ReflectionFrames;
    use holocave_vlf::{FrameContext, WallPass};
    let scene = cornell();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cornell.vlf");
    common::write_field(&scene, coarse(), &path);
    let opened = || holocave_vlf::baked::open(&path, &scene).expect("open the light field");
    let base = VlfBase::open(&path, scene.clone()).expect("open the light field");
    let fisheye = holocave_glare::draw::Drawing::light_field(scene.clone(), opened(), false, 1, 1);
    let pass = WallPass::of_opened(scene.clone(), opened(), false).unwrap();
    assert!(pass.direct_per_pixel() && base.direct_per_pixel());
    assert!(
        pass.visibility().caustics_per_pixel(),
        "the box has caustics"
    );

    let view = EyeView::looking_at(wall(40), 0.05).unwrap();
    let w = view.wall.size.width;
    let rays: Vec<Ray> = (0..view.wall.size.area() as u32)
        .map(|i| {
            view.wall
                .ray(Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5))
        })
        .collect();
    let estimates = pass.estimates_after(1);
    let first_frame = ReflectionFrames::still(0);
    let ctx = FrameContext {
        values: pass.values(),
        reflections: &first_frame,
        estimates,
    };
    let compared = base.field_radiance(&rays, estimates);
    let mut beyond_the_lookup = 0;
    for (i, ray) in rays.iter().enumerate() {
        let glare = fisheye.radiance(ray, 0, i as u64);
        let viewed = pass.radiance(ctx, *ray, i as u64);
        assert_eq!(glare, compared[i], "glare against compare, ray {i}");
        assert_eq!(
            viewed, compared[i],
            "vlf view's pass against compare, ray {i}"
        );
        let (l, _) = pass.visibility().lookup_and_point(*ray);
        if (compared[i] - holocave_vlf::view::shade_one(&l, pass.values())).max_element() > 1e-3 {
            beyond_the_lookup += 1;
        }
    }
    assert!(
        beyond_the_lookup > rays.len() / 2,
        "the direct light is in {beyond_the_lookup} of {} rays",
        rays.len()
    );

    let walls = shade(&base.lookups(0, &view), base.values());
    let viewed = pass.render(&view.wall, pass.values(), 1, 1);
    let apart = (walls.iter().zip(&viewed.pixels))
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(apart, 0, "{apart} of {} pixels apart", walls.len());
}

/// A still eye's pixels draw again what they saw (stages 1–3 kept per eye and view): on
/// the Cornell box, its first two frames trace every pixel (the first draws no glossy
/// lobe's reflection to draw anew), the later ones none (but the
/// pixels whose glossy reflections are drawn anew, not counted here). What a reused frame
/// shows is a traced frame's: the still viewer's tests above
/// (`a_cold_start_shows_the_light_field_and_a_still_viewer_converges`,
/// `a_still_viewer_sees_the_glossy_walls_sharpened_and_keeps_their_mean`) run on it.
/// Seen to fail against surfaces kept across a moved eye (the second view drawn from the
/// first's: 0 traced).
#[test]
fn a_still_eye_draws_again_what_its_pixels_saw() {
    let scene = cornell();
    let dir = tempfile::tempdir().unwrap();
    let base = baked(&scene, &coarse(), dir.path());
    let view = EyeView::looking_at(wall(32), 0.05).unwrap();
    let still: Vec<usize> = (0..5)
        .map(|_| {
            base.lookups(0, &view);
            base.take_work().traced
        })
        .collect();
    assert_eq!(still, vec![32 * 32, 32 * 32, 0, 0, 0]);
}

/// An eye moving 10 cm a frame (the back wall some 0.8 pixels) carries most of its
/// pixels from its last frame (`holocave_vlf::carry`, whose tests check that each carried
/// point lies in the pixel that carries it, that outlines and what comes into sight are
/// drawn anew, and the age limits) and draws anew only those new in sight, on an outline,
/// at their age limit or seen through the mirror and the glass: each frame draws some but
/// at most 75 % of them (measured 59–69 % on this 32-pixel view, where the outlines are a
/// large share). When the eye stops, its first still frame is traced whole (the carried
/// surfaces lie up to half a pixel off the pixels' centres, and a still view converges on
/// its centres'), and the next drawn again. Seen to fail against a still frame drawn
/// again from the carried one (`[0, 0]`).
#[test]
fn a_moving_eye_carries_its_pixels_and_draws_anew_only_what_it_must() {
    let scene = cornell();
    let dir = tempfile::tempdir().unwrap();
    let base = baked(&scene, &coarse(), dir.path());
    let at = |dx: f32| {
        let mut w = wall(32);
        w.eye.x += dx;
        EyeView::looking_at(w, 0.05).unwrap()
    };
    let pixels = 32 * 32;
    base.lookups(0, &at(0.0));
    base.take_work();
    for k in 1..=6 {
        base.lookups(0, &at(0.1 * k as f32));
        let work = base.take_work();
        assert!(
            work.traced > 0 && work.traced <= pixels * 3 / 4,
            "frame {k}: {} of {pixels} pixels drawn anew",
            work.traced
        );
    }
    let still = at(0.6);
    let after: Vec<usize> = (0..2)
        .map(|_| {
            base.lookups(0, &still);
            base.take_work().traced
        })
        .collect();
    assert_eq!(after, vec![pixels, 0]);
}
