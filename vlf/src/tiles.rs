//! Directional radiance tiles for glossy surfaces (§3.1 of the paper's
//! `L_s(ω, s, t, u, v, p)`): the radiance a glossy element sends out, stored over the
//! hemisphere of its shading normal.
//!
//! **Which surfaces.** A side of an element is *glossy* when the material at its centroid
//! has a GGX lobe (metal, or a dielectric's specular layer) that is neither a delta (a
//! mirror or smooth glass, followed exactly: `surface`) nor rougher than the bake's
//! [`Settings::glossy_alpha`], and does not transmit (rough glass stays as it was: drawn as
//! diffuse with its tint). Only the front side of a one-sided material gets a tile (its
//! back is the inside of a closed object); rougher surfaces, and the back sides, are
//! diffuse elements as before. A scene without glossy surfaces has no tiles at all.
//!
//! **How an element maps to its tile.** Each glossy element side has one tile: `k × k`
//! bins of the hemi-octahedral map (`octahedral`, `k` = [`Settings::tile_bins`]) in a
//! frame around the shading normal at the element's centroid. Tile `g` holds radiance
//! (not irradiance), and lies after the elements' irradiance in the arrays the lookup
//! reads: its bin `b` is entry `elements + g k² + b`.
//!
//! **What a tile stores.** `L_o(b) = Σ f(b, ω_i) dE(ω_i)` over the light arriving, with
//! `f(b, ω_i)` the BSDF averaged over bin `b` ([`Tiles::bin_mean`], [`BIN_SUB`]):
//! every line's `dE = L Δω h²/A` (the same weight as diffuse irradiance) and every
//! next-event sample of direct light, with the tracer's BSDF ([`Bsdf::eval`]). A lobe
//! narrower than the bins or the line directions cannot be resolved: the bins would alias
//! it (a highlight between two bin centres vanishes, one on a centre is counted over the
//! whole bin) and the lines would show as separate spots. So the tile's BSDF has its GGX
//! `α` raised to at least [`alpha_floor`], 0.7 of a bin's or a direction's spacing (0.22
//! for 8 bins): the highlights of smoother surfaces are blurred to that width instead,
//! with the energy the surface's own lobe reflects ([`Glossy::glossy_scale`]).

use glam::Vec3;
use holocave_scene::{Scene, SurfaceParams};
use holocave_tracer::bsdf::Bsdf;
use holocave_tracer::frame::Frame;
use holocave_tracer::microfacet::Ggx;
use rayon::prelude::*;

use crate::bake::Settings;
use crate::elements::{Elements, cells};
use crate::octahedral;
use crate::surface::{albedo_towards, seen_at};

/// Marks an element without a tile.
pub const NONE: u32 = u32::MAX;

/// Each bin's BSDF is averaged over `BIN_SUB × BIN_SUB` directions in it. At a bin's
/// centre alone, a lobe as narrow as the bins ([`alpha_floor`]) is aliased: light from
/// one bin centre has its mirror direction on another, where the lobe's peak is taken
/// for the whole bin, and between centres it is missed; the energy scaling
/// (`reflection`) then took the excess from the whole arrival, diffuse part included,
/// and the room's varnished floor reflected 5 % too little of a uniform sky at the angles
/// a viewer sees it from (`tests/glossy.rs`). Two by two removes it (three by three is
/// no better) for four times the BSDF evaluations of the direct light's samples.
pub const BIN_SUB: u32 = 2;

/// One glossy element side: the element, the frame its bins are in, and the BSDF its
/// tile integrates (with the widened lobe).
#[derive(Clone, Copy, Debug)]
pub struct Glossy {
    pub element: u32,
    pub frame: Frame,
    pub bsdf: Bsdf,
    /// What `bsdf` was made from.
    pub params: SurfaceParams,
    /// The surface's lobe is narrower than a tile resolves and `params` widen it.
    pub widened: bool,
    /// The surface's own roughness (`params` hold the widened one).
    pub surface_roughness: f32,
}

impl Glossy {
    /// The surface's own BSDF, with the lobe it has (narrower than `bsdf`'s where
    /// widened).
    pub fn surface_bsdf(&self) -> Bsdf {
        Bsdf::new(&self.surface_params())
    }

