//! How the light field treats a surface: a **diffuse** element (Lambertian, with the
//! albedo the material reflects in all), a **glossy** element (a GGX lobe with `α` below
//! the bake's threshold: its outgoing radiance over directions is kept in a directional
//! radiance tile, `tiles`), or a **delta** surface (a perfect mirror or smooth glass),
//! through which lines and eye rays continue exactly.
//!
//! Non-delta materials rougher than the threshold, rough glass, and a mix of a delta lobe
//! with a diffuse one (a half-metallic mirror) are drawn as diffuse with their whole
//! albedo: the energy they reflect is right, their view dependence is missing (the render
//! cache's exact samples add it where a viewer looks).

use glam::Vec3;
use holocave_scene::{Hit, Ray, Scene, SurfaceParams};
use holocave_tracer::bsdf::Bsdf;
use holocave_tracer::fresnel;

/// The most delta surfaces followed in a row before a line or eye ray gives up (black).
pub const MAX_DELTA_DEPTH: u32 = 8;

/// The fraction of light a non-delta surface reflects, as one Lambertian albedo: the
/// opaque dielectric's base behind its specular layer (`(1 − F0)²` through it, in and
/// out) plus the layer's own reflectance, the metal's base colour, rough glass's tint.
pub fn diffuse_albedo(p: &SurfaceParams) -> Vec3 {
    let metal = p.metallic;
    let glass = (1.0 - metal) * p.transmission;
    let dielectric = (1.0 - metal) * (1.0 - p.transmission);
    let r0 = ((p.ior - 1.0) / (p.ior + 1.0)).powi(2);
    let f0 = (Vec3::splat(r0) * p.specular_color).min(Vec3::ONE) * p.specular;
    let opaque = p.base_color * (Vec3::ONE - f0) * (Vec3::ONE - f0) + f0;
    (opaque * dielectric + p.base_color * (metal + glass)).min(Vec3::ONE)
}

/// What a ray sees at a hit: the surface's parameters and whether it is a delta.
pub struct Seen {
    pub hit: Hit,
    pub params: SurfaceParams,
    pub position: Vec3,
    pub normal: Vec3,
    pub shading_normal: Vec3,
    pub delta: bool,
    /// Emission towards the ray (zero from the back of a one-sided emitter).
    pub emitted: Vec3,
}

/// The surface at barycentrics `(u, v)` of `triangle` (an element's centre), seen from
/// no particular direction (emission counts only on a double-sided emitter's side).
pub fn seen_at(scene: &Scene, triangle: u32, u: f32, v: f32) -> Seen {
    let hit = Hit {
        triangle,
        t: 0.0,
        u,
        v,
    };
    seen(scene, hit, Vec3::ZERO)
}

/// The surface at `hit` seen along `dir`.
pub fn seen(scene: &Scene, hit: Hit, dir: Vec3) -> Seen {
    let sp = scene.surface(&hit);
    let material = &scene.materials[sp.material as usize];
    let params = material.params(&scene.textures, sp.uv);
    let towards_viewer = sp.geometric_normal.dot(dir) < 0.0;
    let emitted = if towards_viewer || material.double_sided {
        params.emission
    } else {
        Vec3::ZERO
    };
    Seen {
        hit,
        delta: Bsdf::new(&params).is_pure_delta(),
        params,
        position: sp.position,
        normal: sp.geometric_normal,
        shading_normal: sp.shading_normal,
        emitted,
    }
}

/// The side of a triangle a ray travelling along `dir` arrives on: 0 front, 1 back.
pub fn side_facing(normal: Vec3, dir: Vec3) -> u32 {
    u32::from(normal.dot(dir) > 0.0)
}

/// A direction a delta surface sends light on, with the weight it carries.
pub type Branch = (Vec3, Vec3);

