//! Rays on the GPU: closest hit and any hit over the scene's BVH in WGSL compute
//! (`walk.wgsl` beside this file, with the batch kernels of `rays.wgsl`), one ray per
//! invocation, and a wall's pixel rays made on the GPU so that they never cross the bus.
//! From a wall's first hits kept on the GPU ([`KeptHits`]), the direct light's shadow rays
//! towards the sun's disc and the punctual lights are made there too ([`ShadowMaker`],
//! `shadow.rs`), and the light field's lookups composed ([`lookups`]). Batched passes of
//! the light field (a wall's other shadow rays, gather samples) trace through
//! [`OnGpu`], the GPU's side of `holocave_vlf::StaticRays`. Compute only: no ray-query
//! extension (Mesa 22.3's lavapipe has none) and no raster pipeline.
//!
//! # Layout: the CPU's eight-wide nodes, as they are
//!
//! The GPU walks the very tree the CPU walks: [`holocave_scene::bvh::FlatBvh`], the SBVH
//! collapsed to eight-wide nodes, uploaded word for word once per scene:
//!
//! - **a node is 256 bytes**: the eight children's boxes in full `f32` as six plane rows of
//!   eight, eight child words (inner node, leaf of one to four triangles, or empty) and, per
//!   octant of ray directions, the order the children are met in. 32 bytes per child box,
//!   as in a binary BVH (two boxes and two links in 64 bytes), but a seventh as many nodes:
//!   each visit is the eight children's box tests as two four-lane tests read with twelve
//!   16-byte loads (the CPU's SIMD test, written in `vec4`s; testing slot by slot with
//!   4-byte loads ran Sponza's primary rays three times slower on lavapipe), the same work
//!   for every invocation, so a walker without subgroup operations runs it in lock step
//!   (lavapipe compiles invocations to the lanes of the CPU's SIMD registers: a loop whose
//!   trip count varies per lane costs every lane the longest), and a seventh as many pops
//!   of the stack, where lanes do diverge;
//! - **a triangle slot is 48 bytes**: first vertex and the scene's triangle index, two
//!   edges, four slots per leaf block (the CPU's blocks, lane by lane), so the GPU runs the
//!   CPU's Möller–Trumbore with its widened edges on the same numbers;
//! - **the stack**: a walk pushes every child it enters (far to near, by the node's stored
//!   order for the ray's octant, no sort) and pops the nearest; at most seven entries per
//!   level plus eight, [`holocave_scene::bvh::FlatBvh::stack_size`] (Sponza: 92 entries; its
//!   ray sets hold at most 27), eight bytes each (child word, entry distance) for closest
//!   hit and four for any hit, in private memory. A binary tree of the same scene is three times
//!   as deep and needs a stack of its depth, smaller, but pays three times the pops.
//!
//! Why not a compressed wide BVH (Ylitie et al. 2017, 80 bytes a node with boxes quantised
//! to bytes): it is the better layout where node traffic bounds the walk (a real GPU), but
//! on the CPU its decoding cost 88% of a Sponza primary ray, and exactness is simplest to
//! test on the one tree both walks share. Quantised boxes only grow outward, so it can come
//! later behind the same interface with the same answers.
//!
//! # The round trip
//!
//! Rays made on the CPU (the direct light's shadow rays) and answers read back (the first
//! hits the lookups need) cross the bus through two host-visible buffers kept from batch to
//! batch, rays written into one where it is mapped, answers read out of the other where it
//! is mapped, both in parallel on the CPU's threads. On an H200 a round trip costs five to
//! eight times the walk itself; with a fresh staging buffer each way per batch (the
//! queue's `write_buffer`, a new read-back buffer) it cost thirty to eighty times
//! (`docs/performance/gpu-rays.md`).
//!
//! # Exactness
//!
//! The box test is the CPU's robust slab test with a larger guard: a zero direction
//! component becomes ±1e-30 before inverting (no `0 · ∞`, and `-0.0` behaves as `+0.0`:
//! obvhs' pitfall cannot happen), and the far distance grows by `1 + 16 ε` (Ize's `1 + 2γ₃`
//! assumes correctly rounded operations; Vulkan allows 2.5 ulp for a division), so no box
//! that holds a hit is missed for rounding. The triangle test is the CPU's operations in the
//! CPU's order; the shader compiler may fuse multiply-adds and the division may be off by
//! 2.5 ulp, so for the same triangle
//!
//! `|t_gpu − t_cpu| ≤ 32 ε |e1| |e2| (|s| + t) / |det|`
//!
//! (`e1`, `e2` the triangle's edges, `s` origin minus first vertex, `det` the determinant:
//! twice the CPU's own bound between two roundings of the test, as both sides err), and the
//! barycentrics part by `32 ε |e2| (|s| + |e1|) / |det|` (u) and `32 ε |e1| (|s| + |e2|) /
//! |det|` (v) — [`rounding`]. A hit or miss may only differ for a ray that meets a triangle
//! within that of its widened edge, or of `t = 0` or `tmax`; and where two triangles meet
//! the ray at one point (a shared edge, a triangle in two leaves of the SBVH) either may be
//! named. The tests count these cases and check each.