    fn surface_params(&self) -> SurfaceParams {
        SurfaceParams {
            roughness: self.surface_roughness,
            ..self.params
        }
    }

    /// What the surface's glossy lobes reflect of light arriving at `cos_i` from the
    /// normal, over what the tile's widened ones do (their directional albedos less the
    /// Lambertian base's, per channel; 1 where the lobe is the surface's own). A widened
    /// lobe keeps its shape but sends the surface's energy: GGX masks and shadows more of
    /// a wider lobe near grazing, and the room's varnish widened (`α` 0.06 to 0.22)
    /// reflects 5–11 % (red to blue) less than the surface at 65° off its normal — where
    /// the sun lights the patch of floor that the rest of the room is lit by.
    pub fn glossy_scale(&self, cos_i: f32) -> Vec3 {
        if !self.widened {
            return Vec3::ONE;
        }
        let base = self.bsdf.diffuse_reflectance(cos_i);
        let surface = albedo_towards(&self.surface_params(), cos_i) - base;
        let widened = albedo_towards(&self.params, cos_i) - base;
        Vec3::select(
            widened.cmpgt(Vec3::splat(1e-6)),
            surface.max(Vec3::ZERO) / widened,
            Vec3::ONE,
        )
    }
}

/// The tiles of a scene: which elements have one, and the bins' directions.
#[derive(Clone, Debug)]
pub struct Tiles {
    /// Bins along each side of a tile (`k`).
    pub bins: u32,
    /// The tile of each element ([`NONE`]: a diffuse element); empty when there are no
    /// tiles at all.
    pub of_element: Vec<u32>,
    pub tiles: Vec<Glossy>,
    /// The local direction at each bin's centre, and its cosine-weighted solid angle
    /// `cos θ_b Δω_b` (what a bin's radiance gives as exitance).
    pub centres: Vec<Vec3>,
    pub projected: Vec<f32>,
    /// [`BIN_SUB`]² directions in each bin and their weights
    /// ([`octahedral::bin_samples`]): a bin's radiance is the BSDF averaged over the bin.
    pub samples: Vec<(Vec3, f32)>,
    /// The number of elements (tile `g`'s first entry is `elements + g k²`).
    pub elements: u32,
}

/// Whether a surface with `p` gets a tile under the largest GGX `α` `max_alpha`.
pub fn is_glossy(p: &SurfaceParams, max_alpha: f32) -> bool {
    let glass = (1.0 - p.metallic) * p.transmission;
    let lobe = p.metallic > 0.0 || p.specular > 0.0;
    lobe && glass <= 0.0
        && !Ggx::is_smooth(p.roughness)
        && Ggx::from_roughness(p.roughness).alpha < max_alpha
}

/// The least GGX `α` a tile resolves: 0.7 times the angular spacing `h` of its bins
/// (`√(2π/k²)`) or of the line directions (`√(4π/l)`), whichever is larger. The reflected
/// lobe is about `2α` wide, and sampling a bump of width `w` at spacing `h` errs by about
/// `(h/w)²/12` in its integral: 4 % at the floor (tested below), less for wider lobes.
pub fn alpha_floor(bins: u32, directions: usize) -> f32 {
    let bin = (std::f32::consts::TAU / (bins * bins).max(1) as f32).sqrt();
    let line = (4.0 * std::f32::consts::PI / directions.max(1) as f32).sqrt();
    0.7 * bin.max(line)
}

impl Tiles {
    /// No tiles (a scene without glossy surfaces, or a bake that keeps none).
    pub fn none(bins: u32, elements: u32) -> Tiles {
        Tiles {
            bins,
            of_element: Vec::new(),
            tiles: Vec::new(),
            centres: Vec::new(),
            projected: Vec::new(),
            samples: Vec::new(),
            elements,
        }
    }

    /// Tile `t` alone, on element 0, with these bins (to measure what one tile does).
    pub fn alone(&self, t: Glossy) -> Tiles {
        Tiles {
            bins: self.bins,
            of_element: vec![0],
            tiles: vec![Glossy { element: 0, ..t }],
            centres: self.centres.clone(),
            projected: self.projected.clone(),
            samples: self.samples.clone(),
            elements: 1,
        }
    }

