//! What a wall takes per pixel and what it reads from the light field.
//!
//! The direct light of the sun, punctual lights and emitters is always taken per pixel
//! ([`PixelDirect`]), and the field gives the rest ([`State::indirect_values`]: the sky
//! along the lines, caustics, inter-reflected light). Where the field blurs the sky —
//! glossy surfaces whose lobe is narrower than a tile resolves
//! ([`crate::tiles::alpha_floor`]), which the tiles widen to it: the window a varnished
//! floor reflects — the per-pixel pass adds the difference between the surface's own
//! reflection of the sky and the widened lobe's
//! ([`PixelDirect::with_sharp_sky_reflections`]), so the field keeps all its light and
//! nothing is counted twice; what any tile's bins make of an even light (their binning,
//! and the albedo a widened lobe loses towards grazing) is put right per pixel
//! ([`TileAlbedo`]). Asked for (`--sky-per-pixel`), the whole sky is taken per
//! pixel instead, and the field is read less its sky
//! ([`State::indirect_values_without_sky`]), under the field's sky as a prior
//! ([`crate::view::SkyPrior`]).
//!
//! Where lights shine through mirrors and glass, their caustics are taken per pixel from a
//! photon map ([`Caustics`]) and the field is read less its caustic part (the emitters':
//! [`State::caustics`]).

use std::sync::Arc;

use holocave_scene::Scene;

use holocave_tracer::lights::Lights;

use crate::bake::{Settings, State};
use crate::baked::Blended;
use crate::caustics::{Caustics, PHOTONS};
use crate::elements::Elements;
use crate::hours::mix;
use crate::pixel_direct::PixelDirect;
use crate::plane_smooth::smooth_over_planes;
use crate::tile_albedo::TileAlbedo;
use crate::tiles::{Tiles, alpha_floor};

/// The per-pixel pass and the field's remainder a wall draws.
pub struct Split {
    pub direct: PixelDirect,
    /// What the lookups read: the elements' irradiance, then the tiles' radiance, less
    /// what is taken per pixel.
    pub remainder: Vec<[f32; 3]>,
    /// With the whole sky per pixel, the field's sky: the prior of the pixels' own mean
    /// ([`crate::view::SkyPrior`]).
    pub sky: Option<Vec<[f32; 3]>>,
    /// The caustics per pixel, where the scene has mirrors or glass and lights
    /// ([`crate::view::Visibility::draw_caustics`]).
    pub caustics: Option<Arc<Caustics>>,
}

impl Split {
    /// The split of a field baked with `settings` (`state`, laid out as `elements` and
    /// `tiles`) for `scene`, the whole sky per pixel with `sky_per_pixel`. An error when
    /// that is asked for and the state holds no sky part.
    pub fn new(
        scene: Arc<Scene>,
        settings: &Settings,
        state: &State,
        layout: (&Elements, &Tiles),
        sky_per_pixel: bool,
    ) -> Result<Split, String> {
        Self::of_parts(scene, settings, (state, None), layout, sky_per_pixel)
    }

    /// [`Self::new`] of `state`, which may be a bake set's blend of two bakes
    /// (`blended`): then each bake's remainder is smoothed over planes alone and the
    /// smoothed remainders are blended, so each bake is smoothed once (and kept,
    /// [`smooth_over_planes`]) whatever the time of day.
    pub fn of_parts(
        scene: Arc<Scene>,
        settings: &Settings,
        (state, blended): (&State, Option<&Blended>),
        (elements, tiles): (&Elements, &Tiles),
        sky_per_pixel: bool,
    ) -> Result<Split, String> {
        let direct = PixelDirect::new(scene.clone());
        let directions = Settings::rounded_directions(settings.directions);
        let caustics = Caustics::trace(&scene, &Lights::new(&scene), PHOTONS).map(Arc::new);
        // The field less what is taken per pixel (`part` of a state); smoothed over
        // planes after, so that the caustics' sharp part is not spread into the rest.
        let smoothed = |s: &State, part: &dyn Fn(&State) -> Vec<[f32; 3]>| {
            let values = match &caustics {
                Some(_) => s.less_caustics(part(s)),
                None => part(s),
            };
            smooth_over_planes(&scene, elements, tiles, &values)
        };
        let remainder = |part: &dyn Fn(&State) -> Vec<[f32; 3]>| match blended {
            None => smoothed(state, part),
            Some(b) => {
                let (before, after) = (&b.before.file.state, &b.after.file.state);
                mix(&smoothed(before, part), &smoothed(after, part), b.t)
            }
        };
        if sky_per_pixel {
            let field_sky = (state.sky_values())
                .ok_or("holds no sky part: bake it again to take the sky per pixel".to_string())?;
            // A blend holds a sky part only where both its bakes do ([`crate::hours::blend`]).
            let without_sky = |s: &State| {
                (s.indirect_values_without_sky()).expect("a sky part, as the blend of it has")
            };
            return Ok(Split {
                direct: direct
                    .with_sky(true)
                    .with_tile_albedo(TileAlbedo::new(tiles, directions, None)),
                remainder: remainder(&without_sky),
                sky: Some(field_sky),
                caustics,
            });
        }
        let floor = alpha_floor(settings.tile_bins, directions);
        // The field's sky keeps the widened lobe's albedo where it is sharpened.
        let tile_albedo = TileAlbedo::new(tiles, directions, state.sky_values());
        Ok(Split {
            direct: direct
                .with_sharp_sky_reflections(floor, tiles.triangles_widened(elements))
                .with_tile_albedo(tile_albedo),
            remainder: remainder(&State::indirect_values),
            sky: None,
            caustics,
        })
    }
}