use bytemuck::{Pod, Zeroable};
use holocave_cave::WallView;
use holocave_scene::bvh::{Bvh, FLAT_EMPTY, FLAT_NODE_WORDS, FLAT_TRIANGLE_WORDS};
use holocave_scene::{Hit, Ray, Scene};
use holocave_vlf::{ShadowQuery, StaticRays};
use rayon::prelude::*;
use std::sync::{Mutex, MutexGuard};

use crate::RenderNodeError;
use crate::gpu::{Binding, ComputePass, Gpu};

pub mod lookups;
mod shadow;
pub mod surfaces;
pub use shadow::{MAX_MADE_LIGHTS, ShadowMaker};

/// `@workgroup_size` of the kernels (`WORKGROUP` in the shader).
const WORKGROUP: u32 = 64;
/// The largest stack a tree may need (a tree of 72 levels; real scenes need under 100).
pub const MAX_STACK: usize = 512;
/// The triangle word of a miss (`NO_HIT` in the shader).
const NO_HIT: u32 = u32::MAX;

/// One ray as the kernels read it: origin and `tmax`, unit direction.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuRay {
    pub origin: [f32; 3],
    pub tmax: f32,
    pub dir: [f32; 3],
    pub pad: f32,
}

impl GpuRay {
    pub fn new(ray: &Ray, tmax: f32) -> GpuRay {
        GpuRay {
            origin: ray.origin.to_array(),
            tmax,
            dir: ray.dir.to_array(),
            pad: 0.0,
        }
    }

    pub fn ray(&self) -> Ray {
        Ray::new(self.origin.into(), self.dir.into())
    }
}

/// `RayParams` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct RayParams {
    count: u32,
    row: u32,
    width: u32,
    height: u32,
    eye: [f32; 4],
    pa: [f32; 4],
    pb: [f32; 4],
    pc: [f32; 4],
    tmax: f32,
    pad: [f32; 3],
}

/// Where a node's per-pixel rays are traced (`--rays auto|gpu|cpu`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Rays {
    /// The GPU on a hardware adapter, the CPU on a software one (lavapipe runs compute on
    /// the CPU's own cores, where the CPU's walk is ten to twenty times faster: the
    /// `gpu_rays` bench).
    #[default]
    Auto,
    Gpu,
    Cpu,
}

impl Rays {
    /// Whether rays go to `gpu`'s adapter.
    pub fn on_gpu(self, gpu: &Gpu) -> bool {
        match self {
            Rays::Gpu => true,
            Rays::Cpu => false,
            Rays::Auto => gpu.raw_adapter.get_info().device_type != wgpu::DeviceType::Cpu,
        }
    }
}

impl std::str::FromStr for Rays {
    type Err = String;

    fn from_str(s: &str) -> Result<Rays, String> {
        match s {
            "auto" => Ok(Rays::Auto),
            "gpu" => Ok(Rays::Gpu),
            "cpu" => Ok(Rays::Cpu),
            _ => Err(format!("--rays takes auto, gpu or cpu, not {s:?}")),
        }
    }
}

impl std::fmt::Display for Rays {
    /// The flag's word, what [`std::str::FromStr`] reads back.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Rays::Auto => "auto",
            Rays::Gpu => "gpu",
            Rays::Cpu => "cpu",
        })
    }
}

/// Rays in one batch of [`GpuRays::occluders_in`]: 32 MiB of rays, within every
/// adapter's binding limit (128 MiB on lavapipe).
pub const MAX_BATCH: usize = 1 << 20;

