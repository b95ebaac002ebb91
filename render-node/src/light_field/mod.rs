//! The Virtual Light Field as a render node draws it (`papers/vlf-in-the-cave.md` §4):
//! the baked irradiance of a `.vlf` file, and its glossy tiles' radiance, go to the GPU once; every frame the node casts
//! one ray per pixel of each eye (visibility, continued through mirrors and glass:
//! `holocave_vlf::view`) and the GPU shades each pixel's lookup and blends it under the
//! render cache's exact samples (`cache/shade_field.wgsl`, through [`crate::RenderCache`]).
//!
//! The direct light of the sun, punctual lights and emissive triangles is computed per
//! pixel on the same threads, for the point each pixel's ray found
//! ([`holocave_vlf::pixel_direct`]: `1 + P + 1` shadow rays per pixel and frame, two more
//! where a glossy floor's reflection of the sky is sharpened, averaged
//! per surface point while the view stays still, and carried over to the next view of the
//! same screen when the eye moves: `Accumulator::reproject`), and handed to the shader inside the
//! lookup's `emitted` light; the light field then gives only the rest
//! ([`holocave_vlf::State::indirect_values`]), so nothing is counted twice.
//!
//! With the rays on the CPU, each eye keeps what its last frame's pixels saw and showed:
//! a still eye draws its surfaces again, a moving one carries its pixels to the new view
//! ([`holocave_vlf::carry`]) and traces and estimates only those it must draw anew.
//!
//! With [`VlfBase::with_rays`] choosing the GPU, each pixel's first hit is found on the GPU
//! instead ([`crate::gpu_rays`]: the wall's rays made and traced there, the hits read
//! back and kept there), and the rays on through mirrors and glass, made on the CPU from
//! the surfaces' materials, are traced there in batches (`holocave_vlf::surface::follow_all`).
//! The direct light's shadow rays are traced there too, all of a frame's at once: those of
//! every pixel that sees its first hit made there from the kept hit (towards the sun's
//! disc and the punctual lights from which samples alone, towards the area lamps' points
//! and the sky's directions the CPU drew from their aims: `gpu_rays::ShadowMaker`; a bit a
//! ray back), those of points beyond mirrors and glass made on the CPU and sent (the
//! moving objects are tested on the CPU). The lookups a wall draws are composed there from
//! the kept hits where they are an element's ([`VlfBase::draw_lookups`]: 16 bytes a pixel
//! sent instead of 64, the weight from the material data on the GPU; 32 where the CPU
//! sends the weight), and gather samples trace their three batches of rays there
//! ([`VlfBase::gather`]).

pub mod prior;
pub mod time_of_day;

use std::path::Path;
use std::sync::{Arc, Mutex};

use glam::{Mat4, Vec3};
use holocave_cave::WallView;
use holocave_scene::{Hit, Placement, PunctualKind, Ray, Scene};
use holocave_vlf::baked::Opened;
use holocave_vlf::footprint::Screen;
use holocave_vlf::gather::{Gathered, gather_all};
use holocave_vlf::kept_gathers::KeptGathers;
use holocave_vlf::pixel_direct::same_point;
use holocave_vlf::settling::Settling;
use holocave_vlf::view::{GATHERED_OCCLUSION, ReflectionFrames};
use holocave_vlf::{
    Accumulator, Aim, CpuRays, DirectPoint, Estimate, FrameContext, FrameSurfaces, Lookup, Made,
    MadeRays, StaticRays, WallPass,
};
use holocave_vlf::{baked, carry};
use rayon::prelude::*;

use crate::cache::{MAX_OBJECTS, ObjectMove, SKY_SHARE, ShadowLight};
use crate::gpu_rays::lookups::{LookupComposer, split};
use crate::gpu_rays::{GpuRays, KeptHits, OnGpu, Query, Rays, ShadowMaker};
use crate::light_field::prior::Measured;
use crate::{EyeView, Gpu, RenderCache, RenderNodeError};

/// How many samples the light field is worth in a pixel unless told. Blending `n`
/// samples of variance `σ²` with a base of squared error `b²` as `(kV + nC)/(k + n)`
/// has mean squared error `(k b² k + n σ²)/(k + n)²`, least at `k = σ²/b²`. On the
/// Cornell box's front view one path's relative squared error is 6.7 on average (caustic
/// fireflies) and 0.069 in the median pixel, the light field's 0.007 and 0.001: `k` is
/// 950 by the means, 68 by the medians. 256 lies between: the excess error while samples
/// accumulate stays below `σ²/4k` (0.0065) and the samples have half the say after 256
/// per pixel (see README, "The VLF under the render cache").
pub const DEFAULT_PRIOR_SAMPLES: f32 = 256.0;

/// Views whose per-pixel direct light is being averaged at once (a node's walls times
/// two eyes); a view not drawn for longer is dropped first.
const HISTORIES: usize = 8;

/// A baked light field and the scene it was baked for, drawn on a wall: the per-pixel
/// pass's stages ([`WallPass`]) run over a frame's pixels at once, with their running
/// means kept from frame to frame.
pub struct VlfBase {
    pass: WallPass,
    /// When a pixel's running mean takes no more estimates (`None`: one every frame).
    settling: Option<Settling>,
    /// What each eye's pixels saw in its last frame, where it may be drawn again.
    surfaces: Mutex<Vec<KeptSurfaces>>,
    /// What the frames cost since last asked ([`VlfBase::take_work`]).
    work: Mutex<FrameWork>,

    /// The running means of the direct light, per eye and view drawn, with the frame each
    /// was last drawn (a moved eye takes over its own nearest one of the same screen).
    history: Mutex<Vec<History>>,
    /// Buffers for what a frame's pixels see, kept between frames (one per view drawn at
    /// once).
    pixels: Mutex<Vec<Pixels>>,
    /// Where the pixels' first hits are found: on this GPU, or (`None`) on the CPU.
    gpu_rays: Option<OnGpuRays>,
    shadow_lights: Vec<ShadowLight>,
    /// The gather samples kept in the field's elements, once a display's samples are
    /// gathers ([`VlfBase::keep_gathers`]).
    kept: Mutex<Option<KeptGathers>>,
    /// The field's worth under a display's samples, as measured there
    /// ([`VlfBase::under_samples`]): each pixel's samples count by its direct light's
    /// estimates.
    measured: Mutex<Option<Measured>>,
}

