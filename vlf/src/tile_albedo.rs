//! What a tile reflects of light that comes evenly, put right per pixel at the pixel's
//! own angle: the albedo a widened lobe loses towards grazing, and the bins' own error.
//!
//! A tile widens a glossy lobe narrower than its bins resolve to the least they do
//! ([`crate::tiles::alpha_floor`]); the wider GGX lobe loses more of its light to masking
//! and shadowing towards grazing (the room's varnish, α 0.06 widened to 0.22, 0.7 % at 30°
//! off its normal, 2.2 % at 57°, 5.7 % at 63° and 14 % at 70°, luminance). The bake gives
//! each arrival the surface's energy ([`crate::tiles::Glossy::glossy_scale`]), but the
//! widened lobe shares it out over the views otherwise than the surface's does, and the
//! bins hold it only to within their binning: lit evenly, the room's varnish's bins send
//! the surface's albedo +0.5 % at 10°, +1.5 % at 30°, +5.5 % at 57° and −2.3 % at 70°.
//! Neither can be put right in the bins themselves: the surface's
//! albedo climbs steeply towards grazing, and the bins' bilinear interpolation of it
//! overshot by 11 % at 63° (tried first).
//!
//! So the pixel does it, at its own angle: per material, the tile's response to an even
//! light of radiance 1 (`R`, per bin: what the bake's arrivals from every line direction
//! make of it, splat and scaled as the bake does), the surface's directional albedo `A_s`
//! and the widened lobe's `A_w` (over `cos θ_o`). A pixel that sees a tile along `ω_o`,
//! where the tile holds `L`, of which `S` is the field's sky, adds
//! `(A_s/R − 1)(L − S) + (A_w/R − 1) S`: under an even light `L_e`, `L = R L_e` becomes
//! `A_s L_e`; the sky's part becomes `A_w L_e`, to which the per-pixel pass adds the
//! surface's own sharp reflection of the sky less the widened lobe's
//! ([`crate::PixelDirect::with_sharp_sky_reflections`]). As if the light the tile reflects
//! came evenly from around it.

use std::collections::HashMap;

use glam::Vec3;
use holocave_scene::SurfaceParams;
use holocave_tracer::bsdf::Bsdf;
use rayon::prelude::*;

use crate::Directions;
use crate::octahedral;
use crate::reflection::{Reflection, params_key};
use crate::surface::{at_cos, directional_albedo, table_step};
use crate::tiles::{Glossy, NONE, Tiles};
use crate::view::Lookup;

/// Entries of a table over `cos θ_o ∈ [0, 1]`.
const STEPS: usize = 32;
/// Samples of each BSDF per entry (the same for all: their ratios are smooth).
const SAMPLES: u32 = 1024;

/// Materials given tables at most (one of one base colour takes a few milliseconds of a
/// core to measure, a textured one nine times that).
const MAX_MATERIALS: usize = 64;

/// Base colours the bins' response is measured at, per channel (`i/(BASES − 1)`).
const BASES: usize = 9;

/// One material's tables, over its base colour, so that one serves every texel of a
/// textured material. Each colour channel's light depends on that channel's base alone.
/// A material's albedo is affine in it (the Lambertian base is linear in it, and so is
/// the metal's Schlick Fresnel, whose `F0` it is): a black and a white base give it. The
/// bins' response is not (the bake scales each arrival by a ratio of two albedos): it is
/// measured at the material's one base colour, or, for a texture's many, at [`BASES`]
/// bases and taken linearly between them.
struct Material {
    /// `[A_s(black), A_s(white), A_w(black), A_w(white)]` at `cos θ_o = i/(STEPS − 1)`.
    albedo: [[Vec3; 4]; STEPS],
    /// The bins' response to an even light of radiance 1.
    response: Response,
}

enum Response {
    /// At the material's one base colour.
    One(Vec<Vec3>),
    /// Per base in [`BASES`].
    Over(Vec<Vec<Vec3>>),
}

