//! The light a widened lobe loses at grazing angles, given back per pixel.
//!
//! A tile widens a glossy lobe narrower than its bins resolve to the least they do
//! ([`crate::tiles::alpha_floor`]); the wider GGX lobe loses more of its light to masking
//! and shadowing towards grazing, so its directional albedo falls short of the surface's:
//! the room's varnish (α 0.06 widened to 0.22) reflects 0.7 % less at 30° off its normal,
//! 2.2 % at 57°, 5.7 % at 63° and 14 % at 70° (luminance), and the floor along the walls,
//! seen from a standing eye, was drawn 3–7 % too dark. The bins cannot take the excess
//! themselves: it climbs steeply towards grazing, and the bins' bilinear interpolation of
//! it overshot by 11 % at 63°.
//!
//! So the pixel takes it, at its own angle: a pixel that sees a widened tile along `ω_o`
//! adds `(A_s/A_w − 1) L(ω_o)` of the tile's light `L` (the surface's directional albedo
//! `A_s`, the widened lobe's `A_w`, both tabulated over `cos θ_o` per material), as if the
//! light the tile reflects came evenly from around it. The sky's first arrival is left
//! out: the per-pixel pass sharpens the sky's reflection with the surface's own lobe
//! ([`crate::PixelDirect::with_sharp_sky_reflections`]), which gives the surface's albedo
//! already.

use std::collections::HashMap;

use glam::Vec3;
use holocave_scene::SurfaceParams;
use holocave_tracer::bsdf::Bsdf;
use rayon::prelude::*;

use crate::octahedral;
use crate::reflection::params_key;
use crate::surface::directional_albedo;
use crate::tiles::{NONE, Tiles};
use crate::view::Lookup;

/// Entries of a table over `cos θ_o ∈ [0, 1]`.
const STEPS: usize = 32;
/// Samples of each BSDF per entry (the same for all four: their ratio is smooth).
const SAMPLES: u32 = 1024;

/// Per widened tile, the albedo its lobe lost, and the field's sky it leaves alone.
///
/// A material's albedo is affine in its base colour (the Lambertian base is linear in it,
/// and so is the metal's Schlick Fresnel, whose `F0` it is), so one table serves every
/// base colour of a material: the surface's and the widened lobe's albedo with a black
/// and with a white base, per step in `cos θ_o`. A textured material's texels then share
/// one table (the breakfast room's widened tiles have one per texel: a table each took
/// 25 s to make).
#[derive(Default)]
pub struct GrazingAlbedo {
    /// Per tile, its material's table in `tables` ([`NONE`]: not widened) and its base
    /// colour.
    of_tile: Vec<(u32, Vec3)>,
    /// `[A_s(black), A_s(white), A_w(black), A_w(white)]` per colour channel at
    /// `cos θ_o = i/(STEPS − 1)`.
    tables: Vec<[[Vec3; 4]; STEPS]>,
    /// The field's sky (its first arrival, as the lookups read it), when the values the
    /// lookups read hold it.
    sky: Option<Vec<[f32; 3]>>,
    /// Tile `g`'s first entry is `elements + g bins²`.
    elements: u32,
    bins: u32,
}

impl GrazingAlbedo {
    /// For `tiles`; `sky` the field's sky when the values the lookups read hold it.
    pub fn new(tiles: &Tiles, sky: Option<Vec<[f32; 3]>>) -> GrazingAlbedo {
        let mut index: HashMap<([u32; 11], u32), u32> = HashMap::new();
        let mut materials: Vec<(SurfaceParams, f32)> = Vec::new();
        let of_tile = (tiles.tiles.iter())
            .map(|t| {
                if !t.widened {
                    return (NONE, Vec3::ZERO);
                }
                let black = SurfaceParams {
                    base_color: Vec3::ZERO,
                    ..t.params
                };
                let key = (params_key(&black), t.surface_roughness.to_bits());
                let m = *index.entry(key).or_insert_with(|| {
                    materials.push((black, t.surface_roughness));
                    materials.len() as u32 - 1
                });
                (m, t.params.base_color)
            })
            .collect();
        let tables = materials
            .par_iter()
            .map(|&(black, surface_roughness)| {
                let white = SurfaceParams {
                    base_color: Vec3::ONE,
                    ..black
                };
                let own = |p: SurfaceParams| SurfaceParams {
                    roughness: surface_roughness,
                    ..p
                };
                let bsdfs = [own(black), own(white), black, white].map(|p| Bsdf::new(&p));
                std::array::from_fn(|i| {
                    let cos = i as f32 / (STEPS - 1) as f32;
                    let wo = Vec3::new((1.0 - cos * cos).max(0.0).sqrt(), 0.0, cos);
                    bsdfs.map(|b| directional_albedo(&b, wo, SAMPLES))
                })
            })
            .collect();
        GrazingAlbedo {
            of_tile,
            tables,
            sky,
            elements: tiles.elements,
            bins: tiles.bins,
        }
    }

