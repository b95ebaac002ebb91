//! Next-event estimation through flat mirrors.
//!
//! A perfect mirror is a delta: ordinary light sampling cannot aim through it, so the light
//! it reflects onto diffuse surfaces (the bright patch a mirror throws on a ceiling, the
//! light seen again in the mirror from a wall) is found only when BSDF sampling happens to
//! hit the mirror and then the light — a caustic, and in the Cornell box with its mirror
//! box the largest share of the noise (`examples/path_profile.rs`: the third and fourth
//! path vertices carry 70% of the variance and 9% of the light).
//!
//! A flat mirror images a light exactly: the light point `y` mirrored in the mirror's plane
//! is `y'`, and the path `x → m → y` over the mirror point `m` is the straight line
//! `x → y'`, of length `|x − m| + |m − y|`. So a path through one mirror triangle can be
//! sampled like a direct one: pick a mirror triangle (by area) and a point on a light (as
//! for direct light), aim at the image, keep it if the line crosses that triangle, and check
//! both segments for blockers. Its solid-angle density at `x` is the light's area density
//! times `P(mirror)`, over `cos θ_y / (|x − m| + |m − y|)²`. Paths of this shape that BSDF
//! sampling finds are weighted against it by the power heuristic ([`Lights::mirror_pdf`]),
//! so the sum stays unbiased; paths through two mirrors are left to BSDF sampling.

use glam::{Vec2, Vec3};
use holocave_scene::{Hit, Scene};

use crate::bsdf::Bsdf;
use crate::frame::Frame;
use crate::integrator::segment_clear;
use crate::lights::{LightSample, Lights};
use crate::sampling::{Distribution, is_positive_finite};

/// The scene's flat, opaque, perfect mirror triangles, chosen by area.
pub struct Mirrors {
    triangles: Vec<Mirror>,
    choose: Distribution,
    /// For each scene triangle, its index in `triangles` (`u32::MAX` if not a mirror).
    index_of: Vec<u32>,
}

struct Mirror {
    vertices: [Vec3; 3],
    normal: Vec3,
    /// The mirror's scattering (the same everywhere: mirrors with textures are left out).
    bsdf: Bsdf,
}

impl Mirrors {
    /// `None` when the scene has no mirror such sampling could use.
    pub fn new(scene: &Scene) -> Option<Self> {
        let mut triangles = Vec::new();
        let mut areas = Vec::new();
        let mut index_of = vec![u32::MAX; scene.triangle_count()];
        for t in 0..scene.triangle_count() as u32 {
            let m = &scene.materials[scene.triangle_shading(t).material as usize];
            let textured = m.base_color_texture.is_some()
                || m.metallic_roughness_texture.is_some()
                || m.emissive_texture.is_some();
            let vertices = *scene.triangle(t);
            let sp = scene.surface(&Hit {
                triangle: t,
                t: 0.0,
                u: 1.0 / 3.0,
                v: 1.0 / 3.0,
            });
            let params = m.params(&scene.textures, sp.uv);
            let bsdf = Bsdf::new(&params);
            if textured || !sp.flat || !bsdf.is_pure_delta() || bsdf.transmits() {
                continue;
            }
            if params.emission.max_element() > 0.0 {
                continue;
            }
            index_of[t as usize] = triangles.len() as u32;
            areas.push(scene.triangle_area(t));
            triangles.push(Mirror {
                vertices,
                normal: sp.geometric_normal,
                bsdf,
            });
        }
        let choose = Distribution::new(&areas)?;
        Some(Self {
            triangles,
            choose,
            index_of,
        })
    }

    /// The mirror index of scene triangle `triangle`, if it is one of these mirrors.
    pub fn index_of(&self, triangle: u32) -> Option<u32> {
        match self.index_of[triangle as usize] {
            u32::MAX => None,
            k => Some(k),
        }
    }
}

