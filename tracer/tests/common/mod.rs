//! Helpers shared by the tracer's integration tests: scene paths, small scenes built from
//! parts, random directions and running statistics.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Vec2, Vec3, Vec4};
use holocave_scene::{
    Daylight, LoadOptions, Material, Scene, SceneParts, Sky, SkyModel, SurfaceParams,
    TriangleShading,
};
use holocave_tracer::{TraceSettings, Tracer};
use rand::Rng;
use rand_pcg::Pcg32;

/// A file of the project (relative to the workspace root).
pub fn project_path(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

/// A file of the read-only shared scenes beside the checkout (`../shared/scenes`).
pub fn shared_scene(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/scenes")
        .join(rel)
}

/// Loads a scene, with an optional daylight file; panics with the error (a test failure).
pub fn load(path: &Path, daylight: Option<PathBuf>) -> Arc<Scene> {
    let opts = LoadOptions {
        strict: false,
        daylight,
        ..Default::default()
    };
    match Scene::load(path, &opts) {
        Ok(s) => Arc::new(s),
        Err(e) => panic!("loading {}: {e}", path.display()),
    }
}

pub fn cornell() -> Arc<Scene> {
    load(&project_path("scenes/cornell.gltf"), None)
}

pub fn tracer(scene: Arc<Scene>) -> Tracer {
    Tracer::new(scene, TraceSettings::default())
}

/// A pure Lambertian material (glTF: metallic 0, `specularFactor` 0).
pub fn lambert(rho: Vec3, emissive: Vec3, double_sided: bool) -> Material {
    Material {
        name: "lambert".into(),
        base_color: rho.extend(1.0),
        metallic: 0.0,
        roughness: 1.0,
        specular: 0.0,
        emissive,
        double_sided,
        ..Material::default()
    }
}

/// A material given by its main factors (specular layer on, glTF defaults otherwise).
pub fn material(base: Vec3, metallic: f32, roughness: f32, transmission: f32) -> Material {
    Material {
        name: "m".into(),
        base_color: Vec4::from((base, 1.0)),
        metallic,
        roughness,
        transmission,
        ..Material::default()
    }
}

/// The 12 triangles of an axis-aligned box, front faces inward (`inward`) or outward.
pub fn box_triangles(lo: Vec3, hi: Vec3, inward: bool) -> Vec<[Vec3; 3]> {
    let c = |i: usize| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    // Each face as four corners counter-clockwise seen from outside.
    let faces = [
        [0, 4, 6, 2], // −X
        [1, 3, 7, 5], // +X
        [0, 1, 5, 4], // −Y
        [2, 6, 7, 3], // +Y
        [0, 2, 3, 1], // −Z
        [4, 5, 7, 6], // +Z
    ];
    let mut tris = Vec::new();
    for f in faces {
        let [a, b, cc, d] = f.map(c);
        for t in [[a, b, cc], [a, cc, d]] {
            tris.push(if inward { [t[0], t[2], t[1]] } else { t });
        }
    }
    tris
}

/// A flat-faceted UV sphere, front faces outward.
pub fn sphere_triangles(center: Vec3, radius: f32, rings: u32, segments: u32) -> Vec<[Vec3; 3]> {
    let p = |r: u32, s: u32| {
        let theta = r as f32 / rings as f32 * std::f32::consts::PI;
        let phi = s as f32 / segments as f32 * 2.0 * std::f32::consts::PI;
        center
            + radius
                * Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    -theta.sin() * phi.sin(),
                )
    };
    let mut tris = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (p(r, s), p(r, s + 1), p(r + 1, s), p(r + 1, s + 1));
            if r != 0 {
                tris.push([a, c, b]);
            }
            if r != rings - 1 {
                tris.push([b, c, d]);
            }
        }
    }
    tris
}

/// A scene from triangle groups, each with its material, and optional daylight.
pub fn scene_from(groups: Vec<(Vec<[Vec3; 3]>, Material)>, daylight: Daylight) -> Arc<Scene> {
    let mut parts = SceneParts {
        name: "test".into(),
        daylight,
        ..SceneParts::default()
    };
    for (k, (tris, m)) in groups.into_iter().enumerate() {
        for t in tris {
            parts.positions.push(t);
            parts.shading.push(TriangleShading {
                normals: None,
                uvs: [Vec2::ZERO; 3],
                material: k as u32,
            });
        }
        parts.materials.push(m);
    }
    Arc::new(Scene::from_parts(parts, Path::new("<test>")).expect("test scene builds"))
}

/// Daylight that is a uniform sky of radiance `l` in every direction (ground included).
pub fn uniform_sky(l: Vec3) -> Daylight {
    Daylight {
        sun: None,
        sky: Some(Sky {
            model: SkyModel::Uniform(l),
            ground: l,
        }),
        ..Default::default()
    }
}