/// Per tile, its material's tables, and the field's sky.
#[derive(Default)]
pub struct TileAlbedo {
    /// Per tile, its material in `materials` ([`NONE`]: none) and its base colour.
    of_tile: Vec<(u32, Vec3)>,
    materials: Vec<Material>,
    /// The field's sky (its first arrival, as the lookups read it), when the values the
    /// lookups read hold it.
    sky: Option<Vec<[f32; 3]>>,
    /// Tile `g`'s first entry is `elements + g bins²`.
    elements: u32,
    bins: u32,
}

impl TileAlbedo {
    /// For `tiles`, baked with `directions` line directions; `sky` the field's sky when
    /// the values the lookups read hold it.
    pub fn new(tiles: &Tiles, directions: usize, sky: Option<Vec<[f32; 3]>>) -> TileAlbedo {
        // Each material's first tile, its count of tiles, and whether their base colours
        // vary.
        let mut index: HashMap<([u32; 11], u32), u32> = HashMap::new();
        let mut first: Vec<(Glossy, usize, bool)> = Vec::new();
        let mut of_tile: Vec<(u32, Vec3)> = (tiles.tiles.iter())
            .map(|t| {
                let black = SurfaceParams {
                    base_color: Vec3::ZERO,
                    ..t.params
                };
                let key = (params_key(&black), t.surface_roughness.to_bits());
                let m = *index.entry(key).or_insert_with(|| {
                    first.push((*t, 0, false));
                    first.len() as u32 - 1
                });
                let f = &mut first[m as usize];
                f.1 += 1;
                f.2 |= f.0.params.base_color != t.params.base_color;
                (m, t.params.base_color)
            })
            .collect();
        // The materials with the most tiles, at most `MAX_MATERIALS` (a texture that
        // varies the roughness has one per texel); the rest's tiles are drawn as before.
        let mut order: Vec<usize> = (0..first.len()).collect();
        order.sort_by_key(|&m| std::cmp::Reverse(first[m].1));
        let mut kept = vec![NONE; first.len()];
        for (k, &m) in order.iter().take(MAX_MATERIALS).enumerate() {
            kept[m] = k as u32;
        }
        for t in &mut of_tile {
            t.0 = kept[t.0 as usize];
        }
        let directions = Directions::at_least(directions);
        let materials = (order.par_iter().take(MAX_MATERIALS))
            .map(|&m| Material::of(tiles, &first[m].0, first[m].2, &directions))
            .collect();
        TileAlbedo {
            of_tile,
            materials,
            sky,
            elements: tiles.elements,
            bins: tiles.bins,
        }
    }

    /// What the pixel of lookup `l` adds to the light field's `values` (the lookups'):
    /// the surface's albedo at the pixel's angle in place of what the tile's bins make of
    /// an even light, for the tile's light less the sky's, and the widened lobe's for the
    /// sky's.
    pub fn added(&self, l: &Lookup, values: &[[f32; 3]]) -> Vec3 {
        if l.tile == u32::MAX || l.object != 0 || self.materials.is_empty() {
            return Vec3::ZERO;
        }
        let g = (l.tile - self.elements) / (self.bins * self.bins);
        let Some(&(m, base)) = self.of_tile.get(g as usize).filter(|t| t.0 != NONE) else {
            return Vec3::ZERO;
        };
        let material = &self.materials[m as usize];
        let cos = octahedral::decode(f64::from(l.x), f64::from(l.y), l.bins).z as f32;
        let (i, f) = table_step(cos, STEPS);
        let a = &material.albedo;
        let [s0, s1, w0, w1] = std::array::from_fn(|k| a[i][k].lerp(a[i + 1][k], f));
        // The four bins around the pixel's direction, for every table and array.
        let shares = octahedral::bilinear(l.bins, (l.x, l.y));
        let at = |v: &[Vec3]| {
            (shares.iter())
                .map(|&(bin, w)| v[bin as usize] * w)
                .sum::<Vec3>()
        };
        let affine = |b: Vec3, w: Vec3| b + base * (w - b);
        let (surface, widened) = (affine(s0, s1), affine(w0, w1));
        let response = match &material.response {
            Response::One(r) => at(r),
            Response::Over(r) => Vec3::from_array(std::array::from_fn(|c| {
                let (i, f) = table_step(base[c], BASES);
                let (r0, r1) = (at(&r[i])[c], at(&r[i + 1])[c]);
                r0 + (r1 - r0) * f
            })),
        };
        let more = |albedo: Vec3| {
            Vec3::select(
                response.cmpgt(Vec3::ZERO),
                albedo / response - Vec3::ONE,
                Vec3::ZERO,
            )
        };
        let field = |v: &[[f32; 3]]| {
            (shares.iter())
                .map(|&(bin, w)| Vec3::from(v[(l.tile + bin) as usize]) * w)
                .sum::<Vec3>()
        };
        let (light, sky) = (field(values), self.sky.as_deref().map_or(Vec3::ZERO, field));
        let sky = sky.min(light);
        Vec3::from(l.weight) * (more(surface) * (light - sky) + more(widened) * sky)
    }
}

