//! What a `.vlf` file holds, in words (`holocave vlf info`), and its check (`holocave vlf
//! check`): every chunk read and its checksum, every value a radiance can be, and with a
//! scene, that the bake fits it.

use std::path::Path;

use holocave_scene::Scene;

use crate::bake::tail;
use crate::baked::{self, BakedError};
use crate::file::{VlfError, VlfFile};

/// The file's scene, settings, elements, glossy tiles and bounces, a line each.
pub fn describe(path: &Path) -> Result<Vec<String>, VlfError> {
    let f = VlfFile::read(path)?;
    let (s, state) = (&f.settings, &f.state);
    let per_tile = (s.tile_bins * s.tile_bins).max(1) as usize;
    let finished = match state.converged {
        true => "converged",
        false => "not finished: `vlf bake` resumes it",
    };
    let per_bounce: Vec<String> = state.residuals.iter().map(|r| format!("{r:.2e}")).collect();
    Ok(vec![
        path.display().to_string(),
        format!(
            "  scene        {} (fingerprint {:016x})",
            f.scene, f.fingerprint
        ),
        format!(
            "  settings     {} directions, {}² lines per subfield, element size {:.4}, {} direct samples, tolerance {:.1e}",
            s.directions, s.resolution, f.element_size, s.direct_samples, s.tolerance
        ),
        format!("  elements     {}", state.irradiance.len()),
        format!(
            "  glossy tiles {} of {}² bins ({:.2} MB), for GGX alpha below {}",
            state.tiles.len() / per_tile,
            s.tile_bins,
            (state.tiles.len() * 12) as f64 / 1e6,
            s.glossy_alpha
        ),
        format!(
            "  bounces      {} ({finished}), residual {:.3e}, tail {:.3e}",
            state.bounces,
            state.residual(),
            tail(&state.residuals)
        ),
        format!("  per bounce   {}", per_bounce.join(" ")),
    ])
}

/// Checks the file: its chunks and checksums, that every irradiance and tile value is
/// finite and not negative, and with `scene`, that it was baked for it and fits its
/// layout. What it holds, in a line.
pub fn check(path: &Path, scene: Option<&Scene>) -> Result<String, BakedError> {
    let f = match scene {
        Some(scene) => baked::open(path, scene)?.file,
        None => VlfFile::read(path)?,
    };
    let values = f.state.irradiance.iter().chain(&f.state.tiles).flatten();
    let bad = values.filter(|x| !x.is_finite() || **x < 0.0).count();
    if bad > 0 {
        return Err(BakedError::Mismatch {
            path: path.into(),
            what: format!("{bad} irradiance or tile values are negative or not finite"),
        });
    }
    Ok(format!(
        "{}: ok ({} elements, {} bounces)",
        path.display(),
        f.state.irradiance.len(),
        f.state.bounces
    ))
}
