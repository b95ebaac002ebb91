//! Light sampling for next-event estimation: emissive triangles (chosen by power),
//! punctual lights (all of them, they are deltas), the sun (a cone) and the sky (a
//! piecewise-constant grid over the sphere). Each category exists only when the scene has
//! it, so a scene without, say, punctual lights never loops over them.

use glam::{Vec2, Vec3};
use holocave_scene::{Hit, PunctualKind, PunctualLight, Scene, Sky, Sun, luminance};
use std::f32::consts::PI;

use crate::few_lights::FewLights;
use crate::frame::Frame;
use crate::light_groups::LightGroups;
use crate::mirrors::Mirrors;
use crate::sampling::{Distribution, is_positive_finite, uniform_cone, uniform_triangle};

/// A direction towards a light, as seen from a shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub wi: Vec3,
    /// Distance to the light point (infinite for the sun and sky).
    pub dist: f32,
    /// Radiance arriving along `wi` divided by the pdf; for deltas, the irradiance
    /// normal to `wi`.
    pub contribution: Vec3,
    /// Solid-angle pdf for MIS; `INFINITY` for delta lights.
    pub pdf: f32,
}

/// A point sampled on an emissive triangle, with its area density.
pub struct LightPoint<'a> {
    pub position: Vec3,
    /// The triangle's unit face normal (its emitting side, unless double-sided).
    pub normal: Vec3,
    pub double_sided: bool,
    /// Probability per unit area of having picked this point.
    pub density: f32,
    light: &'a AreaLight,
    barycentrics: Vec3,
}

impl LightPoint<'_> {
    /// The radiance the point emits (the same towards every direction it emits into).
    pub fn emission(&self, scene: &Scene) -> Vec3 {
        self.light.emission(scene, self.barycentrics)
    }
}

/// Emissive triangles, chosen for next-event estimation by place where that pays.
struct AreaLights {
    triangles: Vec<AreaLight>,
    /// In proportion to power: wherever light is wanted, and at shading points when
    /// neither choice by place applies.
    choose: Distribution,
    /// The choice at a shading point.
    by_place: ByPlace,
    /// For each scene triangle, its index in `triangles` (`u32::MAX` if not emissive).
    index_of: Vec<u32>,
}

/// How a shading point chooses its emissive triangle.
enum ByPlace {
    /// Few triangles: each weighed by what it can send to the point ([`FewLights`]).
    Each(FewLights),
    /// Several lamps of many triangles: a lamp by power and distance ([`LightGroups`]).
    Groups(LightGroups),
    /// By power alone.
    Power,
}

/// What sampling a point on one emissive triangle needs, gathered once: a light sample
/// then reads one record instead of the scene's triangle, shading and material tables.
struct AreaLight {
    triangle: u32,
    vertices: [Vec3; 3],
    normal: Vec3,
    area: f32,
    material: u32,
    double_sided: bool,
    /// The emitted radiance when it is the same everywhere (no emissive texture).
    uniform_emission: Option<Vec3>,
}

impl AreaLight {
    fn new(scene: &Scene, triangle: u32) -> Self {
        let vertices = *scene.triangle(triangle);
        let material = scene.triangle_shading(triangle).material;
        let m = &scene.materials[material as usize];
        Self {
            triangle,
            vertices,
            normal: scene.face_normal(triangle),
            area: scene.triangle_area(triangle),
            material,
            double_sided: m.double_sided,
            uniform_emission: m.emissive_texture.is_none().then_some(m.emissive),
        }
    }

    /// Emitted radiance at barycentrics `w` (the texture read only when there is one).
    fn emission(&self, scene: &Scene, w: Vec3) -> Vec3 {
        self.uniform_emission.unwrap_or_else(|| {
            let uvs = scene.triangle_shading(self.triangle).uvs;
            let uv = uvs[0] * w.x + uvs[1] * w.y + uvs[2] * w.z;
            scene.materials[self.material as usize]
                .params(&scene.textures, uv)
                .emission
        })
    }
}

impl AreaLights {
    /// The point at `u` on area light `k`, chosen with `probability`.
    fn point(&self, k: usize, probability: f32, u: Vec2) -> LightPoint<'_> {
        let light = &self.triangles[k];
        let (bu, bv) = uniform_triangle(u);
        let w = Vec3::new(1.0 - bu - bv, bu, bv);
        let [p0, p1, p2] = light.vertices;
        LightPoint {
            position: p0 * w.x + p1 * w.y + p2 * w.z,
            normal: light.normal,
            double_sided: light.double_sided,
            density: probability / light.area,
            light,
            barycentrics: w,
        }
    }
}