/// The queries a batch of rays can be put.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Query {
    /// Four words a ray in the output buffer: `t`, triangle (`u32::MAX` on a miss), `u`, `v`.
    ClosestHit,
    /// One word a ray: a triangle found before `tmax`, or `u32::MAX`.
    AnyHit,
}

/// The scene's BVH on the GPU and room for a batch of rays and their answers.
pub struct GpuRays {
    pass: ComputePass<3>,
    params: wgpu::Buffer,
    nodes: wgpu::Buffer,
    triangles: wgpu::Buffer,
    rays: wgpu::Buffer,
    out: wgpu::Buffer,
    bind: wgpu::BindGroup,
    /// The round trip's host-visible buffers, kept from batch to batch (the module's
    /// "The round trip"): rays are written into `send` (mapped for writing) and copied to
    /// `rays` on the GPU; answers are copied from `out` into `receive` and read where it
    /// is mapped.
    send: wgpu::Buffer,
    receive: wgpu::Buffer,
    /// The rays of a batch as they are made (in parallel), before their one copy into
    /// `send`.
    scratch: Vec<GpuRay>,
    /// Rays the ray, output and transfer buffers have room for.
    capacity: u32,
    stack: usize,
    node_count: usize,
    triangle_slots: usize,
}

/// The batch kernels' WGSL for a tree whose walk needs `stack` entries.
fn source(stack: usize) -> String {
    source_with(stack, include_str!("rays.wgsl"))
}

/// The walk (`walk.wgsl`) for a tree whose walk needs `stack` entries, then `kernels`.
fn source_with(stack: usize, kernels: &str) -> String {
    format!(
        "const RAY_STACK: u32 = {}u;\n{}\n{kernels}",
        stack.max(1),
        include_str!("walk.wgsl")
    )
}

/// The round trip's host-visible buffers for `n` rays: rays out (mapped for writing),
/// answers back (mapped for reading).
fn transfer_buffers(gpu: &Gpu, n: u32) -> (wgpu::Buffer, wgpu::Buffer) {
    let out = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("gpu rays: rays out"),
        size: 32 * u64::from(n),
        usage: wgpu::BufferUsages::MAP_WRITE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    (
        out,
        gpu.read_back_buffer("gpu rays: answers back", 16 * u64::from(n)),
    )
}

/// Records `pipeline` over `bind` for `n` invocations (one a ray or pixel, on the
/// [`grid`]).
fn dispatch(
    enc: &mut wgpu::CommandEncoder,
    pipeline: &wgpu::ComputePipeline,
    bind: &wgpu::BindGroup,
    n: u32,
) {
    let (x, y, _) = grid(n);
    let mut pass = enc.begin_compute_pass(&Default::default());
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind, &[]);
    pass.dispatch_workgroups(x, y, 1);
}

/// Submits `enc` with a copy of the first `bytes` of `from` into the host-visible
/// `receive` after what it records, waits, and turns each `W` words where `receive` is
/// mapped into a `T` by `answer` (in parallel); an error where it did not map (a lost
/// device).
fn read_back<const W: usize, T: Send>(
    gpu: &Gpu,
    mut enc: wgpu::CommandEncoder,
    from: &wgpu::Buffer,
    receive: &wgpu::Buffer,
    bytes: u64,
    answer: impl Fn(&[u32; W]) -> T + Sync,
) -> Result<Vec<T>, String> {
    enc.copy_buffer_to_buffer(from, 0, receive, 0, bytes);
    gpu.queue.submit([enc.finish()]);
    let slice = receive.slice(..bytes);
    slice.map_async(wgpu::MapMode::Read, |_| {});
    gpu.wait();
    let out = match slice.get_mapped_range() {
        Ok(view) => Ok(bytemuck::cast_slice::<u8, [u32; W]>(&view)
            .par_iter()
            .map(&answer)
            .collect()),
        Err(e) => Err(e.to_string()),
    };
    receive.unmap();
    out
}

/// The dispatch grid for `n` rays: workgroups in x and y, and invocations per row.
fn grid(n: u32) -> (u32, u32, u32) {
    let groups = n.div_ceil(WORKGROUP).max(1);
    let x = groups.min(65_535);
    (x, groups.div_ceil(x), x * WORKGROUP)
}

