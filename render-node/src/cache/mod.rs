//! The render cache on the GPU (Walter, Drettakis & Parker; `papers/render-cache.md`): a
//! fixed-size cache of shaded points shared by every eye, projected and filtered into each
//! eye's image by compute shaders, which also choose the pixels to sample next.
//!
//! Per frame ([`RenderCache::draw`]), for each eye: clear, z-buffered projection
//! (`cache/project.wgsl`), 3×3 depth cull and 3×3 interpolation with the priority image
//! (`cache/filter.wgsl`), error-diffusion choice of pixels (`cache/dither.wgsl`); then
//! aging of all points (`cache/age.wgsl`). Samples come back through
//! [`RenderCache::insert`] (`cache/insert.wgsl`). Every pass is linear in pixels or points.
//!
//! Each shader file has a small module beside it in `cache/` that owns its pipelines and
//! bind group layout, makes its bind groups and records its passes; [`RenderCache::new`]
//! assembles them.

use std::time::{Duration, Instant};

use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec4};
use holocave_cave::Size;
use holocave_tracer::film::Image;

use crate::gpu::Gpu;
use crate::{EyeView, RenderNodeError};
use holocave_vlf::Lookup;

mod age;
mod dither;
mod filter;
mod insert;
mod objects;
mod project;
mod shade_field;

use age::Age;
use dither::Dither;
use filter::Filter;
use insert::Insert;
use objects::MovePoints;
pub use objects::{ObjectMove, SKY_SHARE, ShadowLight};
use project::Project;
use shade_field::VlfPass;

/// Points per replacement group (the oldest of a group is replaced, groups round robin).
pub const GROUP_SIZE: u32 = 8;
/// A surface id for rays that escaped the scene.
pub const BACKGROUND: u32 = u32::MAX - 1;
/// Moving objects whose points the cache tells apart (the high byte of a surface id holds
/// the object's index + 1; 254 marks a point that shows an object beyond a mirror or
/// glass, 255 is the reserved ids', [`BACKGROUND`] and the holodeck's hits); a point on
/// any further object counts as one of the static scene's, and is never blended over an
/// object.
pub const MAX_OBJECTS: usize = 253;

/// What a cached point's sample saw, for the cache to move, drop or count it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleSurface {
    /// The static scene.
    Scene,
    /// Moving object `k` (its index), the point lying on it.
    Object(usize),
    /// A moving object beyond a mirror or glass (the point on the static surface that
    /// shows it): it is dropped when any object moves, and never counts.
    ObjectBeyond,
}

/// The surface id of a point: its material, and what it saw (see `OBJECT_SHIFT` in
/// `gpu/common.wgsl`), so that points on an object move with it and only ever stand
/// for it.
pub fn surface_id(material: u32, seen: SampleSurface) -> u32 {
    let object = match seen {
        SampleSurface::Object(k) if k < MAX_OBJECTS => k as u32 + 1,
        SampleSurface::ObjectBeyond => 254,
        _ => 0,
    };
    (object << 24) | (material & 0x00ff_ffff)
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct EyeParams {
    view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
    width: u32,
    height: u32,
    npoints: u32,
    target_samples: u32,
    max_chosen: u32,
    frame: u32,
    eye_index: u32,
    index_bits: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct InsertParams {
    count: u32,
    cursor: u32,
    ngroups: u32,
    group_size: u32,
    npoints: u32,
    index_bits: u32,
    width: u32,
    height: u32,
}

/// A point of the cache as the GPU stores it (`Point` in `gpu/common.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuPoint {
    pub pos: [f32; 4],
    pub rad: [f32; 4],
    pub origin: [f32; 4],
    pub square: [f32; 4],
}

/// A traced sample on its way into the cache (`NewSample` in `cache/insert.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct NewSample {
    pos: [f32; 4],
    rad: [f32; 4],
    origin: [f32; 4],
    /// x: how many samples this one stands for (their mean radiance); y: 1 when it is
    /// view-independent ([`NewSample::view_independent`]); zw unused.
    weight: [f32; 4],
}

impl NewSample {
    /// A sample for `pixel` (index `y * width + x` of the eye that asked for it): the ray
    /// from `origin` hit `position` (at `distance`) on `surface` and brought `radiance`.
    pub fn new(
        pixel: u32,
        origin: Vec3,
        position: Vec3,
        distance: f32,
        radiance: [f32; 3],
        surface: u32,
    ) -> NewSample {
        NewSample {
            pos: position.extend(f32::from_bits(pixel)).to_array(),
            rad: Vec3::from(radiance)
                .extend(f32::from_bits(surface))
                .to_array(),
            origin: origin.extend(distance).to_array(),
            weight: [1.0, 0.0, 0.0, 0.0],
        }
    }

    /// The same sample standing for the mean of `n` samples (counted `n` times in the
    /// point's running mean).
    pub fn with_weight(mut self, n: f32) -> NewSample {
        self.weight[0] = n.max(1.0);
        self
    }

    /// The same sample, marked as radiance that does not depend on where it is seen
    /// from (its surface is Lambertian): it may join a point made from any eye position,
    /// not only a near one, so a moving head's samples keep averaging.
    pub fn view_independent(mut self) -> NewSample {
        self.weight[1] = 1.0;
        self
    }

    pub fn weight(&self) -> f32 {
        self.weight[0]
    }

    pub fn pixel(&self) -> u32 {
        self.pos[3].to_bits()
    }

    pub fn position(&self) -> Vec3 {
        Vec4::from(self.pos).truncate()
    }

    pub fn radiance(&self) -> Vec3 {
        Vec4::from(self.rad).truncate()
    }
}

