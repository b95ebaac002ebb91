//! Converged references: a path-traced image of exactly a frame's view at many paths per
//! pixel, rendered once and kept in `DIR/refs/` under a hash of the scene file, the view
//! and the path count, so a second run (another method list, another budget) reuses them.
//! A reference's own noise is measured with a second seed: an error near it reads as "no
//! measurable difference".

use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};

use holocave_cave::WallView;
use holocave_tracer::Tracer;
use holocave_tracer::film::{FilmError, Image};
use holocave_tracer::render::render;

/// The seed every reference is rendered with (the noise check uses another).
const SEED: u64 = 0x005E_ED0F_2EF5;

/// References of one scene at one path count, cached in a folder.
pub struct References<'a> {
    pub tracer: &'a Tracer,
    /// Paths per pixel.
    pub spp: u32,
    /// Where they are kept.
    pub dir: PathBuf,
    /// The scene's identity (its file's bytes hashed), so another scene never matches.
    pub scene_key: u64,
}

impl References<'_> {
    /// A hash of the scene file's contents.
    pub fn scene_key(scene: &Path) -> std::io::Result<u64> {
        let bytes = std::fs::read(scene)?;
        let mut h = std::collections::hash_map::DefaultHasher::new();
        bytes.hash(&mut h);
        Ok(h.finish())
    }

    fn path(&self, view: &WallView, seed: u64) -> PathBuf {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        self.scene_key.hash(&mut h);
        for v in [view.eye, view.pa, view.pb, view.pc] {
            v.to_array().map(f32::to_bits).hash(&mut h);
        }
        (view.size.width, view.size.height, self.spp, seed).hash(&mut h);
        self.dir.join(format!("{:016x}.exr", h.finish()))
    }

    /// The reference of `view`: read from the folder, or rendered and stored.
    pub fn get(&self, view: &WallView) -> Result<Image, FilmError> {
        self.with_seed(view, SEED)
    }

    fn with_seed(&self, view: &WallView, seed: u64) -> Result<Image, FilmError> {
        let path = self.path(view, seed);
        if path.exists() {
            // A damaged file is rendered again rather than trusted.
            if let Ok(img) = Image::read_exr(&path)
                && (img.width, img.height) == (view.size.width, view.size.height)
            {
                return Ok(img);
            }
        }
        let img = render(self.tracer, view, self.spp, seed, &|| {});
        std::fs::create_dir_all(&self.dir).map_err(|e| FilmError::Write {
            path: self.dir.display().to_string(),
            message: e.to_string(),
        })?;
        img.write_exr(&path)?;
        Ok(img)
    }

    /// The reference's own error: the relative MSE between two references of `view` with
    /// different seeds, halved (each is one independent noisy estimate, so their squared
    /// difference has twice the variance of one against the truth).
    pub fn noise(&self, view: &WallView) -> Result<f64, FilmError> {
        let a = self.get(view)?;
        let b = self.with_seed(view, SEED ^ 0xFFFF)?;
        Ok(b.relative_mse(&a) / 2.0)
    }
}