pub fn uniform_sphere(rng: &mut Pcg32) -> Vec3 {
    let z = 1.0 - 2.0 * rng.random::<f32>();
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * rng.random::<f32>();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Running mean and variance of RGB values (f64 sums).
#[derive(Clone, Copy, Debug, Default)]
pub struct Stats {
    pub n: u64,
    sum: [f64; 3],
    sum2: [f64; 3],
}

impl Stats {
    pub fn add(&mut self, v: Vec3) {
        self.n += 1;
        for c in 0..3 {
            let x = f64::from(v[c]);
            self.sum[c] += x;
            self.sum2[c] += x * x;
        }
    }

    pub fn mean(&self, c: usize) -> f64 {
        self.sum[c] / self.n as f64
    }

    /// Unbiased sample variance of one value.
    pub fn variance(&self, c: usize) -> f64 {
        let n = self.n as f64;
        ((self.sum2[c] - self.sum[c] * self.sum[c] / n) / (n - 1.0)).max(0.0)
    }

    /// Standard error of the mean.
    pub fn std_error(&self, c: usize) -> f64 {
        (self.variance(c) / self.n as f64).sqrt()
    }
}

/// The two-sided normal quantile z such that P(|Z| > z) = `p`, for small `p`, by
/// bisection on the complementary error function (good to ~1e-6 in z).
pub fn z_for_two_sided(p: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if erfc(mid / std::f64::consts::SQRT_2) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Complementary error function (Numerical Recipes' Chebyshev fit, relative error
/// below 1.2e-7 everywhere).
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    // Coefficients of the fit's polynomial in t, lowest power first, summed by Horner's
    // rule (a written-out nested form sends rustfmt into exponential time).
    const C: [f64; 10] = [
        -1.265_512_23,
        1.000_023_68,
        0.374_091_96,
        0.096_784_18,
        -0.186_288_06,
        0.278_868_07,
        -1.135_203_98,
        1.488_515_87,
        -0.822_152_23,
        0.170_872_77,
    ];
    let poly = C.iter().rev().fold(0.0, |acc, &c| c + t * acc);
    let r = t * (-z * z + poly).exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

/// Adaptive Simpson quadrature of `f` over `[a, c]` (Lyness' stopping rule).
pub fn adaptive_simpson(f: &dyn Fn(f64) -> f64, a: f64, c: f64, eps: f64, depth: u32) -> f64 {
    #[allow(clippy::too_many_arguments)]
    fn rec(
        f: &dyn Fn(f64) -> f64,
        a: f64,
        b: f64,
        c: f64,
        fa: f64,
        fb: f64,
        fc: f64,
        whole: f64,
        eps: f64,
        depth: u32,
    ) -> f64 {
        let (d, e) = (0.5 * (a + b), 0.5 * (b + c));
        let (fd, fe) = (f(d), f(e));
        let h = c - a;
        let left = h / 12.0 * (fa + 4.0 * fd + fb);
        let right = h / 12.0 * (fb + 4.0 * fe + fc);
        let both = left + right;
        // Lyness' stopping rule, with Richardson extrapolation.
        if depth == 0 || (both - whole).abs() <= 15.0 * eps {
            return both + (both - whole) / 15.0;
        }
        rec(f, a, d, b, fa, fd, fb, left, 0.5 * eps, depth - 1)
            + rec(f, b, e, c, fb, fe, fc, right, 0.5 * eps, depth - 1)
    }
    let b = 0.5 * (a + c);
    let (fa, fb, fc) = (f(a), f(b), f(c));
    let whole = (c - a) / 6.0 * (fa + 4.0 * fb + fc);
    rec(f, a, b, c, fa, fb, fc, whole, eps, depth)
}

/// ∫∫ f(θ, φ) over a cell of the (θ, φ) rectangle. The θ range is shrunk by 1e-7 of its width at each end: the
/// density jumps at the horizon (θ = π/2, a cell edge), and a quadrature node exactly on
/// it would be evaluated on the wrong side (cos(π/2) = 6e-17 > 0 in floating point),
/// smearing reflection density into the first cell below. The mass left out is below
/// 2e-7 of a cell's.
pub fn integrate_cell(f: &dyn Fn(f64, f64) -> f64, t0: f64, t1: f64, p0: f64, p1: f64) -> f64 {
    let eps = 1e-7;
    let shrink = 1e-7 * (t1 - t0);
    let (t0, t1) = (t0 + shrink, t1 - shrink);
    let inner = |t: f64| adaptive_simpson(&|p| f(t, p), p0, p1, eps, 8);
    adaptive_simpson(&inner, t0, t1, eps, 8)
}

/// A surface of base colour `base` with glTF's other defaults.
pub fn params(base: Vec3, metallic: f32, roughness: f32, transmission: f32) -> SurfaceParams {
    SurfaceParams {
        base_color: base,
        metallic,
        roughness,
        transmission,
        ..SurfaceParams::default()
    }
}
