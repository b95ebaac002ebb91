//! Moving objects in the cache (`objects.wgsl`): points on a moved object move with it and
//! are marked for resampling; points in its old or new shadow are dropped. On the CPU, the
//! same shadows tell the per-pixel pass which running means a move changed
//! ([`ObjectMove::shadows`], [`ObjectMove::takes_more_than`]).

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3, Vec4};

use crate::gpu::{Binding, ComputePass, Gpu};

use super::MAX_OBJECTS;
use super::recorder::Recorder;

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

/// A moved object whose bounding sphere takes less than this share of a point's
/// cosine-weighted hemisphere, before and after the move, changes what the point's
/// estimates of the sky bring by less than that share: the share below which the light
/// field trusts its static samples beside an object (`vlf::objects`), and half the 2 % a
/// settled pixel's running mean may be off (`vlf::Settling::WALLS`).
pub const SKY_SHARE: f32 = 0.01;

impl ShadowLight {
    /// Whether the way from `p` to this light passes through the sphere `s` (xyz centre,
    /// w radius), widened by the light's size as the penumbra widens towards it:
    /// `shadowed` in `objects.wgsl`, on the CPU.
    pub fn shadowed_by(&self, p: Vec3, s: Vec4) -> bool {
        let (c, r) = (s.truncate() - p, s.w);
        if c.length_squared() <= r * r {
            return true;
        }
        let at = Vec4::from(self.at);
        let spread = self.spread[0];
        if at.w == 0.0 {
            let towards = at.truncate();
            let t = c.dot(towards);
            return t > 0.0 && (c - t * towards).length() <= r + t * spread;
        }
        let to = at.truncate() - p;
        let d = to.length();
        if d <= 0.0 {
            return false;
        }
        let u = to / d;
        let t = c.dot(u).clamp(0.0, d);
        (c - t * u).length() <= r + spread * t / d
    }
}

impl ObjectMove {
    /// The moved object's index in the scene.
    pub fn object(&self) -> usize {
        self.object as usize - 1
    }

    /// Its bounding sphere before and after the move (xyz centre, w radius).
    fn spheres(&self) -> [Vec4; 2] {
        [self.before, self.after].map(Vec4::from)
    }

    /// Whether a point `p` lies in the object's shadow towards one of `lights`, where it
    /// was or where it is now.
    pub fn shadows(&self, p: Vec3, lights: &[ShadowLight]) -> bool {
        (self.spheres().iter()).any(|&s| lights.iter().any(|l| l.shadowed_by(p, s)))
    }

    /// Whether the object's bounding sphere took or takes more than `share` of the
    /// cosine-weighted hemisphere of a point `p` (unit normal `normal`; `None` where any
    /// side counts): an upper bound of what the object itself takes.
    pub fn takes_more_than(&self, share: f32, p: Vec3, normal: Option<Vec3>) -> bool {
        self.spheres().iter().any(|&s| {
            let c = s.truncate() - p;
            let d = c.length().max(s.w);
            let cos = normal.map_or(1.0, |n| (n.dot(c) / d).abs().min(1.0));
            cos * (s.w / d).powi(2) > share
        })
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

/// The pipeline that moves the points, with its parameters, the moves (room for
/// [`MAX_OBJECTS`]) and the lights, kept from move to move.
pub(super) struct MovePoints {
    pass: ComputePass<1>,
    params: wgpu::Buffer,
    moves: wgpu::Buffer,
    /// The lights' buffer and the lights it holds.
    lights: Option<(wgpu::Buffer, Vec<ShadowLight>)>,
}

impl MovePoints {
    pub(super) fn new(gpu: &Gpu) -> MovePoints {
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        let size = |n: usize| (n * std::mem::size_of::<ObjectMove>()) as u64;
        MovePoints {
            pass: ComputePass::new(
                gpu,
                "objects",
                SOURCE,
                &[Uniform, rw, ro, ro],
                ["move_points"],
            ),
            params: gpu.uniform("move params", std::mem::size_of::<MoveParams>() as u64),
            moves: gpu.storage("moves", size(MAX_OBJECTS)),
            lights: None,
        }
    }

    /// Applies `moves` to the `npoints` points of `points`, with the shadows towards
    /// `lights`.
    pub(super) fn apply(
        &mut self,
        r: &mut Recorder,
        points: &wgpu::Buffer,
        npoints: u32,
        moves: &[ObjectMove],
        lights: &[ShadowLight],
    ) {
        let gpu = r.gpu;
        let moves = &moves[..moves.len().min(MAX_OBJECTS)];
        let params = MoveParams {
            npoints,
            nmoves: moves.len() as u32,
            nlights: lights.len() as u32,
            pad: 0,
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        gpu.queue
            .write_buffer(&self.moves, 0, bytemuck::cast_slice(moves));
        if self.lights.as_ref().is_none_or(|(_, held)| held != lights) {
            // A binding may not be empty: one unused light when there are none.
            let none = [ShadowLight::at(Vec3::ZERO, 0.0)];
            let contents = if lights.is_empty() { &none[..] } else { lights };
            let buffer = gpu.storage_init("shadow lights", bytemuck::cast_slice(contents));
            self.lights = Some((buffer, lights.to_vec()));
        }
        let Some((lights, _)) = &self.lights else {
            return;
        };
        let bg = (self.pass).bind_group(gpu, &[&self.params, points, &self.moves, lights]);
        let [pipe] = &self.pass.pipelines;
        r.pass(pipe, &bg, npoints, WORKGROUP);
    }
}