    /// The tiles of `scene` with `elements` and `settings`. Deterministic: the same on
    /// every machine, so a file stores the radiance and not the layout.
    pub fn new(scene: &Scene, elements: &Elements, settings: &Settings) -> Tiles {
        let k = settings.tile_bins.max(1);
        let count = elements.count as u32;
        if settings.glossy_alpha <= 0.0 {
            return Tiles::none(k, count);
        }
        // No material that can be glossy anywhere (glTF's textures only scale the factors
        // down): no tiles, and not even a look at the elements.
        let may_be_glossy = |m: &holocave_scene::Material| {
            let lobe = m.metallic > 0.0 || m.specular > 0.0;
            let glass = (1.0 - m.metallic) * m.transmission > 0.0;
            let smooth = Ggx::is_smooth(m.roughness);
            let rough = Ggx::from_roughness(m.roughness).alpha >= settings.glossy_alpha;
            lobe && !glass && !smooth && (!rough || m.metallic_roughness_texture.is_some())
        };
        if !scene.materials.iter().any(may_be_glossy) {
            return Tiles::none(k, count);
        }
        let floor = alpha_floor(k, Settings::rounded_directions(settings.directions));
        let (area, centre) = elements.areas_and_centres(scene);
        // A glossy element smaller than the area a line's light is spread over keeps
        // only `A / least` of what reaches it in its tile (and tiles that small cannot be
        // pooled: their bounces grew); one a little larger receives a few dozen lines, and
        // on a curved shell of small triangles its tile's light is patchy beside its
        // pooled neighbours (the breakfast room's chairs were mottled). Below
        // `POOLED_BELOW` times that area it is drawn diffuse instead — its albedo the
        // BSDF's, pooled with its neighbours (`crate::pools`), its reflection the view's
        // (`view::Visibility::blurred_reflection`) — and its highlights come from the
        // direct light per pixel, with the full BSDF.
        let least = crate::bake::least_area(scene, settings);
        let found: Vec<Option<Glossy>> = centre
            .par_iter()
            .enumerate()
            .map(|(e, &(t, u, v))| {
                let cells = elements.triangles[t as usize];
                let side = u32::from(e as u32 >= cells.base(1));
                let s = seen_at(scene, t, u, v);
                let material = &scene.materials[scene.triangle_shading(t).material as usize];
                if s.delta
                    || !is_glossy(&s.params, settings.glossy_alpha)
                    || (side == 1 && !material.double_sided)
                    || crate::pools::pooled(area[e], least)
                {
                    return None;
                }
                let ng = if side == 0 { s.normal } else { -s.normal };
                let mut n = s.shading_normal;
                if n.dot(ng) < 0.0 {
                    n = -n;
                }
                let mut p = s.params;
                let surface_roughness = p.roughness;
                let widened = Ggx::from_roughness(p.roughness).alpha < floor;
                if widened {
                    p.roughness = floor.sqrt();
                }
                Some(Glossy {
                    element: e as u32,
                    frame: Frame::new(n),
                    bsdf: Bsdf::new(&p),
                    params: p,
                    widened,
                    surface_roughness,
                })
            })
            .collect();
        let tiles: Vec<Glossy> = found.into_iter().flatten().collect();
        if tiles.is_empty() {
            return Tiles::none(k, count);
        }
        let mut of_element = vec![NONE; elements.count];
        for (g, t) in tiles.iter().enumerate() {
            of_element[t.element as usize] = g as u32;
        }
        let (centres, projected) = octahedral::centres_and_projected(k);
        Tiles {
            bins: k,
            of_element,
            tiles,
            centres,
            projected,
            samples: octahedral::bin_samples(k, BIN_SUB),
            elements: count,
        }
    }

    /// Per triangle of the scene laid out as `elements`, whether any of its elements has
    /// a tile whose lobe was widened to the least a tile resolves.
    pub fn triangles_widened(&self, elements: &Elements) -> Vec<bool> {
        (elements.triangles.iter())
            .map(|c| {
                let (first, count) = (c.offset as usize, 2 * cells(c.res) as usize);
                (self.of_element.get(first..first + count)).is_some_and(|e| {
                    e.iter()
                        .any(|&g| g != NONE && self.tiles[g as usize].widened)
                })
            })
            .collect()
    }

