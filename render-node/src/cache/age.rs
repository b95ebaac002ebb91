//! Aging (`age.wgsl`): every point grows older each frame, faster when no eye saw it.

use crate::gpu::{Binding, ComputePass, Gpu};

use super::recorder::Recorder;

/// `@workgroup_size` of the shader's entry point.
const WORKGROUP: u32 = 256;

/// The age pipeline.
pub(super) struct Age(ComputePass<1>);

impl Age {
    pub(super) fn new(gpu: &Gpu) -> Age {
        use Binding::{Storage, Uniform};
        let rw = Storage { read_only: false };
        let source = include_str!("age.wgsl");
        Age(ComputePass::new(
            gpu,
            "age",
            source,
            &[Uniform, rw, rw],
            ["age"],
        ))
    }

    /// A bind group of `[params, points, visible]`, in binding order.
    pub(super) fn bind_group(&self, gpu: &Gpu, buffers: [&wgpu::Buffer; 3]) -> wgpu::BindGroup {
        self.0.bind_group(gpu, &buffers)
    }

    /// Ages `points` points.
    pub(super) fn age(&self, r: &mut Recorder, bg: &wgpu::BindGroup, points: u32) {
        let [age] = &self.0.pipelines;
        r.pass(age, bg, points, WORKGROUP);
    }
}
