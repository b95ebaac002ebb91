//! Moving objects in the cache (`objects.wgsl`): points on a moved object move with it and
//! are marked for resampling; points in its old or new shadow are dropped.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3, Vec4};

use crate::gpu::{Binding, ComputePass, Gpu};

use super::Recorder;

pub(super) const SOURCE: &str = include_str!("objects.wgsl");
/// `@workgroup_size` of the shader's entry point.
const WORKGROUP: u32 = 256;

/// One moving object's change since the cache last heard of it (`Move` in
/// `objects.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct ObjectMove {
    pub(super) delta: [[f32; 4]; 4],
    pub(super) before: [f32; 4],
    pub(super) after: [f32; 4],
    pub(super) object: u32,
    pub(super) pad: [u32; 3],
}

impl ObjectMove {
    /// Object `object` (its index in the scene) moved by the rigid transform `delta`
    /// from the bounding sphere `before` to `after` (xyz centre, w radius).
    pub fn new(object: usize, delta: Mat4, before: Vec4, after: Vec4) -> ObjectMove {
        ObjectMove {
            delta: delta.to_cols_array_2d(),
            before: before.to_array(),
            after: after.to_array(),
            object: object as u32 + 1,
            pad: [0; 3],
        }
    }
}

/// A light whose shadows a moved object changes (`ShadowLight` in `objects.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct ShadowLight {
    pub(super) at: [f32; 4],
    pub(super) spread: [f32; 4],
}

impl ShadowLight {
    /// A light at `position` of radius `radius` (0 for a point).
    pub fn at(position: Vec3, radius: f32) -> ShadowLight {
        ShadowLight {
            at: position.extend(1.0).to_array(),
            spread: [radius.max(0.0), 0.0, 0.0, 0.0],
        }
    }

    /// A distant light in the unit direction `towards`, of angular radius
    /// `angular_radius` (radians; 0 for a direction alone).
    pub fn distant(towards: Vec3, angular_radius: f32) -> ShadowLight {
        ShadowLight {
            at: towards.normalize_or_zero().extend(0.0).to_array(),
            spread: [angular_radius.clamp(0.0, 1.5).tan(), 0.0, 0.0, 0.0],
        }
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct MoveParams {
    pub(super) npoints: u32,
    pub(super) nmoves: u32,
    pub(super) nlights: u32,
    pub(super) pad: u32,
}

/// The pipeline that moves the points.
pub(super) struct MovePoints(ComputePass<1>);

impl MovePoints {
    pub(super) fn new(gpu: &Gpu) -> MovePoints {
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        MovePoints(ComputePass::new(
            gpu,
            "objects",
            SOURCE,
            &[Uniform, rw, ro, ro],
            ["move_points"],
        ))
    }

    /// Applies `moves` to the `npoints` points of `points`, with the shadows towards
    /// `lights`.
    pub(super) fn apply(
        &self,
        r: &mut Recorder,
        points: &wgpu::Buffer,
        npoints: u32,
        moves: &[ObjectMove],
        lights: &[ShadowLight],
    ) {
        let gpu = r.gpu;
        let params = MoveParams {
            npoints,
            nmoves: moves.len() as u32,
            nlights: lights.len() as u32,
            pad: 0,
        };
        let uniform = gpu.uniform("move params", std::mem::size_of::<MoveParams>() as u64);
        gpu.queue
            .write_buffer(&uniform, 0, bytemuck::bytes_of(&params));
        let moves = gpu.storage_init("moves", bytemuck::cast_slice(moves));
        // A binding may not be empty: one unused light when there are none.
        let none = [ShadowLight::at(Vec3::ZERO, 0.0)];
        let lights = gpu.storage_init(
            "shadow lights",
            bytemuck::cast_slice(if lights.is_empty() { &none } else { lights }),
        );
        let bg = self.0.bind_group(gpu, &[&uniform, points, &moves, &lights]);
        let [pipe] = &self.0.pipelines;
        r.pass(pipe, &bg, npoints, WORKGROUP);
    }
}