/// The GPU that traces a node's rays: its engine, the maker of the direct light's shadow
/// rays from a wall's first hits kept there (`None` for a scene whose lights it does not
/// make), and the composer of the light field's lookups from the same hits (`None` where
/// the adapter cannot bind what it reads).
struct OnGpuRays {
    gpu: Gpu,
    engine: Mutex<GpuRays>,
    maker: Option<Mutex<ShadowMaker>>,
    composer: Option<Mutex<LookupComposer>>,
}

/// What one view's pixels see: the points the direct light is computed at, and with rays
/// on the GPU the first hits read back and kept there.
#[derive(Default)]
struct Pixels {
    points: Vec<Option<DirectPoint>>,
    hits: Option<Vec<Option<Hit>>>,
    kept: Option<KeptHits>,
}

/// The first hits of a frame's pixels found on the GPU: read back, and kept there.
#[derive(Clone, Copy)]
struct GpuHits<'a> {
    hits: Option<&'a [Option<Hit>]>,
    kept: Option<&'a KeptHits>,
}

/// One eye's running means of the direct light in one view.
struct History {
    /// When it was last drawn (a count of draws).
    drawn: u64,
    /// The eye (its index in the display).
    eye: usize,
    view: WallView,
    means: Accumulator,
    /// What each pixel keeps of its point while it sees it: a still view's pixels see
    /// the same points frame after frame.
    at_points: Vec<AtPoint>,
    /// How many frames in a row this eye has drawn this view: the next one's reflections
    /// take the directions that follow theirs ([`ReflectionFrames::still`]).
    still: u64,
}

/// What one eye's pixels saw in its last frame of a view (stages 1–3), their points, and
/// the light each showed before the edges (stages 4–6), for the eye's next frame: drawn
/// again where the eye stays still, carried where it moves ([`carry`]).
struct KeptSurfaces {
    eye: usize,
    view: WallView,
    surfaces: FrameSurfaces,
    points: Vec<Option<DirectPoint>>,
    lit: Vec<Lookup>,
    /// Frames since each pixel was drawn anew.
    ages: Vec<u8>,
    /// How many frames of its view had been drawn in a row before it: from 1 on, its
    /// glossy lobes' reflections were drawn ([`ReflectionFrames::still`]) and a still eye
    /// draws them anew where they are.
    still: u64,
    /// The pixels drawn anew in its frame, and those to draw anew in the next: an object
    /// moved in their way or changed their light.
    anew: Vec<bool>,
    stale: Vec<bool>,
}

/// A frame's pixels found (stages 1–3): what they see, and where they carry their light
/// from the last frame (stages 4–6, `None` where it is found anew).
struct Found {
    surfaces: FrameSurfaces,
    ages: Vec<u8>,
    held: Option<Vec<Option<Lookup>>>,
    /// The pixels drawn anew.
    anew: Vec<bool>,
}

/// What a wall's frames cost, counted in pixels (both eyes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameWork {
    /// Pixels whose first hits, chains and lookups were found anew.
    pub traced: usize,
    /// Pixels drawn again from what they saw in the last frame (a still view), or carried
    /// from it to the view the eye moved to.
    pub reused: usize,
    /// Pixels that took direct-light estimates.
    pub estimated: usize,
}

/// What a pixel keeps of the point it sees, from frame to frame while it sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct AtPoint {
    at: Vec3,
    /// The caustics' light there ([`Visibility::caustic_light`]), taken once.
    caustic: Vec3,
    /// The mean of the glossy reflections drawn there ([`DirectPoint::reflected`]), and
    /// over how many frames.
    reflected: Vec3,
    frames: u32,
}

impl AtPoint {
    /// Where a pixel sees no point.
    const NONE: AtPoint = AtPoint {
        at: Vec3::NAN,
        caustic: Vec3::ZERO,
        reflected: Vec3::ZERO,
        frames: 0,
    };
}

/// What each pixel keeps of its point (`points`, this frame's), with this frame's
/// reflections in the mean: where the pixel saw the same point last frame (`kept`) its
/// caustics are taken again and its mean goes on (kept as it is in a frame that drew none
/// there), else `caustic` gives the point's caustics and the mean starts again. A pixel
/// `held` shows the light it carried and keeps nothing.
fn at_points(
    points: &[Option<DirectPoint>],
    kept: &[AtPoint],
    held: impl Fn(usize) -> bool + Sync,
    caustic: impl Fn(usize, &DirectPoint) -> Vec3 + Sync,
) -> Vec<AtPoint> {
    (points.par_iter().enumerate())
        .map(|(i, p)| {
            let Some(p) = p.as_ref().filter(|_| !held(i)) else {
                return AtPoint::NONE;
            };
            match (
                kept.get(i).filter(|k| same_point(k.at, p.position)),
                p.reflected,
            ) {
                (Some(&k), Some(r)) => {
                    let frames = k.frames.saturating_add(1);
                    AtPoint {
                        reflected: k.reflected + (r - k.reflected) / frames as f32,
                        frames,
                        ..k
                    }
                }
                (Some(&k), None) => k,
                (None, r) => AtPoint {
                    at: p.position,
                    caustic: caustic(i, p),
                    reflected: r.unwrap_or(Vec3::ZERO),
                    frames: u32::from(r.is_some()),
                },
            }
        })
        .collect()
}

/// The directions a glossy reflection of GGX `alpha` takes at a point of unit normal
/// `normal` seen along `view`, as a distant light for an object to stand in the way of:
/// the mirror direction, widened to twice the half-vector's angle at `tan θ = 3 α`
/// (within which lie 90 % of GGX's microfacet normals, `tan²θ / (α² + tan²θ)`).
fn reflected_lobe(view: Vec3, normal: Vec3, alpha: f32) -> ShadowLight {
    let d = view.normalize_or_zero();
    let mirror = d - 2.0 * d.dot(normal) * normal;
    ShadowLight::distant(mirror, 2.0 * (3.0 * alpha).atan())
}

/// Emissive triangles beyond this many are taken together, as one light the size of all.
const AREA_SHADOW_LIGHTS: usize = 64;