/// The sky's radiance as a grid in (θ from +Y, φ): cells chosen by their power, a
/// direction uniform in solid angle within the cell.
pub struct SkySampler {
    sky: Sky,
    choose: Distribution,
}

const SKY_THETA: usize = 32;
const SKY_PHI: usize = 64;

fn sky_dir(cos_t: f32, phi: f32) -> Vec3 {
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    Vec3::new(sin_t * phi.cos(), cos_t, sin_t * phi.sin())
}

fn cell_cos_bounds(i: usize) -> (f32, f32) {
    let t0 = i as f32 / SKY_THETA as f32 * PI;
    let t1 = (i + 1) as f32 / SKY_THETA as f32 * PI;
    (t0.cos(), t1.cos())
}

fn cell_solid_angle(i: usize) -> f32 {
    let (c0, c1) = cell_cos_bounds(i);
    (c0 - c1) * 2.0 * PI / SKY_PHI as f32
}

impl SkySampler {
    pub fn new(sky: &Sky) -> Option<Self> {
        let mut weights = Vec::with_capacity(SKY_THETA * SKY_PHI);
        for i in 0..SKY_THETA {
            let (c0, c1) = cell_cos_bounds(i);
            for j in 0..SKY_PHI {
                // Mean of a 3×3 set of points in the cell: the weight only shapes the
                // pdf, the estimate stays unbiased however rough it is.
                let mut l = 0.0;
                for a in 0..3 {
                    for b in 0..3 {
                        let c = c0 + (c1 - c0) * (a as f32 + 0.5) / 3.0;
                        let phi = (j as f32 + (b as f32 + 0.5) / 3.0) / SKY_PHI as f32 * 2.0 * PI;
                        l += luminance(sky.radiance(sky_dir(c, phi))).max(0.0);
                    }
                }
                weights.push(l / 9.0 * cell_solid_angle(i));
            }
        }
        // A floor keeps every direction reachable even where the grid saw darkness.
        let mean = weights.iter().sum::<f32>() / weights.len() as f32;
        weights.iter_mut().for_each(|w| *w += 1e-3 * mean);
        Some(Self {
            sky: sky.clone(),
            choose: Distribution::new(&weights)?,
        })
    }

    fn cell_of(dir: Vec3) -> usize {
        let theta = dir.y.clamp(-1.0, 1.0).acos();
        let mut phi = dir.z.atan2(dir.x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let i = ((theta / PI * SKY_THETA as f32) as usize).min(SKY_THETA - 1);
        let j = ((phi / (2.0 * PI) * SKY_PHI as f32) as usize).min(SKY_PHI - 1);
        i * SKY_PHI + j
    }

    pub fn pdf(&self, dir: Vec3) -> f32 {
        let c = Self::cell_of(dir);
        self.choose.probability(c) / cell_solid_angle(c / SKY_PHI)
    }

    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        self.sky.radiance(dir)
    }

    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        // Reuse u.x: pick the cell, then rescale the remainder for the position inside.
        let c = self.choose.sample(u.x);
        let p = self.choose.probability(c);
        let lo = self.choose.cdf_before(c);
        let ux = ((u.x - lo) / p.max(1e-12)).clamp(0.0, 1.0);
        let (i, j) = (c / SKY_PHI, c % SKY_PHI);
        let (c0, c1) = cell_cos_bounds(i);
        let cos_t = c0 + (c1 - c0) * ux;
        let phi = (j as f32 + u.y) / SKY_PHI as f32 * 2.0 * PI;
        let dir = sky_dir(cos_t, phi);
        (dir, self.pdf(dir))
    }
}

/// Everything next-event estimation can aim at.
pub struct Lights {
    area: Option<AreaLights>,
    /// Flat mirrors that area lights are sampled through (only with area lights).
    pub(crate) mirrors: Option<Mirrors>,
    pub punctual: Vec<PunctualLight>,
    pub sun: Option<Sun>,
    pub sky: Option<SkySampler>,
}