/// Wall-clock time of each step of [`RenderCache::draw`] (all eyes), measured by
/// submitting each step on its own and waiting for it (only with `timed`).
#[derive(Clone, Copy, Debug, Default)]
pub struct StepTimes {
    pub clear: Duration,
    pub projection: Duration,
    pub depth_cull: Duration,
    /// Interpolation and the priority image (one pass).
    pub interpolation_priority: Duration,
    /// The light field's lookup and blend (one pass; zero without a light field).
    pub vlf: Duration,
    pub dither: Duration,
    pub aging: Duration,
    /// Copying the chosen pixels back to the CPU.
    pub readback: Duration,
}

impl StepTimes {
    pub fn total(&self) -> Duration {
        self.clear
            + self.projection
            + self.depth_cull
            + self.interpolation_priority
            + self.vlf
            + self.dither
            + self.aging
            + self.readback
    }
}

struct EyeBuffers {
    width: u32,
    height: u32,
    params: wgpu::Buffer,
    key: wgpu::Buffer,
    color: wgpu::Buffer,
    priority: wgpu::Buffer,
    /// The pixels chosen in the last frame.
    last_chosen: Vec<u32>,
    counters: wgpu::Buffer,
    chosen: wgpu::Buffer,
    staging: wgpu::Buffer,
    project_bg: wgpu::BindGroup,
    filter_bg: wgpu::BindGroup,
    dither_bg: wgpu::BindGroup,
    insert_bg: wgpu::BindGroup,
}

/// The passes, one per shader file.
struct Passes {
    project: Project,
    filter: Filter,
    dither: Dither,
    insert: Insert,
    age: Age,
    vlf: VlfPass,
    objects: MovePoints,
}

/// The buffers every eye's bind groups share: the points, what the age pass reads of them,
/// the new samples and where they matched, the insert pass's parameters.
#[derive(Clone, Copy)]
struct SharedBuffers<'a> {
    points: &'a wgpu::Buffer,
    visible: &'a wgpu::Buffer,
    samples: &'a wgpu::Buffer,
    matched: &'a wgpu::Buffer,
    insert_params: &'a wgpu::Buffer,
}

impl Passes {
    fn new(gpu: &Gpu) -> Passes {
        Passes {
            project: Project::new(gpu),
            filter: Filter::new(gpu),
            dither: Dither::new(gpu),
            insert: Insert::new(gpu),
            age: Age::new(gpu),
            vlf: VlfPass::new(gpu),
            objects: MovePoints::new(gpu),
        }
    }
}

impl EyeBuffers {
    /// One eye's buffers and bind groups for an image of `size`, at most `max_chosen`
    /// pixels chosen a frame.
    fn new(
        gpu: &Gpu,
        passes: &Passes,
        shared: SharedBuffers,
        Size { width, height }: Size,
        max_chosen: u32,
    ) -> EyeBuffers {
        let n = u64::from(width) * u64::from(height);
        let params = gpu.uniform("eye params", std::mem::size_of::<EyeParams>() as u64);
        let depth = gpu.storage("depth", 4 * n);
        let key = gpu.storage("key", 4 * n);
        let culled = gpu.storage("culled", 16 * n);
        let color = gpu.storage("color", 16 * n);
        let priority = gpu.storage("priority", 4 * n);
        let counters = gpu.storage("counters", 16);
        let chosen = gpu.storage("chosen", 4 * u64::from(max_chosen));
        let staging = gpu.read_back_buffer("chosen read-back", 16 + 4 * u64::from(max_chosen));
        let project_bg = passes.project.bind_group(
            gpu,
            [
                &params,
                shared.points,
                &depth,
                &key,
                shared.visible,
                &counters,
            ],
        );
        let filter_bg = passes.filter.bind_group(
            gpu,
            [
                &params,
                shared.points,
                &depth,
                &key,
                &culled,
                &color,
                &priority,
                &counters,
            ],
        );
        let dither_bg = passes
            .dither
            .bind_group(gpu, [&params, &priority, &counters, &chosen]);
        let aging = gpu.storage("aging", 4 * n);
        let insert_bg = passes.insert.bind_group(
            gpu,
            [
                shared.insert_params,
                shared.points,
                shared.samples,
                &key,
                shared.matched,
                &aging,
            ],
        );
        EyeBuffers {
            width,
            height,
            params,
            key,
            color,
            priority,
            last_chosen: Vec::new(),
            counters,
            chosen,
            staging,
            project_bg,
            filter_bg,
            dither_bg,
            insert_bg,
        }
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct VlfParams {
    width: u32,
    height: u32,
    index_bits: u32,
    prior: f32,
    /// Values per light-field buffer (the last may hold fewer).
    chunk: u32,
    /// A sample's variance over `μ² + 0.01` on the display ([`crate::light_field::prior::Measured`]);
    /// 0: the prior is the same in every pixel.
    spread: f32,
    _pad: [u32; 2],
}

/// The light field's values are bound as this many storage buffers, each within the
/// adapter's binding limit (128 MiB on lavapipe, where the breakfast room's default bake,
/// 375 MB, needs three).
const VLF_BUFFERS: usize = 4;

/// The Virtual Light Field on the GPU: the baked irradiance, and per eye its lookups.
struct VlfBuffers {
    /// The values, `chunk` floats a buffer; `floats` in all.
    irradiance: Vec<wgpu::Buffer>,
    chunk: usize,
    floats: usize,
    eyes: Vec<(wgpu::Buffer, wgpu::Buffer, wgpu::BindGroup)>,
}

/// The render cache of one render node: points shared by its eyes, images per eye.
pub struct RenderCache {
    gpu: Gpu,
    capacity: u32,
    ngroups: u32,
    cursor: u32,
    max_chosen: u32,
    batch: u32,
    frame: u32,
    /// Low bits of a pixel key holding the point index (enough for `capacity`, with the
    /// all-ones index left for "empty").
    index_bits: u32,
    points: wgpu::Buffer,
    samples: wgpu::Buffer,
    insert_params: wgpu::Buffer,
    age_bg: wgpu::BindGroup,
    eyes: Vec<EyeBuffers>,
    passes: Passes,
    vlf: Option<VlfBuffers>,
    /// Scratch for [`exactly`]: one flag per pixel of the largest eye, all false between
    /// frames.
    taken: Vec<bool>,
}

fn groups(n: u32, size: u32) -> u32 {
    n.div_ceil(size).max(1)
}

/// Records passes, and in timed mode submits and waits after each step.
struct Recorder<'a> {
    gpu: &'a Gpu,
    enc: Option<wgpu::CommandEncoder>,
    timed: bool,
    t0: Instant,
}

impl<'a> Recorder<'a> {
    fn new(gpu: &'a Gpu, timed: bool) -> Self {
        Recorder {
            gpu,
            enc: Some(gpu.device.create_command_encoder(&Default::default())),
            timed,
            t0: Instant::now(),
        }
    }