impl GpuRays {
    /// Uploads `scene`'s BVH and triangles.
    pub fn for_scene(gpu: &Gpu, scene: &Scene) -> Result<GpuRays, RenderNodeError> {
        GpuRays::new(gpu, scene.bvh())
    }

    /// Uploads `bvh` (its tree and triangle blocks, once) and builds the kernels.
    pub fn new(gpu: &Gpu, bvh: &Bvh) -> Result<GpuRays, RenderNodeError> {
        let mut flat = bvh.flat();
        if flat.stack_size > MAX_STACK {
            return Err(RenderNodeError::Device(format!(
                "the scene's BVH needs a walk stack of {} entries; the GPU ray engine has {MAX_STACK}",
                flat.stack_size
            )));
        }
        if flat.nodes.is_empty() {
            // No triangles: one node of empty slots, which every ray misses.
            let mut empty = [0u32; FLAT_NODE_WORDS];
            empty[48..56].fill(FLAT_EMPTY);
            flat.nodes.push(empty);
        }
        if flat.triangles.is_empty() {
            flat.triangles.push([0; FLAT_TRIANGLE_WORDS]);
        }
        let limit = gpu.device.limits().max_storage_buffer_binding_size;
        let tri_bytes = (flat.triangles.len() * 4 * FLAT_TRIANGLE_WORDS) as u64;
        if tri_bytes > limit {
            return Err(RenderNodeError::Device(format!(
                "the scene's triangles take {tri_bytes} bytes; the adapter binds at most {limit}"
            )));
        }
        let nodes = gpu.storage_init("gpu rays: nodes", bytemuck::cast_slice(&flat.nodes));
        let triangles =
            gpu.storage_init("gpu rays: triangles", bytemuck::cast_slice(&flat.triangles));
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        let pass = ComputePass::new(
            gpu,
            "gpu rays",
            &source(flat.stack_size),
            &[Uniform, ro, ro, rw, rw],
            ["generate", "closest_hit", "occluded"],
        );
        let params = gpu.uniform("gpu rays: params", std::mem::size_of::<RayParams>() as u64);
        let rays = gpu.storage("gpu rays: rays", 32);
        let out = gpu.storage("gpu rays: answers", 16);
        let bind = pass.bind_group(gpu, &[&params, &nodes, &triangles, &rays, &out]);
        let (send, receive) = transfer_buffers(gpu, 1);
        Ok(GpuRays {
            pass,
            params,
            nodes,
            triangles,
            rays,
            out,
            bind,
            send,
            receive,
            scratch: Vec::new(),
            capacity: 1,
            stack: flat.stack_size,
            node_count: flat.nodes.len(),
            triangle_slots: flat.triangles.len(),
        })
    }

    /// Entries of the per-invocation stack.
    pub fn stack_size(&self) -> usize {
        self.stack
    }

    /// Bytes of the tree and of the triangles on the GPU.
    pub fn scene_bytes(&self) -> (usize, usize) {
        (
            self.node_count * 4 * FLAT_NODE_WORDS,
            self.triangle_slots * 4 * FLAT_TRIANGLE_WORDS,
        )
    }

    /// The rays of the current batch (`GpuRay` each), for kernels that make or read them.
    pub fn rays_buffer(&self) -> &wgpu::Buffer {
        &self.rays
    }

    /// The answers of the last query (see [`Query`]), for kernels that read them.
    pub fn answers_buffer(&self) -> &wgpu::Buffer {
        &self.out
    }

    /// Makes room for `n` rays (keeps the current ones only if there was room already).
    fn reserve(&mut self, gpu: &Gpu, n: u32) {
        if n <= self.capacity {
            return;
        }
        self.rays = gpu.storage("gpu rays: rays", 32 * u64::from(n));
        self.out = gpu.storage("gpu rays: answers", 16 * u64::from(n));
        (self.send, self.receive) = transfer_buffers(gpu, n);
        self.capacity = n;
        self.bind = self.pass.bind_group(
            gpu,
            &[
                &self.params,
                &self.nodes,
                &self.triangles,
                &self.rays,
                &self.out,
            ],
        );
    }

