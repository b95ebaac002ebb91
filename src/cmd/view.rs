//! The view flags of `render`, `vlf view` and `holodeck view`: an eye and a screen
//! rectangle, or a glTF camera of the scene; the image size is each command's own.

use std::path::Path;

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::Vec3;
use holocave_cave::{Size, WallView};
use holocave_render_node::present::tonemap::wall_directions;
use holocave_render_node::present::vision::VeilSources;
use holocave_scene::Scene;
use holocave_tracer::film::Image;

use super::tone::Tone;

/// Writes the PNG preview of `image` (drawn through `view`) to `png`: tone-mapped by
/// `tone` (in human mode, seen from the view's eye) at the scene's `efficacy`, or the
/// tracer's auto-exposed preview without one.
pub fn write_preview(
    image: &Image,
    view: &WallView,
    tone: Option<Tone>,
    efficacy: f32,
    png: &Path,
) -> Result<()> {
    match tone.and_then(|t| t.mapper(efficacy)) {
        Some(mut tm) => {
            let dirs = wall_directions(view);
            let (picture, _) = tm.map_view(image, &dirs, &VeilSources::none(), true);
            picture
                .save(png)
                .with_context(|| format!("writing {}", png.display()))?;
        }
        None => image.write_png(png, image.auto_exposure())?,
    }
    Ok(())
}

/// Which view of a scene: an eye and a screen, or a glTF camera.
#[derive(Args)]
pub struct ViewFlags {
    /// Eye position X,Y,Z in scene metres.
    #[arg(long, value_parser = super::parse::vec3, allow_hyphen_values = true)]
    pub eye: Option<Vec3>,
    /// The screen rectangle "PA;PB;PC": lower-left, lower-right and upper-left corners.
    #[arg(long, value_parser = super::parse::screen, allow_hyphen_values = true)]
    pub screen: Option<[Vec3; 3]>,
    /// Use a glTF camera of the scene instead of --eye/--screen.
    #[arg(long, conflicts_with_all = ["eye", "screen"])]
    pub camera: Option<String>,
}

impl ViewFlags {
    /// The view the flags give at `size` pixels; `scene` (and the path naming it
    /// in errors) is needed for `--camera` only.
    pub fn view(&self, scene: Option<(&Scene, &Path)>, size: Size) -> Result<WallView> {
        match (&self.camera, self.eye, self.screen) {
            (Some(name), _, _) => {
                let (scene, path) = scene.context("--camera needs --scene")?;
                let cam = scene
                    .cameras
                    .iter()
                    .find(|c| &c.name == name)
                    .with_context(|| {
                        let names: Vec<_> = scene.cameras.iter().map(|c| c.name.as_str()).collect();
                        format!(
                            "{} has no camera {name:?} (it has {names:?})",
                            path.display()
                        )
                    })?;
                Ok(WallView::through_camera(cam, size))
            }
            (None, Some(eye), Some([pa, pb, pc])) => Ok(WallView {
                eye,
                pa,
                pb,
                pc,
                size,
            }),
            _ => bail!("give --eye and --screen, or --camera"),
        }
    }
}