    fn enc(&mut self) -> &mut wgpu::CommandEncoder {
        self.enc
            .get_or_insert_with(|| self.gpu.device.create_command_encoder(&Default::default()))
    }

    fn pass(&mut self, pipe: &wgpu::ComputePipeline, bg: &wgpu::BindGroup, n: u32, size: u32) {
        let mut pass = self.enc().begin_compute_pass(&Default::default());
        pass.set_pipeline(pipe);
        pass.set_bind_group(0, bg, &[]);
        pass.dispatch_workgroups(groups(n, size), 1, 1);
    }

    /// Ends a step: in timed mode submits, waits and adds the elapsed time to `into`.
    fn step(&mut self, into: &mut Duration) {
        if self.timed {
            self.submit();
            self.gpu.wait();
            *into += self.t0.elapsed();
            self.t0 = Instant::now();
        }
    }

    fn submit(&mut self) {
        if let Some(enc) = self.enc.take() {
            self.gpu.queue.submit([enc.finish()]);
        }
    }
}

impl RenderCache {
    /// The cache a wall's node uses: `eyes` images of `size`, room for every pixel of every
    /// eye and a quarter more (points off screen survive a head turn), and up to twice the
    /// `samples` an eye asks for per frame chosen.
    pub fn for_wall(gpu: Gpu, size: Size, eyes: usize, samples: u32) -> RenderCache {
        let capacity = size.width * size.height * eyes as u32 * 5 / 4;
        RenderCache::new(gpu, &vec![size; eyes], capacity, samples.saturating_mul(2))
    }

    /// Samples an eye asks for per frame unless told: a sixteenth of its pixels.
    pub fn default_samples(size: Size) -> u32 {
        (size.width * size.height / 16).max(1)
    }

    /// A cache of `capacity` points (rounded up to whole groups) for eyes of the given
    /// sizes; at most `max_chosen` pixels are chosen per eye and frame.
    pub fn new(gpu: Gpu, eyes: &[Size], capacity: u32, max_chosen: u32) -> RenderCache {
        let ngroups = capacity.div_ceil(GROUP_SIZE).max(1);
        let capacity = ngroups * GROUP_SIZE;
        let max_chosen = max_chosen.max(1);
        // At most 2^24 points, so that at least 8 bits of a pixel key quantise the miss.
        let index_bits = (32 - capacity.leading_zeros()).max(1);
        assert!(
            index_bits <= 24,
            "a render cache holds at most 2^24 - 1 points ({capacity} asked for)"
        );
        let batch = max_chosen.min(ngroups);
        let empty = GpuPoint {
            pos: [0.0, 0.0, 0.0, 2.0e6],
            rad: [0.0; 4],
            origin: [0.0; 4],
            square: [0.0; 4],
        };
        let points = gpu.storage_init(
            "points",
            bytemuck::cast_slice(&vec![empty; capacity as usize]),
        );
        let visible = gpu.storage("visible", 4 * u64::from(capacity));
        let samples = gpu.storage(
            "samples",
            std::mem::size_of::<NewSample>() as u64 * u64::from(batch),
        );
        let matched = gpu.storage("matched", 4 * u64::from(batch));
        let insert_params = gpu.uniform("insert params", 32);

        let passes = Passes::new(&gpu);
        let shared = SharedBuffers {
            points: &points,
            visible: &visible,
            samples: &samples,
            matched: &matched,
            insert_params: &insert_params,
        };
        let eyes: Vec<EyeBuffers> = (eyes.iter())
            .map(|&size| EyeBuffers::new(&gpu, &passes, shared, size, max_chosen))
            .collect();
        let age_bg = passes
            .age
            .bind_group(&gpu, [&eyes[0].params, &points, &visible]);
        RenderCache {
            gpu,
            capacity,
            ngroups,
            cursor: 0,
            max_chosen,
            batch,
            frame: 0,
            index_bits,
            points,
            samples,
            insert_params,
            age_bg,
            eyes,
            passes,
            vlf: None,
            taken: Vec::new(),
        }
    }

