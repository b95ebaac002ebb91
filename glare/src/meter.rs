//! Glare measured live: a running session calls [`GlareMeter::measure`] once a frame with
//! the head's position and view direction and gets the figures of what it sees, drawn
//! the meter's way ([`Drawing`]) at a fixed fisheye size (the solid angles, which depend
//! only on the size, are computed once).

use glam::Vec3;
use holocave_scene::Photometry;
use holocave_tracer::film::Image;

use crate::draw::Drawing;
use crate::error::GlareError;
use crate::figures::{Figures, evaluate_with};
use crate::fisheye::Fisheye;
use crate::luminance::LuminanceMap;
use crate::rules::Rules;

/// Measures the glare of views of one scene.
pub struct GlareMeter {
    drawing: Drawing,
    size: u32,
    up: Vec3,
    rules: Rules,
    photometry: Photometry,
    omega: Vec<f64>,
}

/// Up directions tried in turn when a view looks along the meter's own.
const OTHER_UPS: [Vec3; 2] = [Vec3::NEG_Z, Vec3::X];

impl GlareMeter {
    /// The meter of a session's glare: `size`² fisheyes of `scene` drawn from the light
    /// field at `vlf` with the direct light per pixel, as the walls draw them, by the
    /// default rules in the scene's photometric units (`sim --glare`, `master --glare`,
    /// `node --standalone --glare`).
    pub fn of_light_field(
        scene: &std::sync::Arc<holocave_scene::Scene>,
        vlf: &std::path::Path,
        size: u32,
    ) -> Result<Self, GlareError> {
        let opened = holocave_vlf::baked::open(vlf, scene).map_err(|e| GlareError::LightField {
            path: vlf.to_path_buf(),
            message: e.to_string(),
        })?;
        let drawing = Drawing::light_field(scene.clone(), opened, false, 1, 1);
        GlareMeter::new(
            drawing,
            size,
            Vec3::Y,
            Rules::default(),
            scene.daylight.photometry,
        )
    }

    /// A meter drawing `size × size` fisheyes with `drawing`, `up` the world's up (the
    /// fisheye's up unless a view looks along it), figures by `rules` in `photometry`'s
    /// units.
    pub fn new(
        drawing: Drawing,
        size: u32,
        up: Vec3,
        rules: Rules,
        photometry: Photometry,
    ) -> Result<Self, GlareError> {
        rules.validate()?;
        let omega = Fisheye::new(size, Vec3::ZERO, Vec3::NEG_Z, Vec3::Y)?.solid_angles();
        if !(up.is_finite() && up.length() > 1e-9) {
            return Err(GlareError::BadView(format!(
                "the up direction {up} is not a direction"
            )));
        }
        Ok(GlareMeter {
            drawing,
            size,
            up,
            rules,
            photometry,
            omega,
        })
    }

    /// The fisheye of an eye at `eye` looking along `look`: the meter's up, or another
    /// axis when `look` is along it (a head looking straight up or down: the position
    /// index then takes that axis as up).
    pub fn fisheye(&self, eye: Vec3, look: Vec3) -> Result<Fisheye, GlareError> {
        let first = Fisheye::new(self.size, eye, look, self.up);
        if let Err(GlareError::BadView(_)) = &first
            && look.is_finite()
            && look.length() > 1e-9
        {
            for up in OTHER_UPS {
                if let Ok(f) = Fisheye::new(self.size, eye, look, up) {
                    return Ok(f);
                }
            }
        }
        first
    }

    /// The figures of the view from `eye` along `look`.
    pub fn measure(&self, eye: Vec3, look: Vec3) -> Result<Figures, GlareError> {
        self.measure_with_image(eye, look).map(|(_, f)| f)
    }

    /// [`GlareMeter::measure`], and the fisheye's radiance it was computed from.
    pub fn measure_with_image(
        &self,
        eye: Vec3,
        look: Vec3,
    ) -> Result<(Image, Figures), GlareError> {
        let fisheye = self.fisheye(eye, look)?;
        let image = self.drawing.draw(&fisheye);
        let dirs = fisheye.directions();
        let map = LuminanceMap::from_radiance(fisheye, &image, &self.photometry)?;
        let figures = evaluate_with(&map, &self.rules, &self.omega, &dirs)?;
        Ok((image, figures))
    }
}