    /// What the pixel of lookup `l` adds to the light field's `values` (the lookups'):
    /// the albedo its tile's widened lobe lost at the pixel's angle, times the tile's
    /// light less the sky's.
    pub fn added(&self, l: &Lookup, values: &[[f32; 3]]) -> Vec3 {
        if l.tile == u32::MAX || l.object != 0 || self.tables.is_empty() {
            return Vec3::ZERO;
        }
        let per_tile = self.bins * self.bins;
        let g = (l.tile - self.elements) / per_tile;
        let Some(&(t, base)) = self.of_tile.get(g as usize).filter(|t| t.0 != NONE) else {
            return Vec3::ZERO;
        };
        let cos = octahedral::decode(f64::from(l.x), f64::from(l.y), l.bins).z as f32;
        let x = cos.clamp(0.0, 1.0) * (STEPS - 1) as f32;
        let i = (x as usize).min(STEPS - 2);
        let table = &self.tables[t as usize];
        let [s0, s1, w0, w1] =
            std::array::from_fn(|k| table[i][k].lerp(table[i + 1][k], x - i as f32));
        let (surface, widened) = (s0 + base * (s1 - s0), w0 + base * (w1 - w0));
        let more = Vec3::select(
            widened.cmpgt(Vec3::ZERO),
            surface / widened - Vec3::ONE,
            Vec3::ZERO,
        );
        let at = |v: &[[f32; 3]]| octahedral::interpolate(v, l.tile, l.bins, l.x, l.y);
        let sky = self.sky.as_deref().map_or(Vec3::ZERO, at);
        Vec3::from(l.weight) * more * (at(values) - sky).max(Vec3::ZERO)
    }
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

    /// A widened tile holding what it reflects of an even light around it (each bin the
    /// widened lobe's albedo at the bin's centre) is drawn, with what the pixel adds, as
    /// the surface reflects that light at the pixel's angle, `L A_s(θ_o)`, up to the
    /// bins' own error (their interpolation of the widened lobe's albedo, `e_b`, which
    /// the pixel cannot know), from 30° to 70° off its normal; without it 2.2 % too dark
    /// at 57°, 5.7 % at 63°, 14 % at 70° besides `e_b`. Bound: 0.5 %, the tables' linear
    /// steps in `cos θ_o` (1/31: about 0.3 % where the ratio bends most, near 70°) and
    /// their sampling (1,024 samples each, the same for both: well under it). Light that
    /// is the field's sky gets nothing: the sharpening gives its reflection the surface's
    /// albedo.
    #[test]
    fn a_widened_tile_is_drawn_with_the_surfaces_albedo() {
        let (tiles, surface) = widened_varnish();
        let k = tiles.bins;
        let widened = tiles.tiles[0].bsdf;
        let lum = |c: Vec3| c.dot(Vec3::new(0.2126, 0.7152, 0.0722));
        // The elements' one entry, then the tile's bins.
        let mut values = vec![[0.0f32; 3]];
        values.extend(
            (tiles.centres.iter()).map(|c| directional_albedo(&widened, *c, 16_384).to_array()),
        );
        let grazing = GrazingAlbedo::new(&tiles, None);
        // Another texel of the material (another base colour) shares its table.
        let mut texels = tiles.clone();
        let mut other = texels.tiles[0];
        other.params.base_color = Vec3::new(0.9, 0.1, 0.3);
        texels.tiles.push(other);
        assert_eq!(GrazingAlbedo::new(&texels, None).tables.len(), 1);
        let all_sky = GrazingAlbedo::new(&tiles, Some(values.clone()));
        for degrees in [30f32, 57.0, 63.0, 70.0] {
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
            let bins = lum(field) / lum(directional_albedo(&widened, wo, 16_384));
            let drawn = field + grazing.added(&l, &values);
            let off = |c: Vec3| lum(c) / truth - bins;
            eprintln!(
                "{degrees}°: bins {:+.2} %, drawn {:+.2} % ({:+.2} % without)",
                100.0 * (bins - 1.0),
                100.0 * off(drawn),
                100.0 * off(field)
            );
            assert!(
                off(drawn).abs() < 0.005,
                "{degrees}°: drawn {:+.4} off the surface's albedo",
                off(drawn)
            );
            if degrees >= 63.0 {
                assert!(off(field) < -0.03, "{degrees}°: the widened lobe's loss");
            }
            assert_eq!(all_sky.added(&l, &values), Vec3::ZERO, "the sky's light");
        }
    }
}