    /// Draws a Virtual Light Field under the cache's samples from now on: `values`, the
    /// irradiance of every element then the radiance of every glossy tile's bins (from a
    /// `.vlf` file: `holocave_vlf::State::values`), worth `prior` samples in each pixel (see
    /// `cache/shade_field.wgsl`). Each frame needs every eye's lookups ([`Self::set_lookups`]).
    pub fn set_vlf(&mut self, values: &[[f32; 3]], prior: f32) -> Result<(), RenderNodeError> {
        let limit = self.gpu.device.limits().max_storage_buffer_binding_size;
        // Floats per buffer: what one binding holds, in whole 256-byte blocks.
        let chunk = ((limit / 4) & !63).min(u64::from(u32::MAX / VLF_BUFFERS as u32)) as usize;
        self.set_vlf_split(values, prior, chunk)
    }

    /// [`Self::set_vlf`] with the values split into buffers of `chunk` floats.
    fn set_vlf_split(
        &mut self,
        values: &[[f32; 3]],
        prior: f32,
        chunk: usize,
    ) -> Result<(), RenderNodeError> {
        let flat: &[f32] = bytemuck::cast_slice(values);
        let limit = 4 * chunk;
        if flat.len() > chunk * VLF_BUFFERS {
            return Err(RenderNodeError::Vlf(format!(
                "the light field's values take {} bytes; this adapter binds {VLF_BUFFERS} buffers of at most {limit} bytes",
                flat.len() * 4
            )));
        }
        let irr: Vec<wgpu::Buffer> = (0..VLF_BUFFERS)
            .map(|b| {
                let part = &flat[(b * chunk).min(flat.len())..((b + 1) * chunk).min(flat.len())];
                let data: &[f32] = if part.is_empty() { &[0.0; 3] } else { part };
                self.gpu
                    .storage_init("vlf irradiance", bytemuck::cast_slice(data))
            })
            .collect();
        let eyes = self
            .eyes
            .iter()
            .map(|e| {
                let n = u64::from(e.width) * u64::from(e.height);
                let params = self
                    .gpu
                    .uniform("vlf params", std::mem::size_of::<VlfParams>() as u64);
                let p = VlfParams {
                    width: e.width,
                    height: e.height,
                    index_bits: self.index_bits,
                    prior,
                    chunk: chunk as u32,
                    spread: 0.0,
                    _pad: [0; 2],
                };
                self.gpu
                    .queue
                    .write_buffer(&params, 0, bytemuck::bytes_of(&p));
                let lookups = self
                    .gpu
                    .storage("vlf lookups", std::mem::size_of::<Lookup>() as u64 * n);
                let bg = self.passes.vlf.bind_group(
                    &self.gpu,
                    [
                        &params,
                        &lookups,
                        &irr[0],
                        &self.points,
                        &e.key,
                        &e.color,
                        &e.priority,
                        &e.counters,
                        &irr[1],
                        &irr[2],
                        &irr[3],
                    ],
                );
                (params, lookups, bg)
            })
            .collect();
        self.vlf = Some(VlfBuffers {
            irradiance: irr,
            chunk,
            floats: flat.len(),
            eyes,
        });
        Ok(())
    }

    /// New values for the light field [`Self::set_vlf`] gave (as many, in the same order:
    /// the gathers kept in its elements), of which those in `changed` are sent; nothing
    /// without a light field, or for values of another length.
    pub fn update_vlf_values(&mut self, values: &[[f32; 3]], changed: &[std::ops::Range<usize>]) {
        let Some(v) = &self.vlf else { return };
        let flat: &[f32] = bytemuck::cast_slice(values);
        if flat.len() != v.floats {
            return;
        }
        for r in changed {
            // The range in floats, cut where one buffer of `chunk` floats ends.
            let (mut at, end) = (3 * r.start.min(values.len()), 3 * r.end.min(values.len()));
            while at < end {
                let (b, offset) = (at / v.chunk, at % v.chunk);
                let upto = end.min((b + 1) * v.chunk);
                self.gpu.queue.write_buffer(
                    &v.irradiance[b],
                    4 * offset as u64,
                    bytemuck::cast_slice(&flat[at..upto]),
                );
                at = upto;
            }
        }
    }

    /// What the light field is worth from now on, in samples per pixel (see
    /// [`Self::set_vlf`]): `prior` where a pixel's samples spread as the display's do,
    /// `spread` their variance over `μ² + 0.01` ([`crate::light_field::prior::Measured::spread`]),
    /// scaled in each pixel by how its own samples spread (`cache/shade_field.wgsl`); with
    /// `spread` 0, `prior` in every pixel. Nothing without a light field.
    pub fn set_vlf_prior(&mut self, prior: f32, spread: f32) {
        if let Some(v) = &self.vlf {
            for (params, _, _) in &v.eyes {
                for (field, value) in [
                    (std::mem::offset_of!(VlfParams, prior), prior),
                    (std::mem::offset_of!(VlfParams, spread), spread),
                ] {
                    self.gpu
                        .queue
                        .write_buffer(params, field as u64, bytemuck::bytes_of(&value));
                }
            }
        }
    }

    /// What each pixel of eye `eye` sees of the light field this frame (one per pixel,
    /// rows from the top). Does nothing without [`Self::set_vlf`].
    pub fn set_lookups(&mut self, eye: usize, lookups: &[Lookup]) {
        let Some(v) = &self.vlf else { return };
        let e = &self.eyes[eye];
        assert_eq!(
            lookups.len(),
            (e.width * e.height) as usize,
            "one lookup per pixel"
        );
        self.gpu
            .queue
            .write_buffer(&v.eyes[eye].1, 0, bytemuck::cast_slice(lookups));
    }

