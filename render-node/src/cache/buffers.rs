//! The buffers and bind groups the cache's passes use: one set per eye (its image, keys,
//! priority and chosen pixels), the passes themselves (one per shader file), and the light
//! field's values and each eye's lookups.

use holocave_cave::Size;

use super::age::Age;
use super::dither::Dither;
use super::filter::Filter;
use super::insert::Insert;
use super::objects::MovePoints;
use super::project::Project;
use super::records::EyeParams;
use super::shade_field::VlfPass;
use crate::gpu::Gpu;

pub(super) struct EyeBuffers {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) params: wgpu::Buffer,
    pub(super) key: wgpu::Buffer,
    pub(super) color: wgpu::Buffer,
    pub(super) priority: wgpu::Buffer,
    /// The pixels chosen in the last frame.
    pub(super) last_chosen: Vec<u32>,
    pub(super) counters: wgpu::Buffer,
    pub(super) chosen: wgpu::Buffer,
    pub(super) staging: wgpu::Buffer,
    pub(super) project_bg: wgpu::BindGroup,
    pub(super) filter_bg: wgpu::BindGroup,
    pub(super) dither_bg: wgpu::BindGroup,
    pub(super) insert_bg: wgpu::BindGroup,
}

/// The passes, one per shader file.
pub(super) struct Passes {
    pub(super) project: Project,
    pub(super) filter: Filter,
    pub(super) dither: Dither,
    pub(super) insert: Insert,
    pub(super) age: Age,
    pub(super) vlf: VlfPass,
    pub(super) objects: MovePoints,
}

/// The buffers every eye's bind groups share: the points, what the age pass reads of them,
/// the new samples and where they matched, the insert pass's parameters.
#[derive(Clone, Copy)]
pub(super) struct SharedBuffers<'a> {
    pub(super) points: &'a wgpu::Buffer,
    pub(super) visible: &'a wgpu::Buffer,
    pub(super) samples: &'a wgpu::Buffer,
    pub(super) matched: &'a wgpu::Buffer,
    pub(super) insert_params: &'a wgpu::Buffer,
}

impl Passes {
    pub(super) fn new(gpu: &Gpu) -> Passes {
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
    pub(super) fn new(
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

/// The light field's values are bound as this many storage buffers, each within the
/// adapter's binding limit (128 MiB on lavapipe, where the breakfast room's default bake,
/// 375 MB, needs three).
pub(super) const VLF_BUFFERS: usize = 4;

/// The Virtual Light Field on the GPU: the baked irradiance, and per eye its lookups.
pub(super) struct VlfBuffers {
    /// The values, `chunk` floats a buffer; `floats` in all.
    pub(super) irradiance: Vec<wgpu::Buffer>,
    pub(super) chunk: usize,
    pub(super) floats: usize,
    pub(super) eyes: Vec<(wgpu::Buffer, wgpu::Buffer, wgpu::BindGroup)>,
}