    fn set_params(&self, gpu: &Gpu, n: u32, view: Option<&WallView>, tmax: f32) {
        let (_, _, row) = grid(n);
        let v4 = |v: glam::Vec3| [v.x, v.y, v.z, 0.0];
        let mut p = RayParams {
            count: n,
            row,
            width: 1,
            height: 1,
            eye: [0.0; 4],
            pa: [0.0; 4],
            pb: [0.0; 4],
            pc: [0.0; 4],
            tmax,
            pad: [0.0; 3],
        };
        if let Some(v) = view {
            (p.width, p.height) = (v.size.width, v.size.height);
            (p.eye, p.pa, p.pb, p.pc) = (v4(v.eye), v4(v.pa), v4(v.pb), v4(v.pc));
        }
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&p));
    }

    fn dispatch(&self, enc: &mut wgpu::CommandEncoder, entry: usize, n: u32) {
        dispatch(enc, &self.pass.pipelines[entry], &self.bind, n);
    }

    fn entry(query: Query) -> usize {
        match query {
            Query::ClosestHit => 1,
            Query::AnyHit => 2,
        }
    }

    /// Copies `rays` (each with `tmax`) into the ray buffer as the current batch.
    pub fn upload(&mut self, gpu: &Gpu, rays: &[Ray], tmax: f32) {
        self.send_rays(gpu, rays.len(), |i| GpuRay::new(&rays[i], tmax));
        self.set_params(gpu, rays.len() as u32, None, tmax);
    }

    /// Makes the current batch's `n` rays with `ray` (in parallel) and copies them to the
    /// GPU through the kept `send` buffer.
    fn send_rays(&mut self, gpu: &Gpu, n: usize, ray: impl Fn(usize) -> GpuRay + Sync) {
        self.scratch.resize(n, GpuRay::zeroed());
        self.scratch
            .par_iter_mut()
            .enumerate()
            .for_each(|(i, r)| *r = ray(i));
        self.send_scratch(gpu);
    }

    /// Makes the current batch's rays from `groups`' items in order (in parallel, a few
    /// thousand groups to a task) and copies them to the GPU through the kept `send`
    /// buffer.
    fn send_groups<T: Sync>(
        &mut self,
        gpu: &Gpu,
        groups: &[Vec<T>],
        ray: &(impl Fn(&T) -> GpuRay + Sync),
    ) {
        const GROUPS_PER_TASK: usize = 4096;
        let n = groups.iter().map(Vec::len).sum();
        self.scratch.resize(n, GpuRay::zeroed());
        let tasks: Vec<&[Vec<T>]> = groups.chunks(GROUPS_PER_TASK).collect();
        let mut slots = Vec::with_capacity(tasks.len());
        let mut rest = &mut self.scratch[..];
        for task in &tasks {
            let (slot, tail) = rest.split_at_mut(task.iter().map(Vec::len).sum());
            slots.push(slot);
            rest = tail;
        }
        slots.into_par_iter().zip(tasks).for_each(|(slot, task)| {
            for (r, item) in slot.iter_mut().zip(task.iter().flatten()) {
                *r = ray(item);
            }
        });
        self.send_scratch(gpu);
    }

    /// Copies the rays in `scratch` to the GPU as the current batch.
    fn send_scratch(&mut self, gpu: &Gpu) {
        let n = self.scratch.len();
        self.reserve(gpu, n as u32);
        let bytes = 32 * n as u64;
        if bytes == 0 {
            return;
        }
        let slice = self.send.slice(..bytes);
        slice.map_async(wgpu::MapMode::Write, |_| {});
        gpu.wait();
        match slice.get_mapped_range_mut() {
            Ok(mut view) => view
                .slice(..)
                .copy_from_slice(bytemuck::cast_slice(&self.scratch)),
            // A lost device: the batch keeps whatever the buffer held, as every other
            // pass of a lost device does.
            Err(e) => tracing::warn!("gpu rays: the rays' transfer buffer did not map: {e}"),
        }
        self.send.unmap();
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(&self.send, 0, &self.rays, 0, bytes);
        gpu.queue.submit([enc.finish()]);
    }

    /// The last query's answers for its first `n` rays (`W` words each), each turned into
    /// a `T` by `answer` (in parallel) where the kept `receive` buffer is mapped.
    fn receive_answers<const W: usize, T: Send>(
        &self,
        gpu: &Gpu,
        n: u32,
        answer: impl Fn(&[u32; W]) -> T + Sync,
    ) -> Vec<T> {
        let bytes = 4 * W as u64 * u64::from(n);
        if bytes == 0 {
            return Vec::new();
        }
        let enc = gpu.device.create_command_encoder(&Default::default());
        read_back(gpu, enc, &self.out, &self.receive, bytes, answer).unwrap_or_else(|e| {
            tracing::warn!("gpu rays: the answers' transfer buffer did not map: {e}");
            Vec::new()
        })
    }

    /// Makes `view`'s pixel rays (row by row from the top-left, each with `tmax`) in the
    /// ray buffer, on the GPU, as the current batch, and puts `query` to them, all in one
    /// submission; returns the number of rays.
    pub fn trace_wall(&mut self, gpu: &Gpu, view: &WallView, tmax: f32, query: Query) -> u32 {
        let n = view.size.width * view.size.height;
        self.reserve(gpu, n);
        self.set_params(gpu, n, Some(view), tmax);
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        self.dispatch(&mut enc, 0, n);
        self.dispatch(&mut enc, Self::entry(query), n);
        gpu.queue.submit([enc.finish()]);
        n
    }

    /// Makes `view`'s pixel rays on the GPU (as [`GpuRays::trace_wall`]) without tracing
    /// them.
    pub fn generate_wall(&mut self, gpu: &Gpu, view: &WallView, tmax: f32) -> u32 {
        let n = view.size.width * view.size.height;
        self.reserve(gpu, n);
        self.set_params(gpu, n, Some(view), tmax);
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        self.dispatch(&mut enc, 0, n);
        gpu.queue.submit([enc.finish()]);
        n
    }

    /// Puts `query` to the current batch's first `n` rays (submitted, not waited for).
    pub fn trace(&self, gpu: &Gpu, n: u32, query: Query) {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        self.dispatch(&mut enc, Self::entry(query), n);
        gpu.queue.submit([enc.finish()]);
    }

    /// The current batch's first `n` rays, read back.
    pub fn read_rays(&self, gpu: &Gpu, n: u32) -> Vec<GpuRay> {
        bytemuck::cast_slice(&gpu.read(&self.rays, 32 * u64::from(n.max(1))))[..n as usize].to_vec()
    }

    /// The closest hits of the last [`Query::ClosestHit`] over `n` rays, read back.
    pub fn read_hits(&self, gpu: &Gpu, n: u32) -> Vec<Option<Hit>> {
        self.receive_answers(gpu, n, |w: &[u32; 4]| {
            (w[1] != NO_HIT).then(|| Hit {
                triangle: w[1],
                t: f32::from_bits(w[0]),
                u: f32::from_bits(w[2]),
                v: f32::from_bits(w[3]),
            })
        })
    }

    /// The occluders found by the last [`Query::AnyHit`] over `n` rays, read back.
    pub fn read_occluders(&self, gpu: &Gpu, n: u32) -> Vec<Option<u32>> {
        self.receive_answers(gpu, n, |&[w]: &[u32; 1]| (w != NO_HIT).then_some(w))
    }

    /// The closest hit of each ray before `tmax` (as [`Bvh::closest_hit`]), in batches of
    /// [`MAX_BATCH`].
    pub fn closest_hits(&mut self, gpu: &Gpu, rays: &[Ray], tmax: f32) -> Vec<Option<Hit>> {
        let mut out = Vec::with_capacity(rays.len());
        for batch in rays.chunks(MAX_BATCH) {
            self.upload(gpu, batch, tmax);
            let n = batch.len() as u32;
            self.trace(gpu, n, Query::ClosestHit);
            out.extend(self.read_hits(gpu, n));
        }
        out
    }

    /// For each ray, a triangle that lies on it before `tmax`, if any (the ray is occluded,
    /// as [`Bvh::occluded`], when there is one).
    pub fn occluders(&mut self, gpu: &Gpu, rays: &[Ray], tmax: f32) -> Vec<Option<u32>> {
        self.upload(gpu, rays, tmax);
        let n = rays.len() as u32;
        self.trace(gpu, n, Query::AnyHit);
        self.read_occluders(gpu, n)
    }

    /// For the ray of each item of `groups` in order (`ray(item)`, each to its own
    /// `tmax`: shadow rays towards lamps end at them), a triangle that lies on it, if any;
    /// in batches of whole groups that the buffers hold (a group larger than a batch is a
    /// batch of its own).
    pub fn occluders_in<T: Sync>(
        &mut self,
        gpu: &Gpu,
        groups: &[Vec<T>],
        ray: impl Fn(&T) -> GpuRay + Sync,
    ) -> Vec<Option<u32>> {
        let mut out = Vec::with_capacity(groups.iter().map(Vec::len).sum());
        let mut rest = groups;
        while !rest.is_empty() {
            let (mut take, mut rays) = (0, 0);
            while take < rest.len() && (take == 0 || rays + rest[take].len() <= MAX_BATCH) {
                rays += rest[take].len();
                take += 1;
            }
            let batch;
            (batch, rest) = rest.split_at(take);
            self.send_groups(gpu, batch, &ray);
            self.set_params(gpu, rays as u32, None, f32::INFINITY);
            self.trace(gpu, rays as u32, Query::AnyHit);
            out.extend(self.read_occluders(gpu, rays as u32));
        }
        out
    }

    /// Whether something lies on each ray before `tmax` (as [`Bvh::occluded`]).
    pub fn occluded(&mut self, gpu: &Gpu, rays: &[Ray], tmax: f32) -> Vec<bool> {
        self.occluders(gpu, rays, tmax)
            .into_iter()
            .map(|o| o.is_some())
            .collect()
    }
}