    /// Eye `eye`'s lookups on the GPU (sixteen words a pixel, as [`Self::set_lookups`]
    /// writes them), for a pass that writes them there; `None` without [`Self::set_vlf`].
    pub fn lookups_buffer(&self, eye: usize) -> Option<&wgpu::Buffer> {
        Some(&self.vlf.as_ref()?.eyes.get(eye)?.1)
    }

    /// The light field alone in eye `eye` (its lookups shaded on the GPU): the shader's
    /// side of the CPU/GPU comparison, and a picture of the base itself. Overwrites the
    /// eye's image until the next [`Self::draw`].
    pub fn vlf_image(&mut self, eye: usize) -> Option<Image> {
        let v = self.vlf.as_ref()?;
        let e = &self.eyes[eye];
        let mut r = Recorder::new(&self.gpu, false);
        self.passes
            .vlf
            .lookup(&mut r, &v.eyes[eye].2, e.width * e.height);
        r.submit();
        Some(self.image(eye))
    }

    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    pub fn eye_count(&self) -> usize {
        self.eyes.len()
    }

    pub fn eye_size(&self, eye: usize) -> Size {
        Size::new(self.eyes[eye].width, self.eyes[eye].height)
    }

    /// Draws every eye from the cache, chooses the pixels each eye should sample next
    /// (`targets[eye]` of them, at most `max_chosen` and the eye's pixel count), ages the
    /// points, and returns the chosen pixel indices per eye. With `timed`, adds each
    /// step's time to `times`.
    pub fn draw(
        &mut self,
        views: &[EyeView],
        targets: &[u32],
        timed: bool,
        times: &mut StepTimes,
    ) -> Vec<Vec<u32>> {
        assert_eq!(views.len(), self.eyes.len(), "one view per eye");
        self.frame = self.frame.wrapping_add(1);
        for (i, (e, v)) in self.eyes.iter().zip(views).enumerate() {
            let params = EyeParams {
                view_proj: v.view_proj.to_cols_array_2d(),
                eye: v.eye().extend(v.near).to_array(),
                width: e.width,
                height: e.height,
                npoints: self.capacity,
                target_samples: targets.get(i).copied().unwrap_or(0).min(self.max_chosen),
                max_chosen: self.max_chosen,
                frame: self.frame,
                eye_index: i as u32,
                index_bits: self.index_bits,
            };
            self.gpu
                .queue
                .write_buffer(&e.params, 0, bytemuck::bytes_of(&params));
        }
        let p = &self.passes;
        let mut r = Recorder::new(&self.gpu, timed);
        for (i, e) in self.eyes.iter().enumerate() {
            let n = e.width * e.height;
            p.project.clear(&mut r, &e.project_bg, n);
            r.step(&mut times.clear);
            p.project.project(&mut r, &e.project_bg, self.capacity);
            r.step(&mut times.projection);
            p.filter.cull(&mut r, &e.filter_bg, n);
            r.step(&mut times.depth_cull);
            p.filter.interpolate(&mut r, &e.filter_bg, n);
            r.step(&mut times.interpolation_priority);
            if let Some(v) = &self.vlf {
                p.vlf.blend(&mut r, &v.eyes[i].2, n);
                r.step(&mut times.vlf);
            }
            p.dither.dither(&mut r, &e.dither_bg, e.width, e.height);
            r.step(&mut times.dither);
        }
        p.age.age(&mut r, &self.age_bg, self.capacity);
        r.step(&mut times.aging);
        for e in &self.eyes {
            let enc = r.enc();
            enc.copy_buffer_to_buffer(&e.counters, 0, &e.staging, 0, 16);
            enc.copy_buffer_to_buffer(&e.chosen, 0, &e.staging, 16, 4 * u64::from(self.max_chosen));
        }
        r.submit();
        let (gpu, max_chosen, frame) = (&self.gpu, self.max_chosen, self.frame);
        let taken = &mut self.taken;
        let chosen: Vec<Vec<u32>> = self
            .eyes
            .iter_mut()
            .enumerate()
            .map(|(i, e)| {
                let bytes = gpu.map_read(&e.staging);
                let words: &[u32] = bytemuck::cast_slice(&bytes);
                // The dither appends in whatever order its tiles run: sorted, the choice
                // is the same on every run. A choice that overflowed the list lost pixels
                // that depend on that order: it is dropped, and `exactly` chooses instead.
                let mut chosen = match words {
                    [_, count, _, _, list @ ..] if *count <= max_chosen => {
                        let mut c = list[..*count as usize].to_vec();
                        c.sort_unstable();
                        c
                    }
                    [_, count, ..] => {
                        tracing::debug!(
                            "eye {i}: the dither chose {count} pixels, more than the {max_chosen} listed; choosing evenly instead"
                        );
                        Vec::new()
                    }
                    _ => {
                        // No read-back (a lost device): nothing chosen.
                        e.last_chosen.clear();
                        return Vec::new();
                    }
                };
                let target = targets.get(i).copied().unwrap_or(0).min(max_chosen);
                let seed = frame ^ ((i as u32) << 16);
                exactly(&mut chosen, target, e.width * e.height, taken, seed);
                e.last_chosen.clone_from(&chosen);
                chosen
            })
            .collect();
        r.step(&mut times.readback);
        chosen
    }

    /// Tells the cache that moving objects moved (the render cache paper's §4): the points
    /// on each moved object move with it and are resampled first, the points in its
    /// shadow where it was or is now, towards any of `lights`, are dropped. Takes effect
    /// for the next [`Self::draw`].
    pub fn move_objects(&mut self, moves: &[ObjectMove], lights: &[ShadowLight]) {
        if moves.is_empty() {
            return;
        }
        let mut r = Recorder::new(&self.gpu, false);
        self.passes
            .objects
            .apply(&mut r, &self.points, self.capacity, moves, lights);
        r.submit();
    }