impl Lights {
    pub fn new(scene: &Scene) -> Self {
        let mut triangles = Vec::new();
        let mut power = Vec::new();
        for t in 0..scene.triangle_count() as u32 {
            let m = &scene.materials[scene.triangle_shading(t).material as usize];
            if m.is_emissive() {
                let sides = if m.double_sided { 2.0 } else { 1.0 };
                triangles.push(AreaLight::new(scene, t));
                power.push(scene.triangle_area(t) * luminance(m.emissive).max(1e-6) * sides * PI);
            }
        }
        let area = Distribution::new(&power).map(|choose| {
            let mut index_of = vec![u32::MAX; scene.triangle_count()];
            for (k, light) in triangles.iter().enumerate() {
                index_of[light.triangle as usize] = k as u32;
            }
            let vertices: Vec<[Vec3; 3]> = triangles.iter().map(|l| l.vertices).collect();
            let normal: Vec<Vec3> = triangles.iter().map(|l| l.normal).collect();
            let sides: Vec<bool> = triangles.iter().map(|l| l.double_sided).collect();
            let material: Vec<u32> = triangles.iter().map(|l| l.material).collect();
            let by_place = match FewLights::new(&vertices, &normal, &sides, &power) {
                Some(each) => ByPlace::Each(each),
                None => LightGroups::new(&vertices, &material, &power)
                    .map_or(ByPlace::Power, ByPlace::Groups),
            };
            AreaLights {
                by_place,
                triangles,
                choose,
                index_of,
            }
        });
        let mirrors = area.as_ref().and_then(|_| Mirrors::new(scene));
        Self {
            area,
            mirrors,
            punctual: scene.lights.clone(),
            sun: scene.daylight.sun.clone(),
            sky: scene.daylight.sky.as_ref().and_then(SkySampler::new),
        }
    }

    pub fn has_area(&self) -> bool {
        self.area.is_some()
    }

    /// Whether light is also sampled through flat mirrors ([`crate::mirrors`]).
    pub fn has_mirrors(&self) -> bool {
        self.mirrors.is_some()
    }

    /// The mirror index of scene triangle `triangle`, when light is sampled through it.
    pub fn mirror_index(&self, triangle: u32) -> Option<u32> {
        self.mirrors.as_ref()?.index_of(triangle)
    }

    pub fn is_empty(&self) -> bool {
        self.area.is_none() && self.punctual.is_empty() && self.sun.is_none() && self.sky.is_none()
    }

    /// Solid-angle pdf with which [`Lights::sample_area`], at shading point `from`, picks
    /// the point `hit` seen along unit `dir`, for MIS against BSDF sampling.
    pub fn area_pdf(&self, hit: &Hit, from: Vec3, normal: Vec3, dir: Vec3) -> f32 {
        let cos = normal.dot(dir).abs();
        if cos <= 0.0 {
            return 0.0;
        }
        let Some(a) = &self.area else { return 0.0 };
        let k = match a.index_of[hit.triangle as usize] {
            u32::MAX => return 0.0,
            k => k as usize,
        };
        let probability = match &a.by_place {
            ByPlace::Each(each) => each.probability(from, k),
            ByPlace::Groups(groups) => groups.probability(from, k),
            ByPlace::Power => a.choose.probability(k),
        };
        let density = probability / a.triangles[k].area;
        density * hit.t * hit.t / cos
    }

    /// A point on an emissive triangle, seen from `p`: the triangle chosen for `p` (by
    /// power, by power and distance, or by what each triangle can send to `p`: see
    /// [`ByPlace`]) with `uc`, the point uniform on it with `u`.
    pub fn sample_area(&self, scene: &Scene, p: Vec3, uc: f32, u: Vec2) -> Option<LightSample> {
        let a = self.area.as_ref()?;
        let (k, probability) = match &a.by_place {
            ByPlace::Each(each) => each.sample(p, uc)?,
            ByPlace::Groups(groups) => groups.sample(p, uc)?,
            ByPlace::Power => {
                let k = a.choose.sample(uc);
                (k, a.choose.probability(k))
            }
        };
        let y = a.point(k, probability, u);
        let to = y.position - p;
        let d2 = to.length_squared();
        if !is_positive_finite(d2) {
            return None;
        }
        let dist = d2.sqrt();
        let wi = to / dist;
        let cos_l = -y.normal.dot(wi);
        if cos_l <= 0.0 && !y.double_sided || cos_l == 0.0 {
            return None;
        }
        let le = y.emission(scene);
        let pdf = y.density * d2 / cos_l.abs();
        if !is_positive_finite(pdf) {
            return None;
        }
        Some(LightSample {
            wi,
            dist,
            contribution: le / pdf,
            pdf,
        })
    }