/// A wall's first hits kept on the GPU (four words a pixel, as the closest-hit pass
/// answers) with the pixels' rays, for the shadow rays made from them and the lookups
/// composed from them.
pub struct KeptHits {
    buffer: wgpu::Buffer,
    rays: wgpu::Buffer,
    pixels: u32,
}

impl GpuRays {
    /// Keeps the first `n` answers of the last closest-hit query (a wall's first hits) and
    /// their rays in `kept`, on the GPU, for [`ShadowMaker::trace`] and
    /// [`lookups::LookupComposer::compose`]; call it before the engine's next query.
    pub fn keep_hits(&self, gpu: &Gpu, n: u32, kept: &mut Option<KeptHits>) {
        let bytes = 16 * u64::from(n);
        let ray_bytes = std::mem::size_of::<GpuRay>() as u64 * u64::from(n);
        if kept.as_ref().is_none_or(|k| k.buffer.size() < bytes) {
            *kept = Some(KeptHits {
                buffer: gpu.storage("gpu rays: a wall's first hits", bytes),
                rays: gpu.storage("gpu rays: a wall's pixel rays", ray_bytes),
                pixels: 0,
            });
        }
        let Some(k) = kept.as_mut() else { return };
        k.pixels = n;
        if bytes > 0 {
            let mut enc = gpu.device.create_command_encoder(&Default::default());
            enc.copy_buffer_to_buffer(&self.out, 0, &k.buffer, 0, bytes);
            enc.copy_buffer_to_buffer(&self.rays, 0, &k.rays, 0, ray_bytes);
            gpu.queue.submit([enc.finish()]);
        }
    }
}