    /// Adds samples that eye `eye` asked for (their pixels index its image).
    pub fn insert(&mut self, eye: usize, samples: &[NewSample]) {
        for chunk in samples.chunks(self.batch as usize) {
            let params = InsertParams {
                count: chunk.len() as u32,
                cursor: self.cursor,
                ngroups: self.ngroups,
                group_size: GROUP_SIZE,
                npoints: self.capacity,
                index_bits: self.index_bits,
                width: self.eyes[eye].width,
                height: self.eyes[eye].height,
            };
            self.cursor = (self.cursor + chunk.len() as u32) % self.ngroups;
            self.gpu
                .queue
                .write_buffer(&self.insert_params, 0, bytemuck::bytes_of(&params));
            self.gpu
                .queue
                .write_buffer(&self.samples, 0, bytemuck::cast_slice(chunk));
            let mut r = Recorder::new(&self.gpu, false);
            let e = &self.eyes[eye];
            let pixels = e.width * e.height;
            self.passes
                .insert
                .insert(&mut r, &e.insert_bg, chunk.len() as u32, pixels);
            r.submit();
        }
    }

    /// The buffer holding eye `eye`'s image on the GPU (`vec4<f32>` per pixel, row by row
    /// from the top: linear radiance and coverage), for drawing it into a window.
    pub fn color_buffer(&self, eye: usize) -> &wgpu::Buffer {
        &self.eyes[eye].color
    }

    /// The image eye `eye` shows (linear radiance; holes black).
    pub fn image(&self, eye: usize) -> Image {
        let e = &self.eyes[eye];
        let n = u64::from(e.width) * u64::from(e.height);
        let bytes = self.gpu.read(&e.color, 16 * n);
        let px: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
        let mut img = Image::new(e.width, e.height);
        for (d, s) in img.pixels.iter_mut().zip(px) {
            *d = Vec3::new(s[0], s[1], s[2]);
        }
        img
    }

    /// How each pixel of eye `eye` was filled: 1 a point, 0.5 interpolated, 0 empty.
    pub fn coverage(&self, eye: usize) -> Vec<f32> {
        let e = &self.eyes[eye];
        let n = u64::from(e.width) * u64::from(e.height);
        let bytes = self.gpu.read(&e.color, 16 * n);
        let px: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
        px.iter().map(|p| p[3]).collect()
    }

    /// The priority image of eye `eye` (grey).
    pub fn priority_image(&self, eye: usize) -> Image {
        let e = &self.eyes[eye];
        let n = u64::from(e.width) * u64::from(e.height);
        let bytes = self.gpu.read(&e.priority, 4 * n);
        let px: &[f32] = bytemuck::cast_slice(&bytes);
        let mut img = Image::new(e.width, e.height);
        for (d, &s) in img.pixels.iter_mut().zip(px) {
            *d = Vec3::splat(s);
        }
        img
    }

    /// The pixels eye `eye` chose in the last frame (white on black).
    pub fn chosen_image(&self, eye: usize) -> Image {
        let e = &self.eyes[eye];
        let mut img = Image::new(e.width, e.height);
        for &p in &e.last_chosen {
            if let Some(d) = img.pixels.get_mut(p as usize) {
                *d = Vec3::ONE;
            }
        }
        img
    }

