//! How the cache's passes are recorded and submitted: one command encoder a frame, or in
//! timed mode a submission and a wait after each step, to time it.

use std::time::{Duration, Instant};

use crate::gpu::Gpu;

pub(super) fn groups(n: u32, size: u32) -> u32 {
    n.div_ceil(size).max(1)
}

/// Records passes, and in timed mode submits and waits after each step.
pub(super) struct Recorder<'a> {
    pub(super) gpu: &'a Gpu,
    enc: Option<wgpu::CommandEncoder>,
    timed: bool,
    t0: Instant,
}

impl<'a> Recorder<'a> {
    pub(super) fn new(gpu: &'a Gpu, timed: bool) -> Self {
        Recorder {
            gpu,
            enc: Some(gpu.device.create_command_encoder(&Default::default())),
            timed,
            t0: Instant::now(),
        }
    }

    pub(super) fn enc(&mut self) -> &mut wgpu::CommandEncoder {
        self.enc
            .get_or_insert_with(|| self.gpu.device.create_command_encoder(&Default::default()))
    }

    pub(super) fn pass(
        &mut self,
        pipe: &wgpu::ComputePipeline,
        bg: &wgpu::BindGroup,
        n: u32,
        size: u32,
    ) {
        let mut pass = self.enc().begin_compute_pass(&Default::default());
        pass.set_pipeline(pipe);
        pass.set_bind_group(0, bg, &[]);
        pass.dispatch_workgroups(groups(n, size), 1, 1);
    }

    /// Ends a step: in timed mode submits, waits and adds the elapsed time to `into`.
    pub(super) fn step(&mut self, into: &mut Duration) {
        if self.timed {
            self.submit();
            self.gpu.wait();
            *into += self.t0.elapsed();
            self.t0 = Instant::now();
        }
    }

    pub(super) fn submit(&mut self) {
        if let Some(enc) = self.enc.take() {
            self.gpu.queue.submit([enc.finish()]);
        }
    }
}
