//! Drawing the light field from a viewpoint (§4 of the paper): for each pixel, what the
//! eye sees — found by a ray cast through the pixel, continued exactly through mirrors
//! and smooth glass (the paper's recursive rendering of specular faces) — and the baked
//! irradiance there, interpolated between element centres. No shadow rays and no
//! sampling: the cost per pixel does not depend on the lighting.
//!
//! Visibility gives each pixel a [`Lookup`]; the radiance is then
//! `emitted + weight · E(base, res, u, v)` with `E` the baked irradiance interpolated by
//! [`crate::elements::interpolate`]. The render node does the second step on the GPU
//! (`render-node/src/shaders/vlf.wgsl`), [`shade`] on the CPU.

use std::sync::Arc;

use glam::{Vec2, Vec3};
use holocave_scene::bvh::PACKET;
use holocave_scene::{Ray, Scene};
use holocave_tracer::film::Image;
use holocave_tracer::lights::Lights;
use holocave_tracer::view::WallView;
use rayon::prelude::*;

use crate::bake::environment;
use crate::elements::{Elements, interpolate};
use crate::surface::{Chain, diffuse_albedo, follow, follow_from, side_facing};

/// What one pixel (or one ray) sees of the light field.
/// Laid out as the render node's shader reads it (`Lookup` in
/// `render-node/src/shaders/vlf.wgsl`): uploaded as it is.
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct Lookup {
    /// First element of the side seen; `u32::MAX` when no diffuse surface is seen.
    pub base: u32,
    /// That triangle's resolution.
    pub res: u32,
    /// Barycentric coordinates of the point seen.
    pub u: f32,
    pub v: f32,
    /// `ρ/π` of the point times what delta surfaces on the way let through.
    pub weight: [f32; 3],
    /// Light reaching the eye along the way: emitters, the sky, the sun.
    pub emitted: [f32; 3],
}

impl Lookup {
    pub const NONE: Lookup = Lookup {
        base: u32::MAX,
        res: 1,
        u: 0.0,
        v: 0.0,
        weight: [0.0; 3],
        emitted: [0.0; 3],
    };
}

/// The scene's side of drawing: the element layout and the light the eye sees directly.
pub struct Visibility {
    scene: Arc<Scene>,
    elements: Elements,
    lights: Lights,
}

impl Visibility {
    pub fn new(scene: Arc<Scene>, elements: Elements) -> Self {
        let lights = Lights::new(&scene);
        Visibility {
            scene,
            elements,
            lights,
        }
    }

    /// What `ray` sees.
    pub fn lookup(&self, ray: Ray) -> Lookup {
        let env = environment(&self.lights);
        self.lookup_chain(follow(&self.scene, ray, &env))
    }

    fn lookup_chain(&self, chain: Chain) -> Lookup {
        let Some((s, r)) = chain.end else {
            return Lookup {
                emitted: chain.emitted.to_array(),
                ..Lookup::NONE
            };
        };
        let cells = self.elements.triangles[s.hit.triangle as usize];
        let side = side_facing(s.normal, r.dir);
        Lookup {
            base: cells.base(side),
            res: cells.res,
            u: s.hit.u,
            v: s.hit.v,
            weight: (chain.weight * diffuse_albedo(&s.params) * std::f32::consts::FRAC_1_PI)
                .to_array(),
            emitted: (chain.emitted + chain.weight * s.emitted).to_array(),
        }
    }

    /// One lookup per pixel of `view`, through the pixel's centre, rows from the top. The
    /// first hits are found in packets of neighbouring pixels (coherent rays).
    pub fn pixels(&self, view: &WallView) -> Vec<Lookup> {
        let w = view.width as usize;
        let n = w * view.height as usize;
        let env = environment(&self.lights);
        let chunk = 8 * PACKET;
        let mut out = vec![Lookup::NONE; n];
        out.par_chunks_mut(chunk).enumerate().for_each(|(c, out)| {
            let rays: Vec<Ray> = (c * chunk..(c * chunk + out.len()))
                .map(|i| view.ray(Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5)))
                .collect();
            let hits = self.scene.closest_hits(&rays, f32::INFINITY);
            for ((o, ray), hit) in out.iter_mut().zip(rays).zip(hits) {
                *o = self.lookup_chain(follow_from(&self.scene, ray, hit, &env));
            }
        });
        out
    }

    /// `view` drawn from the light field with `k × k` lookups per pixel (an antialiased
    /// image for comparison with a path-traced one; the render node uses one).
    pub fn render(&self, view: &WallView, irradiance: &[[f32; 3]], k: u32) -> Image {
        let k = k.max(1);
        let mut image = Image::new(view.width, view.height);
        let w = view.width as usize;
        image.pixels.par_iter_mut().enumerate().for_each(|(i, px)| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            let mut sum = Vec3::ZERO;
            for s in 0..k * k {
                let o = Vec2::new(
                    ((s % k) as f32 + 0.5) / k as f32,
                    ((s / k) as f32 + 0.5) / k as f32,
                );
                sum += shade_one(&self.lookup(view.ray(Vec2::new(x, y) + o)), irradiance);
            }
            *px = sum / (k * k) as f32;
        });
        image
    }
}

/// The radiance of one lookup.
pub fn shade_one(l: &Lookup, irradiance: &[[f32; 3]]) -> Vec3 {
    let mut c = Vec3::from(l.emitted);
    if l.base != u32::MAX {
        c += Vec3::from(l.weight) * interpolate(irradiance, l.base, l.res, l.u, l.v);
    }
    c
}

/// The radiance of every lookup (the CPU twin of the render node's shader).
pub fn shade(lookups: &[Lookup], irradiance: &[[f32; 3]]) -> Vec<Vec3> {
    lookups.iter().map(|l| shade_one(l, irradiance)).collect()
}