    /// All points (for tests and debugging).
    pub fn points(&self) -> Vec<GpuPoint> {
        let size = std::mem::size_of::<GpuPoint>() as u64;
        let bytes = self.gpu.read(&self.points, size * u64::from(self.capacity));
        bytemuck::cast_slice(&bytes).to_vec()
    }
}

/// Makes the dither's choice exactly `target` of the `pixels` (or all of them), so every
/// frame spends its budget, no more and no less. The dither's count is the target only
/// to within its rounding: each 8 × 8 tile starts from a random error and may hand half a
/// sample on or lose it, so it may choose a few pixels more (as many are dropped, spread
/// evenly over the list from a start that moves with `seed`) or fewer. And it takes at most one sample per pixel: where a tile's
/// priority asks for more than its pixels, the excess is lost, and a budget near one
/// sample per pixel came out about half spent. The rest goes to pixels not yet chosen,
/// spread evenly from a start that moves with `seed`.
fn exactly(chosen: &mut Vec<u32>, target: u32, pixels: u32, taken: &mut Vec<bool>, seed: u32) {
    let target = target.min(pixels) as usize;
    if chosen.len() >= target {
        let (n, drop) = (chosen.len(), chosen.len() - target);
        if drop > 0 {
            // Drop positions ⌊(j + f)·n / drop⌋, j = 0..drop, f in [0, 1) from the seed:
            // one in each n/drop of the list, none twice.
            let f = f64::from(seed.wrapping_mul(0x9E37_79B9) >> 8) / f64::from(1u32 << 24);
            let mut j = 0;
            let mut k = 0;
            chosen.retain(|_| {
                let at = ((j as f64 + f) * n as f64 / drop as f64) as usize;
                let keep = !(j < drop && k == at);
                if !keep {
                    j += 1;
                }
                k += 1;
                keep
            });
        }
        return;
    }
    // `taken` is all false on entry, and left so: only the chosen pixels are set, and
    // they are cleared again at the end.
    if taken.len() < pixels as usize {
        taken.resize(pixels as usize, false);
    }
    for &p in chosen.iter() {
        if let Some(t) = taken.get_mut(p as usize) {
            *t = true;
        }
    }
    // A stride prime to the pixel count visits every pixel once, in a scattered order.
    let stride = [7919u64, 104_729, 1_299_709]
        .into_iter()
        .find(|s| u64::from(pixels) % s != 0)
        .unwrap_or(1);
    let n = u64::from(pixels);
    let start = u64::from(seed.wrapping_mul(0x9E37_79B9)) % n;
    for k in 0..n {
        if chosen.len() >= target {
            break;
        }
        let p = ((start + k * stride) % n) as usize;
        if !taken[p] {
            taken[p] = true;
            chosen.push(p as u32);
        }
    }
    for &p in chosen.iter() {
        if let Some(t) = taken.get_mut(p as usize) {
            *t = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::exactly;
    use super::{Lookup, RenderCache, Size};
    use crate::gpu::Gpu;

    /// The light field's values split over the four buffers (here 300 floats each, a
    /// value's three floats straddling a boundary at every 100th element) read as one
    /// array: each pixel's element, looked up on the GPU, is the value the CPU holds; and
    /// more values than four buffers hold are refused, not drawn.
    #[test]
    fn values_split_over_buffers_read_as_one() {
        let gpu = Gpu::new().expect("a GPU adapter (lavapipe without a GPU)");
        let (w, h) = (20u32, 19u32);
        let mut cache = RenderCache::new(gpu, &[Size::new(w, h)], 64, 64);
        let values: Vec<[f32; 3]> = (0..380).map(|i| [i as f32, 0.5 * i as f32, 1.0]).collect();
        cache.set_vlf_split(&values, 0.0, 300).unwrap();
        let lookups: Vec<Lookup> = (0..w * h)
            .map(|i| Lookup {
                base: i,
                res: 1,
                weight: [1.0; 3],
                ..Lookup::NONE
            })
            .collect();
        cache.set_lookups(0, &lookups);
        let image = cache.vlf_image(0).unwrap();
        for (i, px) in image.pixels.iter().enumerate() {
            assert_eq!(px.to_array(), values[i], "element {i}");
        }
        let too_many = vec![[0.0; 3]; 401];
        assert!(cache.set_vlf_split(&too_many, 0.0, 300).is_err());
    }

    /// The dither's choice is kept, the rest of the target is added without repeating a
    /// pixel, a target beyond the image takes every pixel once, and a choice over the
    /// target is cut to it.
    #[test]
    fn a_choice_is_made_exactly_the_target_with_new_pixels() {
        // One scratch for every size, as the cache's eyes share it.
        let mut taken = Vec::new();
        for pixels in [7919u32 * 3, 1, 7, 12_288] {
            let mut chosen = vec![0, pixels / 2, pixels - 1];
            chosen.dedup();
            let before = chosen.clone();
            let target = pixels.min(1000) * 3 / 4 + 1;
            exactly(&mut chosen, target, pixels, &mut taken, 5);
            assert!(!taken.contains(&true), "scratch left clean");
            assert_eq!(chosen.len(), target.max(before.len() as u32) as usize);
            assert_eq!(chosen[..before.len()], before[..]);
            let mut sorted = chosen.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), chosen.len(), "{pixels}: a pixel chosen twice");
            assert!(chosen.iter().all(|&p| p < pixels));
        }
        let mut all = vec![3];
        exactly(&mut all, 100, 64, &mut Vec::new(), 9);
        assert_eq!(all.len(), 64);
        // More than enough: cut to the target, the pixels dropped spread over the list,
        // in order, with a start that moves with the seed.
        let over: Vec<u32> = (0..100).collect();
        let mut dropped_first = std::collections::BTreeSet::new();
        for seed in 0..50 {
            let mut cut = over.clone();
            exactly(&mut cut, 90, 1000, &mut Vec::new(), seed);
            assert_eq!(cut.len(), 90);
            assert!(cut.windows(2).all(|w| w[0] < w[1]), "kept in order");
            let dropped: Vec<u32> = over.iter().copied().filter(|p| !cut.contains(p)).collect();
            for (j, &d) in dropped.iter().enumerate() {
                assert_eq!(
                    d / 10,
                    j as u32,
                    "seed {seed}: one dropped in each tenth: {dropped:?}"
                );
            }
            dropped_first.insert(dropped[0]);
        }
        assert!(
            dropped_first.len() > 5,
            "the start moves with the seed: {dropped_first:?}"
        );
    }
}

/// The structs uploaded to the cache's shaders against their WGSL declarations, parsed
/// as the pipelines compile them (`common.wgsl` first).
#[cfg(test)]
mod layout_tests {
    use std::mem::{offset_of, size_of};

    use super::objects::MoveParams;
    use super::{
        EyeParams, GpuPoint, InsertParams, Lookup, NewSample, ObjectMove, ShadowLight, VlfParams,
        insert, objects, shade_field,
    };
    use crate::gpu::layout::{assert_same_layout, every_field};
    use crate::gpu::with_common;