impl Material {
    /// The tables of tile `t`'s material (`tiles`' bins; its tiles' base colours
    /// `varying` or all `t`'s), the response to the even light from `directions`.
    fn of(tiles: &Tiles, t: &Glossy, varying: bool, directions: &Directions) -> Material {
        let with = |base: Vec3| {
            let params = SurfaceParams {
                base_color: base,
                ..t.params
            };
            let tile = Glossy {
                bsdf: Bsdf::new(&params),
                params,
                ..*t
            };
            (tile.surface_bsdf(), tile)
        };
        let [(s0, t0), (s1, t1)] = [with(Vec3::ZERO), with(Vec3::ONE)];
        let albedo = std::array::from_fn(|i| {
            [s0, s1, t0.bsdf, t1.bsdf].map(|b| directional_albedo(&b, at_cos(i, STEPS), SAMPLES))
        });
        let response = if varying {
            Response::Over(
                (0..BASES)
                    .map(|i| {
                        let base = Vec3::splat(i as f32 / (BASES - 1) as f32);
                        response(tiles, with(base).1, directions)
                    })
                    .collect(),
            )
        } else {
            Response::One(response(tiles, *t, directions))
        };
        Material { albedo, response }
    }
}

/// What tile `t` (one tile alone with `tiles`' bins, in its own frame) sends out into
/// each bin when light of radiance 1 arrives evenly along `directions`, splat and scaled
/// as the bake's lines are ([`Reflection`]).
fn response(tiles: &Tiles, t: Glossy, directions: &Directions) -> Vec<Vec3> {
    let alone = tiles.alone(t);
    let reflection = Reflection::new(&alone);
    let n = alone.per_tile();
    let mut arrived = vec![Vec3::ZERO; Reflection::slots(&alone)];
    for (d, omega) in directions.dirs.iter().zip(&directions.solid_angle) {
        let cos = t.frame.n.dot(*d);
        if cos > 0.0 {
            reflection.splat(&alone, 0, *d, Vec3::splat(cos * omega), &mut arrived);
        }
    }
    let mut out = vec![Vec3::ZERO; n];
    reflection.apply(&alone, 0, &arrived, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tiles::{BIN_SUB, Glossy, alpha_floor};
    use crate::view::shade_one;
    use holocave_tracer::frame::Frame;

    /// The room's varnish in a tile that widens it to the floor.
    fn widened_varnish() -> (Tiles, Bsdf) {
        let k = 8;
        let surface = SurfaceParams {
            base_color: Vec3::new(0.45, 0.28, 0.16),
            metallic: 0.0,
            roughness: 0.25,
            emission: Vec3::ZERO,
            specular: 1.0,
            specular_color: Vec3::ONE,
            transmission: 0.0,
            ior: 1.5,
        };
        let widened = SurfaceParams {
            roughness: alpha_floor(k, 642).sqrt(),
            ..surface
        };
        let (centres, projected) = octahedral::centres_and_projected(k);
        let tiles = Tiles {
            bins: k,
            of_element: vec![0],
            tiles: vec![Glossy {
                element: 0,
                frame: Frame::new(Vec3::Z),
                bsdf: Bsdf::new(&widened),
                params: widened,
                widened: true,
                surface_roughness: surface.roughness,
            }],
            centres,
            projected,
            samples: octahedral::bin_samples(k, BIN_SUB),
            elements: 1,
        };
        (tiles, Bsdf::new(&surface))
    }

    /// A widened tile lit evenly (its bins what the bake makes of an even light of
    /// radiance 1 from its 642 line directions) is drawn, with what the pixel adds, as the
    /// surface reflects that light at the pixel's angle, `A_s(θ_o)`, from 10° to 70° off
    /// its normal; the bins alone are +0.5 % at 10°, +1.5 % at 30°, +5.5 % at 57°, +4.2 %
    /// at 63° and −2.3 % at 70° (their binning, and the widened lobe's shape sending the
    /// surface's energy: [`crate::tiles::Glossy::glossy_scale`]). Bound: 0.5 %,
    /// the tables' linear steps in `cos θ_o` (1/31: about 0.3 % where the albedo bends
    /// most, near 70°) and their sampling (1,024 samples each, the same for all: well
    /// under it). Where that light is the field's sky, the widened lobe's albedo, `A_w`:
    /// the sharpening adds the surface's own reflection of the sky less the widened one's.
    #[test]
    fn an_evenly_lit_tile_is_drawn_with_the_surfaces_albedo() {
        let (tiles, surface) = widened_varnish();
        let k = tiles.bins;
        let widened = tiles.tiles[0].bsdf;
        let lum = holocave_scene::luminance;
        // The elements' one entry, then the tile's bins.
        let mut values = vec![[0.0f32; 3]];
        let lit = response(&tiles, tiles.tiles[0], &Directions::at_least(642));
        values.extend(lit.iter().map(|v| v.to_array()));
        let grazing = TileAlbedo::new(&tiles, 642, None);
        // Another texel of the material (another base colour) shares its tables, measured
        // over the bases.
        let mut texels = tiles.clone();
        let mut other = texels.tiles[0];
        other.params.base_color = Vec3::new(0.9, 0.1, 0.3);
        texels.tiles.push(other);
        let textured = TileAlbedo::new(&texels, 642, None);
        assert_eq!(textured.materials.len(), 1);
        let all_sky = TileAlbedo::new(&tiles, 642, Some(values.clone()));
        for degrees in [10f32, 30.0, 57.0, 63.0, 70.0] {
            let (s, c) = degrees.to_radians().sin_cos();
            let wo = Vec3::new(s * 0.6, s * 0.8, c);
            let (x, y) = octahedral::encode(wo, k);
            let l = Lookup {
                tile: tiles.elements,
                bins: k,
                x,
                y,
                weight: [1.0; 3],
                ..Lookup::NONE
            };
            let truth = lum(directional_albedo(&surface, wo, 16_384));
            let field = shade_one(&l, &values);
            let drawn = field + grazing.added(&l, &values);
            let off = |c: Vec3, truth: f32| lum(c) / truth - 1.0;
            eprintln!(
                "{degrees}°: drawn {:+.2} % (the bins alone {:+.2} %)",
                100.0 * off(drawn, truth),
                100.0 * off(field, truth)
            );
            assert!(
                off(drawn, truth).abs() < 0.005,
                "{degrees}°: drawn {:+.4} off the surface's albedo",
                off(drawn, truth)
            );
            // Measured over the bases, for a texture's texels.
            let over = field + textured.added(&l, &values);
            assert!(
                off(over, truth).abs() < 0.005,
                "{degrees}°: a texel drawn {:+.4} off the surface's albedo",
                off(over, truth)
            );
            if degrees >= 57.0 {
                assert!(
                    off(field, truth).abs() > 0.02,
                    "{degrees}°: the bins alone {:+.4}",
                    off(field, truth)
                );
            }
            let sky = field + all_sky.added(&l, &values);
            let truth = lum(directional_albedo(&widened, wo, 16_384));
            assert!(
                off(sky, truth).abs() < 0.005,
                "{degrees}°: the sky's part {:+.4} off the widened lobe's albedo",
                off(sky, truth)
            );
        }
    }
}