/// The lights whose shadows a moving object changes, for the render cache to drop the
/// points it shadowed or now shadows: the sun (a disc of its angular size), every
/// punctual light, and each emissive triangle of the static scene as a light the size of
/// its bounding sphere (all of them as one when there are more than
/// `AREA_SHADOW_LIGHTS`). The sky is left out: what an object takes from it is the
/// indirect light near the object, which the lookups leave to the light field there.
pub fn shadow_lights(scene: &Scene) -> Vec<ShadowLight> {
    let mut lights = Vec::new();
    if let Some(sun) = &scene.daylight.sun {
        lights.push(ShadowLight::distant(sun.direction, sun.angular_radius));
    }
    for l in &scene.lights {
        lights.push(match l.kind {
            PunctualKind::Directional => ShadowLight::distant(-l.direction, 0.0),
            _ => ShadowLight::at(l.position, 0.0),
        });
    }
    let emitters: Vec<&[Vec3; 3]> = (0..scene.triangle_count() as u32)
        .filter(|&t| scene.materials[scene.triangle_shading(t).material as usize].is_emissive())
        .map(|t| scene.triangle(t))
        .collect();
    let sphere = |points: &mut dyn Iterator<Item = Vec3>| {
        let (lo, hi) = points.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p), hi.max(p))
        });
        ShadowLight::at((lo + hi) * 0.5, (hi - lo).length() * 0.5)
    };
    if emitters.len() > AREA_SHADOW_LIGHTS {
        lights.push(sphere(&mut emitters.iter().flat_map(|t| t.iter().copied())));
    } else {
        lights.extend(emitters.iter().map(|t| sphere(&mut t.iter().copied())));
    }
    lights
}

/// How a wall draws its light field: what it computes per pixel and where its rays go.
#[derive(Clone, Copy, Debug)]
pub struct VlfDrawing {
    /// The direct light per pixel (false: the light field alone, its baked direct light
    /// included).
    pub direct: bool,
    /// The sky's light per pixel too ([`VlfBase::open_with_sky`]).
    pub sky_per_pixel: bool,
    /// Where each pixel's rays are traced.
    pub rays: Rays,
}

impl VlfBase {
    /// The light field at `path` as a wall draws it (`drawing`), checked against `scene`;
    /// its rays on `gpu` when `drawing.rays` puts them on a GPU (`None`: a device of its
    /// own). The one way `node`, the cluster node and `compare` open a wall's light field.
    pub fn for_wall(
        path: &Path,
        scene: Arc<Scene>,
        drawing: VlfDrawing,
        gpu: Option<&Gpu>,
    ) -> Result<VlfBase, RenderNodeError> {
        let opened = baked::open(path, &scene).map_err(|e| RenderNodeError::Vlf(e.to_string()))?;
        Self::drawn(opened, scene, drawing, gpu, path)
    }

    /// [`Self::for_wall`] of a field already opened (`path` names it in messages): a bake
    /// set's blend, or a bake drawn under a scene lit at another time than its own.
    pub fn drawn(
        opened: Opened,
        scene: Arc<Scene>,
        drawing: VlfDrawing,
        gpu: Option<&Gpu>,
        path: &Path,
    ) -> Result<VlfBase, RenderNodeError> {
        let base = Self::of_opened(opened, scene, drawing.sky_per_pixel, path)?
            .with_direct(drawing.direct);
        if drawing.rays == Rays::Cpu {
            return Ok(base);
        }
        let gpu = match gpu {
            Some(g) => g.clone(),
            None => Gpu::new()?,
        };
        base.with_rays(&gpu, drawing.rays)
    }

    /// Opens `path`, refusing a file baked for another scene or with another layout.
    pub fn open(path: &Path, scene: Arc<Scene>) -> Result<VlfBase, RenderNodeError> {
        Self::open_with_sky(path, scene, false)
    }

    /// [`Self::open`]; the direct light per pixel sharpens the sky's reflection where a
    /// tile widened a glossy lobe, or with `sky_per_pixel` takes the whole sky, under the
    /// light field's sky as a prior worth [`SKY_PRIOR_SAMPLES`] of a pixel's samples, and
    /// the lookups read the field less the sky's first arrival (an error for a file baked
    /// without it) ([`Split`]).
    pub fn open_with_sky(
        path: &Path,
        scene: Arc<Scene>,
        sky_per_pixel: bool,
    ) -> Result<VlfBase, RenderNodeError> {
        let opened = baked::open(path, &scene).map_err(|e| RenderNodeError::Vlf(e.to_string()))?;
        Self::of_opened(opened, scene, sky_per_pixel, path)
    }

    fn of_opened(
        opened: Opened,
        scene: Arc<Scene>,
        sky_per_pixel: bool,
        path: &Path,
    ) -> Result<VlfBase, RenderNodeError> {
        if !opened.file.state.converged {
            tracing::warn!(
                "{}: bake not finished ({} bounces); drawing what it has",
                path.display(),
                opened.file.state.bounces
            );
        }
        let shadow_lights = shadow_lights(&scene);
        let pass = WallPass::of_opened(scene, opened, sky_per_pixel)
            .map_err(|e| RenderNodeError::Vlf(format!("{}: {e}", path.display())))?;
        Ok(VlfBase {
            pass,
            settling: Some(Settling::WALLS),
            surfaces: Mutex::new(Vec::new()),
            work: Mutex::new(FrameWork::default()),

            history: Mutex::new(Vec::new()),
            pixels: Mutex::new(Vec::new()),
            gpu_rays: None,
            shadow_lights,
            kept: Mutex::new(None),
            measured: Mutex::new(None),
        })
    }

    /// The scene drawn.
    pub fn scene(&self) -> &Arc<Scene> {
        self.pass.scene()
    }

    /// The per-pixel pass this wall runs.
    pub fn pass(&self) -> &WallPass {
        &self.pass
    }

    /// Where the scene's moving objects stand now.
    pub fn placements(&self) -> Vec<Placement> {
        self.pass.visibility().placements()
    }