    /// Bins in one tile.
    pub fn per_tile(&self) -> usize {
        (self.bins * self.bins) as usize
    }

    /// Entries of all tiles (`tiles × k²`).
    pub fn len(&self) -> usize {
        self.tiles.len() * self.per_tile()
    }

    pub fn is_empty(&self) -> bool {
        self.tiles.is_empty()
    }

    /// The tile of element `e`, if it has one.
    pub fn of(&self, e: u32) -> Option<u32> {
        self.of_element
            .get(e as usize)
            .copied()
            .filter(|&g| g != NONE)
    }

    /// Adds to `out` (one tile's bins) the radiance that irradiance `de` arriving from
    /// world direction `wi` (towards where the light comes from) sends into every bin:
    /// the glossy lobes' (at the surface's energy, [`Glossy::glossy_scale`]) and the
    /// Lambertian base's.
    pub fn accumulate(&self, g: u32, wi: Vec3, de: Vec3, out: &mut [Vec3]) {
        let t = &self.tiles[g as usize];
        let wi = t.frame.to_local(wi);
        if wi.z <= 0.0 {
            return;
        }
        let (scale, through) = (t.glossy_scale(wi.z), t.bsdf.through_layer(wi.z));
        for (o, b) in out.iter_mut().zip(0..) {
            // The base's share of the bin is separable (`Bsdf::lambert_out` times
            // `through_layer`): one evaluation of the BSDF a direction, as for the whole.
            let all = self.bin_mean(b, |wo| t.bsdf.eval(wo, wi).0);
            let base = self.bin_lambert_out(&t.bsdf, b) * through;
            *o += ((all - base) * scale + base) * de;
        }
    }

    /// The mean of `f` over the local directions of bin `b`, weighted by `cos θ dω` (so
    /// that a BSDF's mean, times the bin's `projected`, is the exitance the bin stands
    /// for).
    pub fn bin_mean(&self, b: usize, f: impl Fn(Vec3) -> Vec3) -> Vec3 {
        let n = (BIN_SUB * BIN_SUB) as usize;
        self.samples[b * n..(b + 1) * n]
            .iter()
            .map(|(wo, w)| f(*wo) * *w)
            .sum()
    }

    /// The BSDF's glossy lobes (its Lambertian base left out: [`Self::bin_lambert_out`])
    /// from local direction `wi` into bin `b`, averaged over the bin.
    pub fn bin_glossy(&self, bsdf: &Bsdf, b: usize, wi: Vec3) -> Vec3 {
        self.bin_mean(b, |wo| bsdf.eval(wo, wi).0 - bsdf.eval_diffuse(wo, wi))
    }

    /// The Lambertian base's `f` into bin `b` for light that has passed the specular
    /// layer ([`Bsdf::lambert_out`]), averaged over the bin.
    pub fn bin_lambert_out(&self, bsdf: &Bsdf, b: usize) -> Vec3 {
        self.bin_mean(b, |wo| bsdf.lambert_out(wo.z))
    }

    /// The radiance tile `g` sends along world direction `dir`, from `values` (the tiles'
    /// bins only, tile `g` at `g k²`).
    pub fn radiance(&self, values: &[[f32; 3]], g: u32, dir: Vec3) -> Vec3 {
        let local = self.tiles[g as usize].frame.to_local(dir);
        let (x, y) = octahedral::encode(local, self.bins);
        octahedral::interpolate(values, g * self.bins * self.bins, self.bins, x, y)
    }

    /// The map coordinates a viewer looking along `view` (towards the surface) reads in
    /// tile `g` at a point whose shading normal is `n`: the direction that the tile's
    /// normal mirrors into the same reflected direction as `n` does, so a highlight moves
    /// smoothly across the element instead of being one per element.
    pub fn view_coords(&self, g: u32, view: Vec3, n: Vec3) -> (f32, f32) {
        let f = &self.tiles[g as usize].frame;
        let wo = -view;
        let n = if n.dot(f.n) < 0.0 { -n } else { n };
        let mirror = n * (2.0 * n.dot(wo)) - wo;
        let corrected = f.n * (2.0 * f.n.dot(mirror)) - mirror;
        octahedral::encode(f.to_local(corrected.normalize_or(wo)), self.bins)
    }

