//! What a headless node leaves in its output folder, and the one reader of it: each
//! frame's images (`DIR/<wall>/<frame>-<eye>.exr` linear and `.png` tone-mapped, with
//! debug images and a contact sheet on request) and, in a cluster, `presented.log` (one
//! presented frame number per line), which `sim` and the tests read back.

use std::collections::{BTreeMap, BTreeSet};
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use holocave_cave::Eye;

use crate::display::contact_sheet;
use crate::present::tonemap::wall_directions;
use crate::present::vision::{VeilSources, perceive};
use crate::{RenderNodeError, ToneMapper, ToneMode, WallDisplay};

/// The presented-frame log's name in a wall's folder.
pub const PRESENTED_LOG: &str = "presented.log";

/// An eye's name in file names.
pub fn eye_name(eye: Eye) -> &'static str {
    match eye {
        Eye::Left => "left",
        Eye::Right => "right",
        Eye::Centre => "centre",
    }
}

/// `<frame>-<eye>`: the stem of a frame's image of one eye.
pub fn frame_stem(frame: u64, eye: Eye) -> String {
    format!("{frame:05}-{}", eye_name(eye))
}

/// `DIR/<frame>-<eye>.png`: a frame's tone-mapped image of one eye.
pub fn frame_png(dir: &Path, frame: u64, eye: Eye) -> PathBuf {
    dir.join(format!("{}.png", frame_stem(frame, eye)))
}

fn write_error(path: &Path, e: impl std::fmt::Display) -> RenderNodeError {
    RenderNodeError::Write {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Writes frame `frame`'s images of every eye into `dir`: `.exr` (linear) and `.png`
/// (tone-mapped by `tone` — in human mode what a person would see from the eye's view of
/// the last frame — or the tracer's Reinhard preview at the display's exposure without
/// one), and with `debug` the priority image, the chosen pixels and a contact
/// sheet of all three.
pub fn write_frame(
    dir: &Path,
    frame: u64,
    eyes: &[Eye],
    display: &mut WallDisplay,
    tone: &mut Option<ToneMapper>,
    debug: bool,
) -> Result<(), RenderNodeError> {
    std::fs::create_dir_all(dir).map_err(|e| write_error(dir, e))?;
    let mut sheet = Vec::new();
    let mut width = 1;
    for (i, &eye) in eyes.iter().enumerate() {
        let img = display.cache.image(i);
        width = img.width;
        let stem = frame_stem(frame, eye);
        let exr = dir.join(format!("{stem}.exr"));
        img.write_exr(&exr).map_err(|e| write_error(&exr, e))?;
        let preview = match tone {
            Some(tm) => {
                // Human mode: the image as a person would see it from this eye's view.
                let seen = match (tm.mode, display.views.get(i)) {
                    (ToneMode::Human, Some(view)) => {
                        let dirs = wall_directions(&view.wall);
                        perceive(&img, &dirs, &VeilSources::none(), tm.efficacy).image
                    }
                    _ => img.clone(),
                };
                if i == 0 && tm.update(&seen, false) {
                    tracing::debug!("frame {frame}: tone mapping recomputed");
                }
                tm.apply(&seen)
            }
            None => {
                let exposure = display.exposure(&img);
                img.to_preview(exposure)
            }
        };
        let save = |img: &image::RgbImage, path: PathBuf| {
            img.save(&path).map_err(|e| write_error(&path, e))
        };
        save(&preview, dir.join(format!("{stem}.png")))?;
        if debug {
            let pr = display.cache.priority_image(i).to_preview(0.5);
            save(&pr, dir.join(format!("{stem}-priority.png")))?;
            let ch = display.cache.chosen_image(i).to_preview(100.0);
            save(&ch, dir.join(format!("{stem}-chosen.png")))?;
            sheet.push(vec![preview, pr, ch]);
        }
    }
    if debug {
        let zoom = (512 / width).max(1);
        let path = dir.join(format!("{frame:05}-sheet.png"));
        contact_sheet(&sheet, zoom)
            .save(&path)
            .map_err(|e| write_error(&path, e))?;
    }
    Ok(())
}

/// A wall's frames written as images (every eye's EXR and PNG preview) into its folder.
pub struct FrameImages {
    pub dir: PathBuf,
    pub eyes: &'static [Eye],
    /// The previews' tone mapping (`None`: the tracer's Reinhard preview).
    pub tone: Option<ToneMapper>,
    /// Also the priority image, the chosen pixels and a contact sheet of the three.
    pub debug: bool,
}

impl FrameImages {
    /// Writes frame `frame`'s images ([`write_frame`]).
    pub fn write(&mut self, frame: u64, display: &mut WallDisplay) -> Result<(), String> {
        write_frame(
            &self.dir,
            frame,
            self.eyes,
            display,
            &mut self.tone,
            self.debug,
        )
        .map_err(|e| format!("{e:#}"))
    }
}

/// A wall's `presented.log`, appended to as frames are presented.
pub struct PresentedLog {
    path: PathBuf,
    file: File,
}

impl PresentedLog {
    /// Opens (or creates) `DIR/presented.log` for appending.
    pub fn append(dir: &Path) -> Result<PresentedLog, RenderNodeError> {
        std::fs::create_dir_all(dir).map_err(|e| write_error(dir, e))?;
        let path = dir.join(PRESENTED_LOG);
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&path)
            .map_err(|e| write_error(&path, e))?;
        Ok(PresentedLog { path, file })
    }

    /// Records that `frame` was presented.
    pub fn presented(&mut self, frame: u64) -> Result<(), RenderNodeError> {
        writeln!(self.file, "{frame}").map_err(|e| write_error(&self.path, e))
    }
}

/// Why a presented log could not be read.
#[derive(Debug, thiserror::Error)]
pub enum PresentedLogError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: line {line}: {text:?} is not a frame number")]
    NotAFrame {
        path: String,
        line: usize,
        text: String,
    },
}

/// The frames a wall presented, in the order presented (`DIR/presented.log`; a wall that
/// has not presented anything yet has none).
pub fn read_presented(dir: &Path) -> Result<Vec<u64>, PresentedLogError> {
    let path = dir.join(PRESENTED_LOG);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(source) => {
            return Err(PresentedLogError::Io {
                path: path.display().to_string(),
                source,
            });
        }
    };
    text.lines()
        .enumerate()
        .map(|(i, l)| {
            l.trim()
                .parse::<u64>()
                .map_err(|_| PresentedLogError::NotAFrame {
                    path: path.display().to_string(),
                    line: i + 1,
                    text: l.to_owned(),
                })
        })
        .collect()
}

/// Each of `walls`' presented frames, from its `OUT/<wall>/presented.log`.
pub fn presented_logs(
    out: &Path,
    walls: &[holocave_cave::Wall],
) -> Result<BTreeMap<String, BTreeSet<u64>>, PresentedLogError> {
    (walls.iter())
        .map(|wall| {
            let frames = read_presented(&out.join(&wall.name))?;
            Ok((wall.name.clone(), frames.into_iter().collect()))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presented_frames_read_back_in_order_and_garbage_is_named() {
        let dir = tempfile::tempdir().unwrap();
        assert!(read_presented(dir.path()).unwrap().is_empty());
        let mut log = PresentedLog::append(dir.path()).unwrap();
        for f in [3, 4, 7] {
            log.presented(f).unwrap();
        }
        drop(log);
        assert_eq!(read_presented(dir.path()).unwrap(), vec![3, 4, 7]);
        std::fs::write(dir.path().join(PRESENTED_LOG), "3\nfour\n").unwrap();
        let e = read_presented(dir.path()).unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("four"), "{e}");
    }
}