    /// Puts the scene's moving objects at `placements` (one per object, in the scene's
    /// order) for the frames drawn from now on, and returns how each that moved did, for
    /// the render cache ([`crate::RenderCache::move_objects`]). Where a move changed the
    /// light under points that stayed put (their shadows, beside the object), the running
    /// means of the direct light start again ([`ObjectMove::shadows`],
    /// [`ObjectMove::takes_more_than`]); every
    /// other pixel's goes on.
    pub fn place_objects(&self, placements: &[Placement]) -> Vec<ObjectMove> {
        let before = self.pass.visibility().placements();
        if !self.pass.visibility().place_objects(placements) {
            return Vec::new();
        }
        let objects = self.scene().objects();
        let after = self.pass.visibility().placements();
        let matrix = |p: &Placement| Mat4::from_rotation_translation(p.rotation, p.translation);
        let moves: Vec<ObjectMove> = (before.iter().zip(&after).enumerate())
            .filter(|(_, (a, b))| a != b)
            .map(|(k, (a, b))| {
                let sphere = |p: &Placement| {
                    let (centre, radius) = objects[k].bounding_sphere(p);
                    centre.extend(radius)
                };
                ObjectMove::new(k, matrix(b) * matrix(a).inverse(), sphere(a), sphere(b))
            })
            .collect();
        self.restart_where_moved(&moves);
        self.mark_moved(&moves);
        moves
            .into_iter()
            .filter(|m| m.object() < MAX_OBJECTS)
            .collect()
    }

    /// Starts again the running means, in every view, of the points whose light `moves`
    /// changed: on a moved object, in its shadows before and after, beside it (where its
    /// sphere takes more than [`SKY_SHARE`] of a point's hemisphere with the sky per pixel,
    /// else more than the share beyond which a point gathers what the objects change,
    /// [`GATHERED_OCCLUSION`]), or in the way of a sharpened reflection of the sky.
    fn restart_where_moved(&self, moves: &[ObjectMove]) {
        let mut h = self.history.lock().unwrap_or_else(|e| e.into_inner());
        for x in h.iter_mut() {
            let eye = x.view.eye;
            (x.means).restart_where(|triangle, at| self.light_moved(moves, eye, triangle, at));
        }
    }

    /// Whether `moves` changed the light a point `at` of `triangle` sends towards `eye`:
    /// it is on a moved object, in its shadows before and after, beside it (where its
    /// sphere takes more than [`SKY_SHARE`] of the point's hemisphere with the sky per
    /// pixel, else more than the share beyond which a point gathers what the objects
    /// change, [`GATHERED_OCCLUSION`]), or the object stands in the way of a sharpened
    /// reflection of the sky there.
    fn light_moved(&self, moves: &[ObjectMove], eye: Vec3, triangle: u32, at: Vec3) -> bool {
        let scene = self.scene();
        let direct = self.pass.direct();
        let share = if direct.samples_sky() {
            SKY_SHARE
        } else {
            GATHERED_OCCLUSION
        };
        let on = scene.statics().object_of(triangle);
        if on.is_some_and(|k| moves.iter().any(|m| m.object() == k)) {
            return true;
        }
        let normal = on.is_none().then(|| scene.face_normal(triangle));
        let lobe = (normal.zip(direct.sharpened_lobe(triangle)))
            .map(|(n, alpha)| reflected_lobe(at - eye, n, alpha));
        moves.iter().any(|m| {
            m.shadows(at, &self.shadow_lights)
                || m.takes_more_than(share, at, normal)
                || lobe.is_some_and(|l| m.shadows(at, &[l]))
        })
    }

    /// Marks, in what each eye keeps of its last frame, the pixels `moves` changed, to be
    /// drawn anew: those the object stood or stands in the way of (the eye's ray to the
    /// pixel's point, or through its centre where it sees none, or any that sees its
    /// point through a mirror or glass), and those whose light it changed
    /// ([`Self::light_moved`]). Every other pixel is drawn again, or carried.
    fn mark_moved(&self, moves: &[ObjectMove]) {
        let mut all = self.surfaces.lock().unwrap_or_else(|e| e.into_inner());
        for k in all.iter_mut() {
            let (view, eye) = (k.view, k.view.eye);
            let seen_from = [ShadowLight::at(eye, 0.0)];
            let w = view.size.width as usize;
            let stale: Vec<bool> = (k.points.par_iter().enumerate())
                .map(|(i, p)| match p {
                    Some(p) if p.span == [Vec3::ZERO; 2] => true,
                    Some(p) => {
                        moves.iter().any(|m| m.shadows(p.position, &seen_from))
                            || self.light_moved(moves, eye, p.triangle, p.position)
                    }
                    None => {
                        let centre = glam::Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
                        let far = view.ray(centre).at(1e4);
                        moves.iter().any(|m| m.shadows(far, &seen_from))
                    }
                })
                .collect();
            for (s, now) in k.stale.iter_mut().zip(stale) {
                *s |= now;
            }
        }
    }

    /// The lights whose shadows a moving object changes (see [`shadow_lights`]).
    pub fn shadow_lights(&self) -> &[ShadowLight] {
        &self.shadow_lights
    }

    /// With `on` false, the light field alone as baked (its direct light included, no
    /// shadow rays); with `on` true (as opened), the direct light per pixel and the light
    /// field's remainder. Choose before handing the values to the GPU.
    pub fn with_direct(mut self, on: bool) -> Self {
        self.pass = self.pass.with_direct(on);
        self
    }

    /// The rule by which a pixel's running mean of the direct light is settled and takes
    /// no more estimates ([`Settling::WALLS`] as opened); `None`: every pixel that sees a
    /// point takes one every frame.
    pub fn with_settling(mut self, settling: Option<Settling>) -> Self {
        self.settling = settling;
        self
    }

    /// Whether the direct light is computed per pixel.
    pub fn direct_per_pixel(&self) -> bool {
        self.pass.direct_per_pixel()
    }

    /// Finds the pixels' first hits where `rays` says: on `gpu` (the scene's BVH uploaded
    /// to it once, here) or on the CPU; `auto` takes the GPU on a hardware adapter.
    pub fn with_rays(mut self, gpu: &Gpu, rays: Rays) -> Result<Self, RenderNodeError> {
        self.gpu_rays = if rays.on_gpu(gpu) {
            let (scene, vis) = (self.pass.scene(), self.pass.visibility());
            let engine = GpuRays::for_scene(gpu, scene)?;
            let maker = ShadowMaker::new(gpu, &engine, scene).map(Mutex::new);
            let composer = LookupComposer::new(gpu, vis.elements(), scene);
            Some(OnGpuRays {
                gpu: gpu.clone(),
                engine: Mutex::new(engine),
                maker,
                composer: composer.map(Mutex::new),
            })
        } else {
            None
        };
        let adapter = gpu.raw_adapter.get_info().name;
        match self.gpu_rays {
            Some(_) => tracing::info!(
                "light field: each pixel's first hit, shadow rays and gathers traced on {adapter}"
            ),
            None => tracing::info!(
                "light field: each pixel's first hit, shadow rays and gathers traced on the CPU \
                 (--rays {rays}, adapter {adapter})"
            ),
        }
        Ok(self)
    }