    #[test]
    fn common_wgsl_point_and_eye_params_are_laid_out_as_in_rust() {
        let src = with_common(insert::SOURCE);
        every_field!(GpuPoint {
            pos,
            rad,
            origin,
            square
        });
        assert_same_layout(
            &src,
            "Point",
            size_of::<GpuPoint>(),
            &[
                ("pos", offset_of!(GpuPoint, pos)),
                ("rad", offset_of!(GpuPoint, rad)),
                ("origin", offset_of!(GpuPoint, origin)),
                ("square", offset_of!(GpuPoint, square)),
            ],
        );
        every_field!(EyeParams {
            view_proj,
            eye,
            width,
            height,
            npoints,
            target_samples,
            max_chosen,
            frame,
            eye_index,
            index_bits
        });
        assert_same_layout(
            &src,
            "EyeParams",
            size_of::<EyeParams>(),
            &[
                ("view_proj", offset_of!(EyeParams, view_proj)),
                ("eye", offset_of!(EyeParams, eye)),
                ("width", offset_of!(EyeParams, width)),
                ("height", offset_of!(EyeParams, height)),
                ("npoints", offset_of!(EyeParams, npoints)),
                ("target_samples", offset_of!(EyeParams, target_samples)),
                ("max_chosen", offset_of!(EyeParams, max_chosen)),
                ("frame", offset_of!(EyeParams, frame)),
                ("eye_index", offset_of!(EyeParams, eye_index)),
                ("index_bits", offset_of!(EyeParams, index_bits)),
            ],
        );
    }

    #[test]
    fn insert_wgsl_new_sample_and_insert_params_are_laid_out_as_in_rust() {
        let src = with_common(insert::SOURCE);
        every_field!(NewSample {
            pos,
            rad,
            origin,
            weight
        });
        assert_same_layout(
            &src,
            "NewSample",
            size_of::<NewSample>(),
            &[
                ("pos", offset_of!(NewSample, pos)),
                ("rad", offset_of!(NewSample, rad)),
                ("origin", offset_of!(NewSample, origin)),
                ("weight", offset_of!(NewSample, weight)),
            ],
        );
        every_field!(InsertParams {
            count,
            cursor,
            ngroups,
            group_size,
            npoints,
            index_bits,
            width,
            height
        });
        assert_same_layout(
            &src,
            "InsertParams",
            size_of::<InsertParams>(),
            &[
                ("count", offset_of!(InsertParams, count)),
                ("cursor", offset_of!(InsertParams, cursor)),
                ("ngroups", offset_of!(InsertParams, ngroups)),
                ("group_size", offset_of!(InsertParams, group_size)),
                ("npoints", offset_of!(InsertParams, npoints)),
                ("index_bits", offset_of!(InsertParams, index_bits)),
                ("width", offset_of!(InsertParams, width)),
                ("height", offset_of!(InsertParams, height)),
            ],
        );
    }

    #[test]
    fn vlf_wgsl_lookup_and_params_are_laid_out_as_in_rust() {
        let src = with_common(shade_field::SOURCE);
        // `holocave_vlf::Lookup`'s colour arrays are three scalars each in the WGSL.
        let (w, e) = (offset_of!(Lookup, weight), offset_of!(Lookup, emitted));
        assert_same_layout(
            &src,
            "Lookup",
            size_of::<Lookup>(),
            &[
                ("base", offset_of!(Lookup, base)),
                ("res", offset_of!(Lookup, res)),
                ("u", offset_of!(Lookup, u)),
                ("v", offset_of!(Lookup, v)),
                ("wr", w),
                ("wg", w + 4),
                ("wb", w + 8),
                ("er", e),
                ("eg", e + 4),
                ("eb", e + 8),
                ("tile", offset_of!(Lookup, tile)),
                ("bins", offset_of!(Lookup, bins)),
                ("x", offset_of!(Lookup, x)),
                ("y", offset_of!(Lookup, y)),
                ("samples", offset_of!(Lookup, samples)),
                ("object", offset_of!(Lookup, object)),
            ],
        );
        every_field!(VlfParams {
            width,
            height,
            index_bits,
            prior,
            chunk,
            spread,
            _pad
        });
        assert_same_layout(
            &src,
            "VlfParams",
            size_of::<VlfParams>(),
            &[
                ("width", offset_of!(VlfParams, width)),
                ("height", offset_of!(VlfParams, height)),
                ("index_bits", offset_of!(VlfParams, index_bits)),
                ("prior", offset_of!(VlfParams, prior)),
                ("chunk", offset_of!(VlfParams, chunk)),
                ("spread", offset_of!(VlfParams, spread)),
                ("pad1", offset_of!(VlfParams, _pad)),
                ("pad2", offset_of!(VlfParams, _pad) + 4),
            ],
        );
    }

    #[test]
    fn objects_wgsl_move_light_and_params_are_laid_out_as_in_rust() {
        let src = with_common(objects::SOURCE);
        every_field!(ObjectMove {
            delta,
            before,
            after,
            object,
            pad
        });
        assert_same_layout(
            &src,
            "Move",
            size_of::<ObjectMove>(),
            &[
                ("delta", offset_of!(ObjectMove, delta)),
                ("before", offset_of!(ObjectMove, before)),
                ("after", offset_of!(ObjectMove, after)),
                ("object", offset_of!(ObjectMove, object)),
                ("pad0", offset_of!(ObjectMove, pad)),
                ("pad1", offset_of!(ObjectMove, pad) + 4),
                ("pad2", offset_of!(ObjectMove, pad) + 8),
            ],
        );
        every_field!(ShadowLight { at, spread });
        assert_same_layout(
            &src,
            "ShadowLight",
            size_of::<ShadowLight>(),
            &[
                ("at", offset_of!(ShadowLight, at)),
                ("spread", offset_of!(ShadowLight, spread)),
            ],
        );
        every_field!(MoveParams {
            npoints,
            nmoves,
            nlights,
            pad
        });
        assert_same_layout(
            &src,
            "MoveParams",
            size_of::<MoveParams>(),
            &[
                ("npoints", offset_of!(MoveParams, npoints)),
                ("nmoves", offset_of!(MoveParams, nmoves)),
                ("nlights", offset_of!(MoveParams, nlights)),
                ("pad", offset_of!(MoveParams, pad)),
            ],
        );
    }
}