/// The GPU's walk as the light field's batched passes take it (a wall's shadow rays,
/// gather samples): one engine, shared by the node's threads.
pub struct OnGpu<'a> {
    pub gpu: &'a Gpu,
    pub engine: &'a Mutex<GpuRays>,
}

impl OnGpu<'_> {
    fn engine(&self) -> MutexGuard<'_, GpuRays> {
        self.engine.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl StaticRays for OnGpu<'_> {
    fn closest_hits(&self, rays: &[Ray]) -> Vec<Option<Hit>> {
        self.engine().closest_hits(self.gpu, rays, f32::INFINITY)
    }

    fn blocked(&self, groups: &[Vec<ShadowQuery>]) -> Vec<bool> {
        let occluders =
            (self.engine()).occluders_in(self.gpu, groups, |q| GpuRay::new(&q.ray, q.tmax));
        occluders.iter().map(Option::is_some).collect()
    }
}

/// The adapter under `gpu`: name, backend and driver, type, every feature it offers and
/// its limits (what a GPU figure is read beside).
pub fn adapter_report(gpu: &Gpu) -> String {
    let info = gpu.raw_adapter.get_info();
    format!(
        "adapter: {} ({:?}, {:?}, driver {} {}, vendor {:#06x}, device {:#06x})\n\
         features: {:?}\nlimits: {:#?}\ndevice limits requested: max storage buffer binding {} B, \
         max compute workgroups per dimension {}",
        info.name,
        info.device_type,
        info.backend,
        info.driver,
        info.driver_info,
        info.vendor,
        info.device,
        gpu.raw_adapter.features(),
        gpu.raw_adapter.limits(),
        gpu.device.limits().max_storage_buffer_binding_size,
        gpu.device.limits().max_compute_workgroups_per_dimension,
    )
}