    /// Whether the pixels' first hits are found on the GPU.
    pub fn rays_on_gpu(&self) -> bool {
        self.gpu_rays.is_some()
    }

    /// With the rays on the GPU, the pixels' first hits of `wall` found there, read back
    /// into `pixels` and kept there (for the shadow rays made and the lookups composed
    /// from them); nothing where the rays are on the CPU.
    fn trace_first_hits(&self, wall: &WallView, pixels: &mut Pixels) {
        pixels.hits = self.gpu_rays.as_ref().map(|g| {
            let mut engine = g.engine.lock().unwrap_or_else(|e| e.into_inner());
            let n = engine.trace_wall(&g.gpu, wall, f32::INFINITY, Query::ClosestHit);
            let hits = engine.read_hits(&g.gpu, n);
            engine.keep_hits(&g.gpu, n, &mut pixels.kept);
            hits
        });
    }

    /// One gather sample along each ray ([`holocave_vlf::gather`]): the direct light
    /// exact at the point seen and after one bounce, the light field's remainder beyond.
    /// Their rays are traced where the pixels' first hits are.
    /// Where the gathers are kept ([`Self::keep_gathers`]), each one's estimate is
    /// added to its element.
    pub fn gather(&self, rays: &[Ray], seed: u64) -> Vec<Gathered> {
        let (vis, nee) = (self.pass.visibility(), self.pass.direct());
        let indirect = self.pass.remainder().as_slice();
        let gathered = match self.on_gpu() {
            Some(traced) => gather_all(vis, nee, indirect, rays, seed, &traced),
            None => gather_all(vis, nee, indirect, rays, seed, &CpuRays(self.scene())),
        };
        if let Some(kept) = self.kept.lock().unwrap_or_else(|e| e.into_inner()).as_mut() {
            kept.add(gathered.iter().filter_map(|g| g.kept));
        }
        gathered
    }

    /// Keeps the gather samples taken from now on in the field's elements, a baked
    /// value worth `prior` of them ([`holocave_vlf::kept_gathers`]), or takes the new
    /// prior where they are kept already. Only where the lookups read the field's
    /// remainder beside the direct light per pixel, with the sky in the field (a gather's
    /// bounce brings the sky) and no moving objects (the bounce does not see them): false
    /// elsewhere.
    pub fn keep_gathers(&self, prior: f32) -> bool {
        let sky_per_pixel = self.pass.sky_prior().is_some();
        if !self.direct_per_pixel() || sky_per_pixel || !self.scene().objects().is_empty() {
            return false;
        }
        let mut kept = self.kept.lock().unwrap_or_else(|e| e.into_inner());
        match kept.as_mut() {
            Some(k) => k.set_prior(prior),
            None => *kept = Some(KeptGathers::new(self.pass.remainder().clone(), prior)),
        }
        true
    }

    /// Draws the lookups for a display whose samples measured the field's worth as
    /// `measured`: each pixel's samples count by how many estimates its direct light's
    /// mean holds ([`Measured::worth_at`], in [`Lookup::samples`]).
    pub fn under_samples(&self, measured: Measured) {
        *self.measured.lock().unwrap_or_else(|e| e.into_inner()) = Some(measured);
    }

    /// Runs `f` with the field's values and the gathers kept in them, and the ranges of
    /// them that changed since last asked, where any did; the lookups made on the CPU
    /// (a mirror-drawn surface's base) read the changed values from now on.
    pub fn with_kept_values(&self, f: impl FnOnce(&[[f32; 3]], &[std::ops::Range<usize>])) {
        let mut kept = self.kept.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(k) = kept.as_mut() {
            let changed = k.take_changed();
            if !changed.is_empty() {
                self.pass.visibility().update_drawn(k.values(), &changed);
                self.forget_surfaces();
                f(k.values(), &changed);
            }
        }
    }

