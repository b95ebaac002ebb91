//! The records the cache's shaders read and write, laid out as their WGSL declarations
//! (checked by `layout_tests` in `mod.rs`): each eye's and each insertion's parameters, a
//! cached point, a sample on its way in, and the light field's parameters.

use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec4};

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct EyeParams {
    pub(super) view_proj: [[f32; 4]; 4],
    pub(super) eye: [f32; 4],
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) npoints: u32,
    pub(super) target_samples: u32,
    pub(super) max_chosen: u32,
    pub(super) frame: u32,
    pub(super) eye_index: u32,
    pub(super) index_bits: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct InsertParams {
    pub(super) count: u32,
    pub(super) cursor: u32,
    pub(super) ngroups: u32,
    pub(super) group_size: u32,
    pub(super) npoints: u32,
    pub(super) index_bits: u32,
    pub(super) width: u32,
    pub(super) height: u32,
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
    pub(super) pos: [f32; 4],
    pub(super) rad: [f32; 4],
    pub(super) origin: [f32; 4],
    /// x: how many samples this one stands for (their mean radiance); y: 1 when it is
    /// view-independent ([`NewSample::view_independent`]); zw unused.
    pub(super) weight: [f32; 4],
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

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct VlfParams {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) index_bits: u32,
    pub(super) prior: f32,
    /// Values per light-field buffer (the last may hold fewer).
    pub(super) chunk: u32,
    /// A sample's variance over `μ² + 0.01` on the display ([`crate::light_field::prior::Measured`]);
    /// 0: the prior is the same in every pixel.
    pub(super) spread: f32,
    pub(super) _pad: [u32; 2],
}