/// How far two roundings of Möller–Trumbore, one of them on the GPU, may part for a ray
/// (unit direction) meeting `tri` at `t`: in `t`, `u` and `v` (see the module's
/// "Exactness"). To first order each product and sum errs by a few ε of its terms'
/// magnitudes: `s · p` (`p = d × e2`, `|p| ≤ |e2|`) by ε |s| |e2|, `d · q` (`q = s × e1`)
/// by ε |s| |e1|, `e2 · q` by ε |e2| |s| |e1|, and the determinant by ε |e1| |e2|, which a
/// quotient carries as that relative error times itself; dividing by `|det|` amplifies all
/// of it. 16 ε covers the handful of roundings of one side (fused or not, the division's
/// 2.5 ulp included), 32 ε both sides.
pub fn rounding(tri: &[glam::Vec3; 3], ray: &Ray, t: f32) -> (f32, f32, f32) {
    let (e1, e2, s) = (tri[1] - tri[0], tri[2] - tri[0], ray.origin - tri[0]);
    let det = e1.dot(ray.dir.cross(e2)).abs();
    let (e1, e2, s) = (e1.length(), e2.length(), s.length());
    let scale = 32.0 * f32::EPSILON / det;
    (
        scale * e1 * e2 * (s + t.abs()),
        scale * e2 * (s + e1),
        scale * e1 * (s + e2),
    )
}

#[cfg(test)]
mod tests {
    use std::mem::{offset_of, size_of};

    use super::*;
    use crate::gpu::layout::{assert_same_layout, every_field};
    use crate::gpu::with_common;

    #[test]
    fn the_rays_flag_reads_back_what_it_writes() {
        for r in [Rays::Auto, Rays::Gpu, Rays::Cpu] {
            assert_eq!(r.to_string().parse::<Rays>(), Ok(r));
        }
        assert!("GPU".parse::<Rays>().unwrap_err().contains("\"GPU\""));
    }

    #[test]
    fn the_wgsl_structs_are_laid_out_as_in_rust() {
        let src = with_common(&source(8));
        every_field!(GpuRay {
            origin,
            tmax,
            dir,
            pad
        });
        assert_same_layout(
            &src,
            "GpuRay",
            size_of::<GpuRay>(),
            &[
                ("origin", offset_of!(GpuRay, origin)),
                ("tmax", offset_of!(GpuRay, tmax)),
                ("dir", offset_of!(GpuRay, dir)),
                ("pad", offset_of!(GpuRay, pad)),
            ],
        );
        let pad = offset_of!(RayParams, pad);
        every_field!(RayParams {
            count,
            row,
            width,
            height,
            eye,
            pa,
            pb,
            pc,
            tmax,
            pad
        });
        assert_same_layout(
            &src,
            "RayParams",
            size_of::<RayParams>(),
            &[
                ("count", offset_of!(RayParams, count)),
                ("row", offset_of!(RayParams, row)),
                ("width", offset_of!(RayParams, width)),
                ("height", offset_of!(RayParams, height)),
                ("eye", offset_of!(RayParams, eye)),
                ("pa", offset_of!(RayParams, pa)),
                ("pb", offset_of!(RayParams, pb)),
                ("pc", offset_of!(RayParams, pc)),
                ("tmax", offset_of!(RayParams, tmax)),
                ("pad0", pad),
                ("pad1", pad + 4),
                ("pad2", pad + 8),
            ],
        );
        // The scene's words (holocave_scene::bvh::FlatBvh): a node's planes, children and
        // orders at words 0, 48 and 56; a triangle slot's three vec4s.
        assert_same_layout(
            &src,
            "RayNode",
            4 * FLAT_NODE_WORDS,
            &[("planes", 0), ("children", 4 * 48), ("order", 4 * 56)],
        );
        assert_same_layout(
            &src,
            "RayTriangle",
            4 * FLAT_TRIANGLE_WORDS,
            &[("v0_id", 0), ("e1", 16), ("e2", 32)],
        );
    }
}