    /// The GPU's walk, when the rays are traced there.
    fn on_gpu(&self) -> Option<OnGpu<'_>> {
        let g = self.gpu_rays.as_ref()?;
        Some(OnGpu {
            gpu: &g.gpu,
            engine: &g.engine,
        })
    }

    /// What a still wall shows of the light field along each ray (no samples, a view's
    /// first frame), ray `i` taking sample sequence `i`: [`WallPass::radiance`], with
    /// the mean of `estimates` per-pixel direct estimates when the walls draw that.
    pub fn field_radiance(&self, rays: &[Ray], estimates: u32) -> Vec<glam::Vec3> {
        let first_frame = ReflectionFrames::still(0);
        let ctx = FrameContext {
            values: self.values(),
            reflections: &first_frame,
            estimates,
        };
        (rays.par_iter().enumerate())
            .map(|(i, &ray)| self.pass.radiance(ctx, ray, i as u64))
            .collect()
    }

    /// What the lookups read: the elements' irradiance, then the tiles' radiance.
    pub fn values(&self) -> &[[f32; 3]] {
        self.pass.values()
    }

    /// What each pixel of `view`, drawn for the display's eye `eye`, sees (the node's own
    /// ray casts, on all cores), with the direct light per pixel in its `emitted` light:
    /// this frame's estimate averaged with those of earlier frames of the same eye at the
    /// same surface point.
    pub fn lookups(&self, eye: usize, view: &EyeView) -> Vec<Lookup> {
        self.lookups_with(eye, view, |lookups, _| lookups)
    }

    /// [`Self::lookups`] written into the render cache's lookups of eye `eye`: with the
    /// rays on the GPU (of the cache's device), each common pixel's composed there from
    /// its first hit kept there, the rest sent whole ([`crate::gpu_rays::lookups`]); else
    /// all sent. How many pixels took their weight from the material data on the GPU;
    /// `None` where all were sent.
    pub fn draw_lookups(
        &self,
        eye: usize,
        view: &EyeView,
        cache: &mut RenderCache,
    ) -> Option<usize> {
        self.lookups_with(eye, view, |lookups, pixels| {
            if let Some(g) = &self.gpu_rays
                && let Some(composer) = &g.composer
                && let (Some(hits), Some(kept)) = (&pixels.hits, &pixels.kept)
                && cache.gpu().same_device(&g.gpu)
                && let Some(target) = cache.lookups_buffer(eye)
            {
                let elements = self.pass.visibility().elements();
                let mut composer = composer.lock().unwrap_or_else(|e| e.into_inner());
                let surfaces = &composer.surfaces;
                let split = split(elements, surfaces, &lookups, &pixels.points, hits);
                composer.compose(&g.gpu, kept, &split, target);
                Some(split.weighed_here())
            } else {
                cache.set_lookups(eye, &lookups);
                None
            }
        })
    }

    /// Runs `f` with what each pixel of `view` sees ([`Self::lookups`]) and the pixels'
    /// points and first hits.
    fn lookups_with<T>(
        &self,
        eye: usize,
        view: &EyeView,
        f: impl FnOnce(Vec<Lookup>, &Pixels) -> T,
    ) -> T {
        let mut pixels = {
            let mut pool = self.pixels.lock().unwrap_or_else(|e| e.into_inner());
            pool.pop().unwrap_or_default()
        };
        // A still view's frames take the glossy lobes' directions on from the last frame's.
        let still = {
            let h = self.history.lock().unwrap_or_else(|e| e.into_inner());
            (h.iter().find(|x| x.eye == eye && x.view == view.wall)).map_or(0, |x| x.still)
        };
        let reflections = ReflectionFrames::still(still);
        let found = match self.take_surfaces(eye, &view.wall) {
            Some(k) if k.view == view.wall && k.still > 0 => {
                self.drawn_again(view, k, &mut pixels, &reflections)
            }
            Some(k) if k.view != view.wall && self.may_keep() => {
                self.carried(view, k, &mut pixels, &reflections)
            }
            _ => self.traced(view, &mut pixels, &reflections),
        };
        let Found {
            surfaces,
            ages,
            held,
            anew,
        } = found;
        let kept_surfaces = self.may_keep().then(|| surfaces.clone());
        let Pixels { points, hits, kept } = &pixels;
        let gpu = GpuHits {
            hits: hits.as_deref(),
            kept: kept.as_ref(),
        };
        let mut lit = None;
        let lookups = (self.pass).light(&view.wall, surfaces, points, |l, p| {
            self.add_direct(eye, view, (l, p), gpu, held.as_deref());
            lit = Some(l.to_vec());
        });
        self.count_work(points.len(), anew.iter().filter(|&&a| a).count());
        let out = f(lookups, &pixels);
        if let Some(surfaces) = kept_surfaces {
            self.keep_surfaces(KeptSurfaces {
                eye,
                view: view.wall,
                lit: lit.unwrap_or_else(|| surfaces.lookups.clone()),
                surfaces,
                points: std::mem::take(&mut pixels.points),
                stale: vec![false; ages.len()],
                ages,
                still,
                anew,
            });
        }
        let mut pool = self.pixels.lock().unwrap_or_else(|e| e.into_inner());
        pool.push(pixels);
        out
    }

    /// Stages 1–3 of a frame of `view` on a view not drawn last: every pixel traced.
    fn traced(&self, view: &EyeView, pixels: &mut Pixels, reflections: &ReflectionFrames) -> Found {
        self.trace_first_hits(&view.wall, pixels);
        let on_gpu = self.on_gpu();
        // The rays on through mirrors and glass traced where the first hits were.
        let first = (pixels.hits.as_deref()).zip(on_gpu.as_ref().map(|g| g as &dyn StaticRays));
        let surfaces = (self.pass).surfaces(&view.wall, first, &mut pixels.points, reflections);
        let n = pixels.points.len();
        Found {
            surfaces,
            ages: (0..n).map(|i| carry::stagger(&view.wall, i)).collect(),
            held: None,
            anew: vec![true; n],
        }
    }

    /// Stages 1–3 of a still view's frame: what its pixels saw (`k`), its glossy
    /// reflections drawn anew, and the pixels a moved object changed drawn anew.
    fn drawn_again(
        &self,
        view: &EyeView,
        k: KeptSurfaces,
        pixels: &mut Pixels,
        reflections: &ReflectionFrames,
    ) -> Found {
        pixels.points = k.points;
        let mut surfaces = if k.stale.contains(&true) {
            let kept = (k.surfaces.lookups, &mut pixels.points[..]);
            (self.pass).surfaces_carried(&view.wall, kept, &k.stale, reflections)
        } else {
            k.surfaces
        };
        let (lookups, points) = (&mut surfaces.lookups, &mut pixels.points);
        (self.pass).redraw_reflections(&view.wall, lookups, points, reflections);
        Found {
            surfaces,
            ages: k.ages,
            held: None,
            anew: k.stale,
        }
    }

    /// Stages 1–3 of a frame of `view` after the eye moved from `k`'s view: each pixel
    /// that carries one of the last frame's ([`carry`]), but for those a moved object
    /// changed, shows what that showed, its surface and its light; the others are drawn
    /// anew.
    fn carried(
        &self,
        view: &EyeView,
        k: KeptSurfaces,
        pixels: &mut Pixels,
        reflections: &ReflectionFrames,
    ) -> Found {
        // A pixel a moved object changed is drawn anew.
        let limit = |i: usize| {
            let view_dependent = k.surfaces.lookups[i].tile != u32::MAX
                || k.points[i].is_some_and(|p| p.reflected.is_some());
            if k.stale[i] {
                0
            } else {
                carry::age_limit(view_dependent)
            }
        };
        let c = carry::carry(&k.view, &view.wall, (&k.points, &k.ages), limit);
        let from = |j: usize| c.from[j].map(|i| i as usize);
        let n = c.from.len();
        let lookups = (0..n).map(|j| from(j).map_or(Lookup::NONE, |i| k.surfaces.lookups[i]));
        pixels.points = (0..n).map(|j| from(j).and_then(|i| k.points[i])).collect();
        let anew: Vec<bool> = c.from.iter().map(Option::is_none).collect();
        let carried = (lookups.collect(), &mut pixels.points[..]);
        let surfaces = (self.pass).surfaces_carried(&view.wall, carried, &anew, reflections);
        Found {
            surfaces,
            held: Some((0..n).map(|j| from(j).map(|i| k.lit[i])).collect()),
            ages: c.ages,
            anew,
        }
    }

    /// What eye `eye` saw in its last frame of `view`'s screen (stages 1–3), taken to be
    /// drawn again where that frame's view was `view`: a still view's pixels see the same
    /// surfaces frame after frame. `None` where none was kept.
    fn take_surfaces(&self, eye: usize, view: &WallView) -> Option<KeptSurfaces> {
        let mut kept = self.surfaces.lock().unwrap_or_else(|e| e.into_inner());
        let i = (0..kept.len()).find(|&i| kept[i].eye == eye && kept[i].view.same_screen(view))?;
        Some(kept.swap_remove(i))
    }

    /// Whether a frame can be drawn again from what its pixels saw: with the rays on the
    /// CPU (on the GPU the shadow rays are made from the first hits it keeps, in buffers
    /// the views share).
    fn may_keep(&self) -> bool {
        self.gpu_rays.is_none()
    }

    /// Keeps what an eye's frame saw for its next frame, the oldest forgotten beyond
    /// [`HISTORIES`].
    fn keep_surfaces(&self, kept: KeptSurfaces) {
        let mut all = self.surfaces.lock().unwrap_or_else(|e| e.into_inner());
        if all.len() >= HISTORIES {
            all.remove(0);
        }
        all.push(kept);
    }

    /// Forgets what every view saw: the surfaces' light changed under them.
    fn forget_surfaces(&self) {
        self.surfaces
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clear();
    }

    /// Counts a frame of `pixels` pixels, `traced` of them traced anew and the others
    /// drawn again or carried from the last frame.
    fn count_work(&self, pixels: usize, traced: usize) {
        let mut w = self.work.lock().unwrap_or_else(|e| e.into_inner());
        w.traced += traced;
        w.reused += pixels - traced.min(pixels);
    }

    /// What the frames drawn since last asked cost: pixels whose surfaces were traced,
    /// pixels drawn again from the last frame's, pixels that took direct-light estimates.
    pub fn take_work(&self) -> FrameWork {
        std::mem::take(&mut *self.work.lock().unwrap_or_else(|e| e.into_inner()))
    }

    /// Which pixels eye `eye`'s last frame of `view` drew anew (traced, not drawn again
    /// or carried); `None` when that eye kept no frame of that view.
    pub fn drawn_anew(&self, eye: usize, view: &WallView) -> Option<Vec<bool>> {
        let kept = self.surfaces.lock().unwrap_or_else(|e| e.into_inner());
        let k = kept.iter().find(|k| k.eye == eye && k.view == *view)?;
        Some(k.anew.clone())
    }

    /// How many direct-light estimates each pixel's running mean holds for eye `eye` in
    /// `view`, as last drawn; `None` when that eye has no means of that view.
    pub fn estimates_held(&self, eye: usize, view: &WallView) -> Option<Vec<u32>> {
        let h = self.history.lock().unwrap_or_else(|e| e.into_inner());
        let x = h.iter().find(|x| x.eye == eye && x.view == *view)?;
        Some(x.means.counts().to_vec())
    }

    /// How many frames' glossy reflections each pixel's mean holds for eye `eye` in
    /// `view`, as last drawn ([`DirectPoint::reflected`]); `None` when that eye has no
    /// means of that view.
    pub fn reflections_held(&self, eye: usize, view: &WallView) -> Option<Vec<u32>> {
        let h = self.history.lock().unwrap_or_else(|e| e.into_inner());
        let x = h.iter().find(|x| x.eye == eye && x.view == *view)?;
        Some(x.at_points.iter().map(|a| a.frames).collect())
    }

    /// Runs `f` with the shadow rays the GPU makes from the wall's first hits kept there
    /// (which pixels see their first hit, and the GPU's answers to their made rays); with
    /// `None` where the rays are not on the GPU or it makes none of this scene's.
    fn with_made<T>(
        &self,
        points: &[Option<DirectPoint>],
        gpu: GpuHits,
        f: impl FnOnce(Option<&Made>) -> T,
    ) -> T {
        let on_gpu = self.gpu_rays.as_ref();
        let (Some(g), Some(hits), Some(kept)) = (on_gpu, gpu.hits, gpu.kept) else {
            return f(None);
        };
        let Some(maker) = &g.maker else {
            return f(None);
        };
        let at_first_hit: Vec<bool> = (points.par_iter().zip(hits))
            .map(|(p, h)| matches!((p, h), (Some(p), Some(h)) if p.triangle == h.triangle))
            .collect();
        let trace = |rays: &[MadeRays], aims: &[Aim]| {
            let engine = g.engine.lock().unwrap_or_else(|e| e.into_inner());
            let mut maker = maker.lock().unwrap_or_else(|e| e.into_inner());
            maker.trace(&g.gpu, &engine, kept, rays, aims)
        };
        f(Some(&Made {
            at_first_hit: &at_first_hit,
            trace: &trace,
        }))
    }

    /// Stages 4–6 of the wall's frame ([`WallPass::frame`]): adds each pixel's running
    /// mean of the direct light at its point (`points`), its caustics and the mean of its
    /// glossy reflections, to its lookup's `emitted` light, this frame's estimate
    /// included; the shadow rays made on the GPU from the first hits kept there (`gpu`)
    /// where they are. A pixel `held` shows the light it carried instead, and its mean
    /// takes no estimate.
    fn add_direct(
        &self,
        eye: usize,
        view: &EyeView,
        (lookups, points): (&mut [Lookup], &[Option<DirectPoint>]),
        gpu: GpuHits,
        held: Option<&[Option<Lookup>]>,
    ) {
        let (mut acc, moved_from, kept, still) = self.take_history(eye, &view.wall);
        if let Some(from) = moved_from {
            acc.reproject(&from, &view.wall, points);
        }
        let held_at = |i: usize| held.is_some_and(|h| h[i].is_some());
        if let Some(h) = held {
            acc.hold(h.iter().map(Option::is_some).collect());
        }
        let estimates = self.estimate(&mut acc, points, gpu);
        let screen = Screen::of(&view.wall, 1);
        let at_points = at_points(points, &kept, held_at, |i, p| {
            self.pass.caustics(&lookups[i], p, Some(&screen))
        });
        let means = (&estimates[..], acc.counts());
        self.add_means(lookups, points, means, &at_points, held);
        self.work
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .estimated += acc.taken();
        let mut h = self.history.lock().unwrap_or_else(|e| e.into_inner());
        let drawn = h.iter().map(|x| x.drawn).max().unwrap_or(0) + 1;
        h.push(History {
            drawn,
            eye,
            view: view.wall,
            means: acc,
            at_points,
            still,
        });
    }

    /// Eye `eye`'s running means for `view`, taken out while they are used (other views
    /// may be drawn on other threads meanwhile): its history of this view; else, when the
    /// eye moved, its history of the same screen from where it was nearest, with that
    /// view, to carry them over; else new ones in place of the least recently drawn. Never
    /// the other eye's: the two eyes of a wall would take each other's in turn, carrying
    /// the means across the eyes' parallax every frame. With what each pixel kept of its
    /// point, and how many frames in a row this view has now been drawn.
    fn take_history(
        &self,
        eye: usize,
        view: &WallView,
    ) -> (Accumulator, Option<WallView>, Vec<AtPoint>, u64) {
        let mut h = self.history.lock().unwrap_or_else(|e| e.into_inner());
        let own_screen = |x: &History| x.eye == eye && x.view.same_screen(view);
        if let Some(i) = h.iter().position(|x| own_screen(x) && x.view == *view) {
            let x = h.swap_remove(i);
            return (x.means, None, x.at_points, x.still + 1);
        }
        let nearest = (0..h.len())
            .filter(|&i| own_screen(&h[i]))
            .min_by(|&a, &b| {
                let d = |i: usize| h[i].view.eye.distance_squared(view.eye);
                d(a).total_cmp(&d(b))
            });
        if let Some(i) = nearest {
            let x = h.swap_remove(i);
            return (x.means, Some(x.view), Vec::new(), 1);
        }
        if h.len() >= HISTORIES
            && let Some(oldest) = (0..h.len()).min_by_key(|&i| h[i].drawn)
        {
            h.swap_remove(oldest);
        }
        let acc = (self.settling).map_or_else(Accumulator::new, Accumulator::settling);
        (acc, None, Vec::new(), 1)
    }

    /// Stage 4: this frame's estimates at `points` added to the means `acc`, their shadow
    /// rays traced on the GPU where the first hits were (`gpu`), else on the CPU; each
    /// pixel's running mean.
    fn estimate(
        &self,
        acc: &mut Accumulator,
        points: &[Option<DirectPoint>],
        gpu: GpuHits,
    ) -> Vec<Estimate> {
        let direct = self.pass.direct();
        self.pass.visibility().with_placed(|placed| {
            let objects = self.pass.object_gather();
            let gather = |p: &DirectPoint, seed, n| objects.estimate(placed, p, seed, n);
            match self.on_gpu() {
                Some(traced) => self.with_made(points, gpu, |made| {
                    acc.add_blocked(direct, placed, points, (&traced, made), &gather)
                }),
                None => acc.add(direct, placed, points, &gather),
            }
        })
    }

    /// Stages 5–6: each pixel's running mean (`means`: the estimates' means and counts),
    /// its caustics and the mean of its frames' reflections in place of this frame's
    /// (`at_points`), added to its lookup; a pixel `held` shows the light it carried.
    fn add_means(
        &self,
        lookups: &mut [Lookup],
        points: &[Option<DirectPoint>],
        (estimates, counts): (&[Estimate], &[u32]),
        at_points: &[AtPoint],
        held: Option<&[Option<Lookup>]>,
    ) {
        let measured = *self.measured.lock().unwrap_or_else(|e| e.into_inner());
        let each = (lookups.par_iter_mut().zip(estimates).enumerate()).zip(counts);
        each.for_each(|((i, (l, d)), &n)| {
            if let Some(Some(carried)) = held.map(|h| h[i]) {
                *l = carried;
                return;
            }
            let kept = &at_points[i];
            let reflected = match &points[i] {
                Some(p) => kept.reflected - p.reflected.unwrap_or(Vec3::ZERO),
                None => Vec3::ZERO,
            };
            let added = self.pass.added(self.values(), l, (d, n), kept.caustic);
            l.emitted = (Vec3::from(l.emitted) + added + reflected).to_array();
            if d.object_shadow {
                l.samples = 0.0;
            } else if let Some(m) = &measured {
                l.samples *= m.worth_at(n);
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use holocave_tracer::bsdf::Bsdf;

    fn point(at: Vec3, reflected: Option<Vec3>) -> Option<DirectPoint> {
        Some(DirectPoint {
            triangle: 0,
            position: at,
            normal: Vec3::Y,
            shading_normal: Vec3::Y,
            wo: Vec3::Y,
            bsdf: Bsdf::new(&Default::default()),
            weight: Vec3::ONE,
            albedo: Vec3::ZERO,
            surfaces: reflected.unwrap_or(Vec3::ZERO),
            reflected,
            span: [Vec3::ZERO; 2],
            gathered: false,
        })
    }

    /// A pixel that sees the same point frame after frame shows the mean of the frames'
    /// reflections (kept through a frame that draws none there); one that sees another
    /// point starts again, and one that sees none holds nothing.
    #[test]
    fn a_still_pixels_reflections_are_the_mean_of_its_frames() {
        let (a, b) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0));
        let frames = [Some(1.0f32), Some(4.0), None, Some(7.0), Some(2.0)];
        let mut kept = Vec::new();
        let mut drawn = Vec::new();
        for (k, r) in frames.iter().enumerate() {
            let r = r.map(Vec3::splat);
            // The second pixel sees `a` on odd frames and `b` on even ones.
            let second = if k % 2 == 0 { b } else { a };
            let now = [point(a, r), point(second, r), None];
            kept = at_points(&now, &kept, |_| false, |_, _| Vec3::ZERO);
            drawn.extend(r.map(|r| r.x));
            let mean = drawn.iter().sum::<f32>() / drawn.len() as f32;
            assert_eq!(kept[0].frames as usize, drawn.len());
            assert!(
                (kept[0].reflected.x - mean).abs() < 1e-6,
                "{:?} after {k}",
                kept[0]
            );
            let fresh = (second, r.unwrap_or(Vec3::ZERO), u32::from(r.is_some()));
            assert_eq!((kept[1].at, kept[1].reflected, kept[1].frames), fresh);
            assert_eq!((kept[2].reflected, kept[2].frames), (Vec3::ZERO, 0));
        }
    }
}