    /// A point on an emissive triangle wherever it is wanted: the triangle by power
    /// (`uc`), the point uniform on it (`u`).
    pub fn sample_area_point(&self, uc: f32, u: Vec2) -> Option<LightPoint<'_>> {
        let a = self.area.as_ref()?;
        let k = a.choose.sample(uc);
        Some(a.point(k, a.choose.probability(k), u))
    }

    /// The area density with which [`Lights::sample_area_point`] picks a point of scene
    /// triangle `triangle` (zero for one that does not emit).
    pub fn area_density(&self, triangle: u32) -> f32 {
        let Some(a) = &self.area else { return 0.0 };
        match a.index_of[triangle as usize] {
            u32::MAX => 0.0,
            k => a.choose.probability(k as usize) / a.triangles[k as usize].area,
        }
    }

    /// Light from punctual light `i` at `p`.
    pub fn sample_punctual(&self, i: usize, p: Vec3) -> Option<LightSample> {
        let l = &self.punctual[i];
        if let PunctualKind::Directional = l.kind {
            return Some(LightSample {
                wi: -l.direction,
                dist: f32::INFINITY,
                contribution: l.intensity,
                pdf: f32::INFINITY,
            });
        }
        let to = l.position - p;
        let d2 = to.length_squared();
        if !is_positive_finite(d2) {
            return None;
        }
        let dist = d2.sqrt();
        let wi = to / dist;
        let e = l.intensity * (l.spot_factor(-wi) * l.range_factor(dist) / d2);
        (e.max_element() > 0.0).then_some(LightSample {
            wi,
            dist,
            contribution: e,
            pdf: f32::INFINITY,
        })
    }

    /// A direction within the sun's disk.
    pub fn sample_sun(&self, u: Vec2) -> Option<LightSample> {
        let s = self.sun.as_ref()?;
        let wi = Frame::new(s.direction).to_world(uniform_cone(u, s.one_minus_cos_radius()));
        let pdf = 1.0 / s.solid_angle();
        Some(LightSample {
            wi,
            dist: f32::INFINITY,
            contribution: s.radiance / pdf,
            pdf,
        })
    }

    /// The sun's radiance along `dir` (zero outside the disk) and its sampling pdf.
    pub fn sun_along(&self, dir: Vec3) -> Option<(Vec3, f32)> {
        let s = self.sun.as_ref()?;
        (dir.dot(s.direction) >= s.cos_radius()).then(|| (s.radiance, 1.0 / s.solid_angle()))
    }

    pub fn sample_sky(&self, u: Vec2) -> Option<LightSample> {
        let s = self.sky.as_ref()?;
        let (wi, pdf) = s.sample(u);
        if !is_positive_finite(pdf) {
            return None;
        }
        Some(LightSample {
            wi,
            dist: f32::INFINITY,
            contribution: s.radiance(wi) / pdf,
            pdf,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use holocave_scene::SkyModel;

    /// The sky sampler's pdf integrates to one and matches the density of its samples.
    #[test]
    fn sky_pdf_is_a_density() {
        let sky = Sky {
            model: SkyModel::CieClear {
                zenith: Vec3::splat(2.0),
                sun: Vec3::new(0.5, 0.4, -0.2).normalize(),
            },
            ground: Vec3::splat(0.1),
        };
        let s = SkySampler::new(&sky).unwrap();
        // ∫ pdf dω by a fine midpoint rule.
        let (nt, np) = (256, 512);
        let mut total = 0.0f64;
        for i in 0..nt {
            let c = 1.0 - 2.0 * (i as f32 + 0.5) / nt as f32;
            for j in 0..np {
                let phi = (j as f32 + 0.5) / np as f32 * 2.0 * PI;
                total += f64::from(s.pdf(sky_dir(c, phi)))
                    * (2.0 / nt as f64)
                    * (2.0 * std::f64::consts::PI / np as f64);
            }
        }
        assert!((total - 1.0).abs() < 1e-3, "{total}");
        // Samples report the pdf of the cell they land in, and are unit vectors.
        for k in 0..1000 {
            let u = Vec2::new((k as f32 + 0.5) / 1000.0, ((k * 37) % 1000) as f32 / 1000.0);
            let (d, pdf) = s.sample(u);
            assert!(
                (d.length() - 1.0).abs() < 1e-4
                    && pdf > 0.0
                    && (pdf - s.pdf(d)).abs() <= 1e-3 * pdf
            );
        }
    }
}