    /// The radiosity a tile's bins amount to, `Σ_b L_b cos θ_b Δω_b / π`: the light it
    /// sends out, on the scale of a diffuse element's `B` (for the stopping rule).
    pub fn radiosity(&self, tile: &[[f32; 3]]) -> Vec3 {
        tile.iter()
            .zip(&self.projected)
            .map(|(l, p)| Vec3::from(*l) * *p)
            .sum::<Vec3>()
            * std::f32::consts::FRAC_1_PI
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    fn metal(roughness: f32) -> SurfaceParams {
        SurfaceParams {
            base_color: Vec3::new(0.9, 0.6, 0.3),
            metallic: 1.0,
            roughness,
            emission: Vec3::ZERO,
            specular: 1.0,
            specular_color: Vec3::ONE,
            transmission: 0.0,
            ior: 1.5,
        }
    }

    #[test]
    fn which_surfaces_are_glossy() {
        assert!(is_glossy(&metal(0.3), 0.3));
        assert!(!is_glossy(&metal(0.6), 0.3), "rougher than the threshold");
        assert!(!is_glossy(&metal(0.0), 0.3), "a mirror is a delta");
        let mut lambert = metal(0.2);
        lambert.metallic = 0.0;
        lambert.specular = 0.0;
        assert!(!is_glossy(&lambert, 0.3), "no lobe: pure Lambert");
        lambert.specular = 1.0;
        assert!(is_glossy(&lambert, 0.3), "a dielectric's specular layer");
        lambert.transmission = 1.0;
        assert!(!is_glossy(&lambert, 0.3), "rough glass");
    }

    /// The bins' quadrature of a tile's BSDF, `Σ_b f(b, ω_i) cos θ_b Δω_b` with `f(b, ·)`
    /// the BSDF averaged over bin `b` (what a tile holds), is the directional albedo the
    /// tracer's BSDF has (its importance sampling's mean weight), for lobes at the floor
    /// and wider: what a tile sends out is what the surface reflects. 8 × 8 bins, GGX α
    /// from the floor (0.219) to 0.5, incidence 0° to 70°. Tolerance: 5 % — the
    /// second-order error `(h/2α)²/12` of a quadrature at the bins' centres alone, 4.2 %
    /// at the floor (`h = √(2π)/8`; the bins' 2 × 2 average has a quarter of it), less
    /// above, plus the 40 000-sample reference's spread (under 0.5 % at four standard
    /// deviations).
    #[test]
    fn a_tile_reflects_the_directional_albedo() {
        let k = 8;
        let floor = alpha_floor(k, 642);
        assert!((floor - 0.2193).abs() < 1e-3, "{floor}");
        let (_, projected) = octahedral::centres_and_projected(k);
        let samples = octahedral::bin_samples(k, BIN_SUB);
        let per_bin = (BIN_SUB * BIN_SUB) as usize;
        for alpha in [floor, 0.25, 0.5] {
            let bsdf = Bsdf::new(&metal(alpha.sqrt()));
            for theta in [0.0f32, 0.5, 0.9, 1.2] {
                let wi = Vec3::new(theta.sin(), 0.0, theta.cos());
                let quad: Vec3 = (samples.chunks(per_bin).zip(&projected))
                    .map(|(bin, p)| {
                        bin.iter()
                            .map(|(wo, w)| bsdf.eval(*wo, wi).0 * *w)
                            .sum::<Vec3>()
                            * *p
                    })
                    .sum();
                // Reciprocity: the albedo seen from wi is the mean weight of sampling wi.
                let n = 40_000;
                let mut sum = Vec3::ZERO;
                for s in 0..n {
                    let u = Vec2::new(
                        (s as f32 + 0.5) / n as f32,
                        ((s as u64 * 2_654_435_761) % 1_000_003) as f32 / 1_000_003.0,
                    );
                    if let Some(b) = bsdf.sample(wi, 0.5, u) {
                        sum += b.weight;
                    }
                }
                let mc = sum / n as f32;
                let err = ((quad - mc) / mc).abs().max_element();
                assert!(
                    err < 0.05,
                    "alpha {alpha}, theta {theta}: bins {quad}, sampled {mc}"
                );
            }
        }
    }
}
