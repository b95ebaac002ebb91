//! Inserting samples (`insert.wgsl`): match each sample with the point at its pixel
//! (same eye: running mean; an eye nearby, same surface and place: capped mean), then
//! place the unmatched ones over the oldest point of a round-robin group.

use crate::gpu::{Binding, Gpu};

use super::Recorder;

/// `@workgroup_size` of the shader's entry points.
const WORKGROUP: u32 = 64;

/// The buffers insertion binds, in binding order.
pub(super) struct InsertBuffers<'a> {
    pub params: &'a wgpu::Buffer,
    pub points: &'a wgpu::Buffer,
    pub samples: &'a wgpu::Buffer,
    pub key: &'a wgpu::Buffer,
    pub matched: &'a wgpu::Buffer,
}

/// The match and place pipelines and their bind group layout.
pub(super) struct Insert {
    layout: wgpu::BindGroupLayout,
    matching: wgpu::ComputePipeline,
    place: wgpu::ComputePipeline,
}

impl Insert {
    pub(super) fn new(gpu: &Gpu) -> Insert {
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        let layout = gpu.layout("insert", &[Uniform, rw, ro, ro, rw]);
        let [matching, place] = gpu
            .pipelines(
                "insert",
                include_str!("insert.wgsl"),
                &layout,
                &["match_samples", "place_samples"],
            )
            .try_into()
            .unwrap_or_else(|_| unreachable!("two entry points, two pipelines"));
        Insert {
            layout,
            matching,
            place,
        }
    }

    pub(super) fn bind_group(&self, gpu: &Gpu, b: &InsertBuffers) -> wgpu::BindGroup {
        gpu.bind_group(
            "insert",
            &self.layout,
            &[b.params, b.points, b.samples, b.key, b.matched],
        )
    }

    /// Inserts the first `count` samples of the samples buffer.
    pub(super) fn insert(&self, r: &mut Recorder, bg: &wgpu::BindGroup, count: u32) {
        r.pass(&self.matching, bg, count, WORKGROUP);
        r.pass(&self.place, bg, count, WORKGROUP);
    }
}
