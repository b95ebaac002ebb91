//! What a wall takes per pixel and what it reads from the light field.
//!
//! The direct light of the sun, punctual lights and emitters is always taken per pixel
//! ([`PixelDirect`]), and the field gives the rest ([`State::indirect_values`]). The
//! sky's first arrival is taken per pixel too where the field cannot hold it: on glossy
//! surfaces whose lobe is narrower than a tile resolves ([`crate::tiles::alpha_floor`]:
//! their tiles are widened to it, or they have none and are drawn diffuse), where the
//! field blurs the window a varnished floor reflects. Asked for (`--sky-per-pixel`), it
//! is taken everywhere. Each element and tile whose points take the sky per pixel reads
//! the field less the sky ([`State::indirect_values_without_sky`]), every other one the
//! field with it, so the parts still sum to the whole field and nothing is counted twice.
//! The field's sky at those elements and tiles is the prior of the pixels' own mean
//! ([`crate::view::SkyPrior`]).

use std::sync::Arc;

use holocave_scene::{Material, Scene};
use holocave_tracer::microfacet::Ggx;

use crate::bake::{Settings, State};
use crate::elements::{Elements, cells};
use crate::pixel_direct::PixelDirect;
use crate::tiles::{Tiles, alpha_floor};
use crate::view::SKY_PRIOR_SAMPLES;

/// How many of a pixel's own sky samples the field's sky is worth where the lobe is
/// narrower than a tile resolves: none, as the field's value there is known to be the
/// blurred one (see `docs/vlf-direct.md`, "The sky per pixel").
pub const NARROW_SKY_PRIOR_SAMPLES: f32 = 0.0;

/// The per-pixel pass and the field's remainder a wall draws.
pub struct Split {
    pub direct: PixelDirect,
    /// What the lookups read: the elements' irradiance, then the tiles' radiance, less
    /// what is taken per pixel.
    pub remainder: Vec<[f32; 3]>,
    /// The field's sky where the sky is taken per pixel (zero elsewhere), and what it is
    /// worth in a pixel's samples; `None` where it is taken nowhere.
    pub sky: Option<(Vec<[f32; 3]>, f32)>,
}

/// Whether the sky is taken per pixel everywhere or only where the field blurs it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkyPerPixel {
    WhereBlurred,
    Everywhere,
}

/// Whether material `m`'s lobe is glossy (a GGX lobe, not glass, not a mirror) and
/// narrower than `alpha` at its roughness factor (a texture only scales it down).
fn narrower_than(m: &Material, alpha: f32) -> bool {
    let lobe = m.metallic > 0.0 || m.specular > 0.0;
    let glass = (1.0 - m.metallic) * m.transmission > 0.0;
    lobe && !glass && !Ggx::is_smooth(m.roughness) && Ggx::from_roughness(m.roughness).alpha < alpha
}

impl Split {
    /// The split of a field baked with `settings` (`state`, laid out as `elements` and
    /// `tiles`) for `scene`. An error when the sky is asked for everywhere and the state
    /// holds no sky part.
    pub fn new(
        scene: Arc<Scene>,
        settings: &Settings,
        state: &State,
        elements: &Elements,
        tiles: &Tiles,
        sky: SkyPerPixel,
    ) -> Result<Split, String> {
        let parts = state.indirect_values_without_sky().zip(state.sky_values());
        let indirect = state.indirect_values();
        let direct = PixelDirect::new(scene.clone());
        let materials: Vec<bool> = match sky {
            SkyPerPixel::Everywhere => vec![true; scene.materials.len()],
            SkyPerPixel::WhereBlurred => {
                let floor = alpha_floor(
                    settings.tile_bins,
                    Settings::rounded_directions(settings.directions),
                );
                scene
                    .materials
                    .iter()
                    .map(|m| narrower_than(m, floor))
                    .collect()
            }
        };
        let Some((without, field_sky)) = parts else {
            if sky == SkyPerPixel::Everywhere {
                return Err("holds no sky part: bake it again to take the sky per pixel".into());
            }
            return Ok(Split {
                direct,
                remainder: indirect,
                sky: None,
            });
        };
        let direct = match sky {
            SkyPerPixel::Everywhere => direct.with_sky(true),
            SkyPerPixel::WhereBlurred => direct.with_sky_on(materials.clone()),
        };
        if !direct.samples_sky() {
            return Ok(Split {
                direct,
                remainder: indirect,
                sky: None,
            });
        }
        let taken = taken_values(&scene, elements, tiles, &materials);
        let pick = |(i, t): (usize, &bool)| if *t { without[i] } else { indirect[i] };
        let remainder = taken.iter().enumerate().map(pick).collect();
        let prior = (taken.iter().zip(&field_sky))
            .map(|(t, s)| if *t { *s } else { [0.0; 3] })
            .collect();
        let k = match sky {
            SkyPerPixel::Everywhere => SKY_PRIOR_SAMPLES,
            SkyPerPixel::WhereBlurred => NARROW_SKY_PRIOR_SAMPLES,
        };
        Ok(Split {
            direct,
            remainder,
            sky: Some((prior, k)),
        })
    }
}

/// For each value the lookups read (elements, then tiles' bins), whether it belongs to
/// a triangle of a material marked in `materials`.
fn taken_values(
    scene: &Scene,
    elements: &Elements,
    tiles: &Tiles,
    materials: &[bool],
) -> Vec<bool> {
    let per_tile = tiles.per_tile();
    let mut taken = vec![false; elements.count + tiles.tiles.len() * per_tile];
    for (t, c) in elements.triangles.iter().enumerate() {
        if materials[scene.triangle_shading(t as u32).material as usize] {
            let first = c.offset as usize;
            taken[first..first + 2 * cells(c.res) as usize].fill(true);
        }
    }
    for (g, tile) in tiles.tiles.iter().enumerate() {
        if taken[tile.element as usize] {
            let first = elements.count + g * per_tile;
            taken[first..first + per_tile].fill(true);
        }
    }
    taken
}
