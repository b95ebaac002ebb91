//! Aging (`age.wgsl`): every point grows older each frame, faster when no eye saw it.

use crate::gpu::{Binding, Gpu};

use super::Recorder;

/// `@workgroup_size` of the shader's entry point.
const WORKGROUP: u32 = 256;

/// The buffers aging binds, in binding order.
pub(super) struct AgeBuffers<'a> {
    pub params: &'a wgpu::Buffer,
    pub points: &'a wgpu::Buffer,
    pub visible: &'a wgpu::Buffer,
}

/// The age pipeline and its bind group layout.
pub(super) struct Age {
    layout: wgpu::BindGroupLayout,
    age: wgpu::ComputePipeline,
}

impl Age {
    pub(super) fn new(gpu: &Gpu) -> Age {
        use Binding::{Storage, Uniform};
        let rw = Storage { read_only: false };
        let layout = gpu.layout("age", &[Uniform, rw, rw]);
        let [age] = gpu
            .pipelines("age", include_str!("age.wgsl"), &layout, &["age"])
            .try_into()
            .unwrap_or_else(|_| unreachable!("one entry point, one pipeline"));
        Age { layout, age }
    }

    pub(super) fn bind_group(&self, gpu: &Gpu, b: &AgeBuffers) -> wgpu::BindGroup {
        gpu.bind_group("age", &self.layout, &[b.params, b.points, b.visible])
    }

    /// Ages `points` points.
    pub(super) fn age(&self, r: &mut Recorder, bg: &wgpu::BindGroup, points: u32) {
        r.pass(&self.age, bg, points, WORKGROUP);
    }
}