/// Where a path left its last non-delta vertex for a mirror: what weighting the light it
/// may find after the mirror needs.
#[derive(Clone, Copy, Debug)]
pub struct ViaMirror {
    /// The BSDF's solid-angle pdf of the direction sampled at the vertex.
    pub bsdf_pdf: f32,
    /// The mirror (an index of [`Mirrors`]) and the distance from the vertex to it.
    pub mirror: u32,
    pub distance: f32,
}

/// Whether `p` lies inside triangle `v` (given a point already in its plane).
fn inside(v: &[Vec3; 3], n: Vec3, p: Vec3) -> bool {
    let edge = |a: Vec3, b: Vec3| (b - a).cross(p - a).dot(n) >= 0.0;
    edge(v[0], v[1]) && edge(v[1], v[2]) && edge(v[2], v[0])
}

impl Lights {
    /// Light arriving at `p` from an area light by way of one flat mirror: a
    /// [`LightSample`] whose direction and distance lead to the mirror point (the segment
    /// from there to the light is already checked for blockers), with the mirror's
    /// reflectance in its contribution. `um` picks the mirror, `uc` and `u` the light
    /// point.
    pub fn sample_via_mirror(
        &self,
        scene: &Scene,
        p: Vec3,
        um: f32,
        uc: f32,
        u: Vec2,
    ) -> Option<LightSample> {
        let mirrors = self.mirrors.as_ref()?;
        let k = mirrors.choose.sample(um);
        let mirror = &mirrors.triangles[k];
        let light = self.sample_area_point(uc, u)?;
        let (n, m0) = (mirror.normal, mirror.vertices[0]);
        // The vertex and the light must face the same side of the mirror.
        let (hx, hy) = ((p - m0).dot(n), (light.position - m0).dot(n));
        if hx * hy <= 0.0 {
            return None;
        }
        let image = light.position - n * (2.0 * hy);
        let to = image - p;
        let total2 = to.length_squared();
        if !is_positive_finite(total2) {
            return None;
        }
        let total = total2.sqrt();
        let wi = to / total;
        // Where the line to the image crosses the mirror's plane.
        let to_mirror = hx / (hx - (image - m0).dot(n)) * total;
        let at = p + wi * to_mirror;
        if !is_positive_finite(to_mirror) || !inside(&mirror.vertices, n, at) {
            return None;
        }
        let reflected = wi - n * (2.0 * wi.dot(n));
        let cos_l = -light.normal.dot(reflected);
        if cos_l <= 0.0 && !light.double_sided || cos_l == 0.0 {
            return None;
        }
        // The mirror's reflectance towards the vertex, from its own BSDF's delta lobe.
        let frame = Frame::new(n);
        let reflect = mirror.bsdf.sample(frame.to_local(-wi), 0.0, Vec2::ZERO)?;
        let pdf = mirrors.choose.probability(k) * light.density * total2 / cos_l.abs();
        if !is_positive_finite(pdf) {
            return None;
        }
        // The second segment, mirror to light, checked here (the caller checks the first).
        if !segment_clear(scene, at, n, light.position) {
            return None;
        }
        Some(LightSample {
            wi,
            dist: to_mirror,
            contribution: reflect.weight * light.emission(scene) / pdf,
            pdf,
        })
    }

    /// The solid-angle density with which [`Lights::sample_via_mirror`] would have
    /// produced a path found by BSDF sampling: from a vertex over `via.mirror` to the
    /// point of emitting triangle `triangle` with unit `normal`, reached by `dir` after
    /// `distance` past the mirror.
    pub fn mirror_pdf(
        &self,
        via: &ViaMirror,
        triangle: u32,
        normal: Vec3,
        dir: Vec3,
        distance: f32,
    ) -> f32 {
        let Some(mirrors) = &self.mirrors else {
            return 0.0;
        };
        let cos = normal.dot(dir).abs();
        if cos <= 0.0 {
            return 0.0;
        }
        let total = via.distance + distance;
        mirrors.choose.probability(via.mirror as usize)
            * self.area_density(triangle)
            * total
            * total
            / cos
    }
}