/// The directions a delta surface sends a ray arriving along `dir` on, with the weight
/// each carries: the stronger branch first. Glass both reflects and refracts; the light
/// field follows the stronger branch to a diffuse surface, and the weaker one only for
/// the light it shows directly (a lamp's highlight on a glass sphere, the sky in a
/// window's reflection), so each pixel and line needs one lookup.
pub fn delta_step(s: &Seen, dir: Vec3) -> Option<(Branch, Option<Branch>)> {
    let p = &s.params;
    let n = s.shading_normal;
    let wo = -dir;
    let cos = n.dot(wo);
    let metal = p.metallic;
    let glass = (1.0 - metal) * p.transmission;
    let mirror = fresnel::reflect(wo, n).normalize();
    let metal_r = fresnel::schlick(p.base_color, Vec3::ONE, cos.abs()) * metal;
    let r = fresnel::dielectric(cos, p.ior.max(1.0001));
    let reflected = (mirror, metal_r + Vec3::splat(glass * r));
    let refracted = fresnel::refract(wo, n, p.ior.max(1.0001))
        .map(|(wi, _)| (wi.normalize(), p.base_color * glass * (1.0 - r)))
        .filter(|(_, t)| t.max_element() > 0.0);
    let reflects = reflected.1.max_element() > 0.0;
    match refracted {
        Some(t) if t.1.element_sum() > reflected.1.element_sum() => {
            Some((t, reflects.then_some(reflected)))
        }
        Some(t) if reflects => Some((reflected, Some(t))),
        Some(t) => Some((t, None)),
        None if reflects => Some((reflected, None)),
        None => None,
    }
}

/// The first non-delta surface along `ray`, through at most [`MAX_DELTA_DEPTH`] delta
/// surfaces: what it is, the ray that reached it, the weight the deltas carried and the
/// light they let through on the way (emission of delta surfaces; the sky and sun when
/// the ray escapes, given by `environment`). `None` when the chain is cut off.
pub struct Chain {
    pub end: Option<(Seen, Ray)>,
    pub weight: Vec3,
    pub emitted: Vec3,
}

pub fn follow(scene: &Scene, ray: Ray, environment: &dyn Fn(Vec3) -> Vec3) -> Chain {
    walk(scene, ray, None, environment, MAX_DELTA_DEPTH)
}

/// As [`follow`], with the ray's first hit already found (eye rays are cast in packets).
pub fn follow_from(
    scene: &Scene,
    ray: Ray,
    first: Option<Hit>,
    environment: &dyn Fn(Vec3) -> Vec3,
) -> Chain {
    walk(scene, ray, Some(first), environment, MAX_DELTA_DEPTH)
}

fn walk(
    scene: &Scene,
    mut ray: Ray,
    mut first: Option<Option<Hit>>,
    environment: &dyn Fn(Vec3) -> Vec3,
    depth: u32,
) -> Chain {
    let mut weight = Vec3::ONE;
    let mut emitted = Vec3::ZERO;
    for level in 0..=depth {
        let hit = match first.take() {
            Some(h) => h,
            None => scene.closest_hit(&ray, f32::INFINITY),
        };
        let Some(hit) = hit else {
            emitted += weight * environment(ray.dir);
            return Chain {
                end: None,
                weight,
                emitted,
            };
        };
        let s = seen(scene, hit, ray.dir);
        if !s.delta {
            return Chain {
                end: Some((s, ray)),
                weight,
                emitted,
            };
        }
        emitted += weight * s.emitted;
        let Some(((wi, w), weaker)) = delta_step(&s, ray.dir) else {
            break;
        };
        if let Some((wj, wk)) = weaker
            && level < depth
        {
            // The weaker branch: only what it shows directly, with half the depth left
            // (so a chain of glass surfaces costs a bounded number of rays).
            let side = walk(
                scene,
                Ray::leaving(s.position, s.normal, wj),
                None,
                environment,
                (depth - level - 1) / 2,
            );
            let shown = side.emitted
                + side
                    .end
                    .map_or(Vec3::ZERO, |(e, _)| side.weight * e.emitted);
            emitted += weight * wk * shown;
        }
        weight *= w;
        ray = Ray::leaving(s.position, s.normal, wi);
    }
    Chain {
        end: None,
        weight: Vec3::ZERO,
        emitted,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(base: f32, metallic: f32, roughness: f32, specular: f32) -> SurfaceParams {
        SurfaceParams {
            base_color: Vec3::splat(base),
            metallic,
            roughness,
            emission: Vec3::ZERO,
            specular,
            specular_color: Vec3::ONE,
            transmission: 0.0,
            ior: 1.5,
        }
    }

    #[test]
    fn albedo_of_lambert_is_its_base_and_never_above_one() {
        assert_eq!(
            diffuse_albedo(&params(0.6, 0.0, 1.0, 0.0)),
            Vec3::splat(0.6)
        );
        let coated = diffuse_albedo(&params(0.8, 0.0, 0.3, 1.0));
        // 0.8·0.96² + 0.04 = 0.777
        assert!((coated.x - 0.7773).abs() < 1e-3, "{coated}");
        assert!(diffuse_albedo(&params(1.0, 0.5, 0.5, 1.0)).max_element() <= 1.0);
    }
}
