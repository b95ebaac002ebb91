//! Keyframed object motions, read from CSV: where each object stands at given times, so
//! that a recorded or scripted session moves the furniture the same way every run.
//!
//! The file's first line (after blank lines and `#` comments) is exactly
//! `object,time_s,tx,ty,tz,qx,qy,qz,qw`; each row gives an object's placement (translation
//! in metres, rotation as a quaternion, normalised on reading) at a time in seconds.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};

use super::Placement;
use crate::scene::Scene;

/// The header a path file starts with.
pub const HEADER: [&str; 9] = ["object", "time_s", "tx", "ty", "tz", "qx", "qy", "qz", "qw"];

/// What is wrong with a path file; each names the file, and the line where there is one.
#[derive(Debug, thiserror::Error)]
pub enum PathError {
    #[error("{path}:{line}: the header must be `{expected}`, found {found:?}")]
    Header {
        path: PathBuf,
        line: usize,
        expected: String,
        found: String,
    },
    #[error("{path}: no header `{expected}` (the file has no rows)")]
    NoHeader { path: PathBuf, expected: String },
    #[error("{path}:{line}: {found} fields, expected 9 ({expected})")]
    FieldCount {
        path: PathBuf,
        line: usize,
        found: usize,
        expected: String,
    },
    #[error("{path}:{line}: {field} {text:?} is not a number")]
    NotANumber {
        path: PathBuf,
        line: usize,
        field: &'static str,
        text: String,
    },
    #[error("{path}:{line}: {field} {text:?} is not finite")]
    NotFinite {
        path: PathBuf,
        line: usize,
        field: &'static str,
        text: String,
    },
    #[error("{path}:{line}: the rotation quaternion has zero length")]
    ZeroQuaternion { path: PathBuf, line: usize },
    #[error("{path}:{line}: an empty object name")]
    NoObject { path: PathBuf, line: usize },
    #[error(
        "{path}:{line}: object {object:?} at {time} s: times must increase strictly (the row before is at {previous} s)"
    )]
    TimeOrder {
        path: PathBuf,
        line: usize,
        object: String,
        time: f64,
        previous: f64,
    },
    #[error("{path}: object {object:?} is not a movable object of scene {scene:?}")]
    UnknownObject {
        path: PathBuf,
        object: String,
        scene: String,
    },
}

/// Keyframed placements of objects, by object name.
#[derive(Clone, Debug, Default)]
pub struct ObjectPaths {
    source: PathBuf,
    /// Per object, its keys in strictly increasing time.
    keys: BTreeMap<String, Vec<(f64, Placement)>>,
}

impl ObjectPaths {
    /// Reads a path file's text; `source` names it in errors.
    pub fn parse(text: &str, source: &Path) -> Result<ObjectPaths, PathError> {
        let path = || source.to_path_buf();
        let expected = HEADER.join(",");
        let mut keys: BTreeMap<String, Vec<(f64, Placement)>> = BTreeMap::new();
        let mut header_seen = false;
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let trimmed = raw.trim();
            if trimmed.is_empty() || trimmed.starts_with('#') {
                continue;
            }
            let fields: Vec<&str> = trimmed.split(',').map(str::trim).collect();
            if !header_seen {
                if fields != HEADER {
                    return Err(PathError::Header {
                        path: path(),
                        line,
                        expected,
                        found: trimmed.into(),
                    });
                }
                header_seen = true;
                continue;
            }
            if fields.len() != HEADER.len() {
                return Err(PathError::FieldCount {
                    path: path(),
                    line,
                    found: fields.len(),
                    expected,
                });
            }
            let object = fields[0];
            if object.is_empty() {
                return Err(PathError::NoObject { path: path(), line });
            }
            let number = |k: usize| -> Result<f64, PathError> {
                let text = fields[k];
                let x: f64 = text.parse().map_err(|_| PathError::NotANumber {
                    path: path(),
                    line,
                    field: HEADER[k],
                    text: text.into(),
                })?;
                // Stored as f32 (all but the time): finite there too.
                if !x.is_finite() || (k > 1 && !(x as f32).is_finite()) {
                    return Err(PathError::NotFinite {
                        path: path(),
                        line,
                        field: HEADER[k],
                        text: text.into(),
                    });
                }
                Ok(x)
            };
            let time = number(1)?;
            let v: Vec<f32> = (2..9)
                .map(|k| number(k).map(|x| x as f32))
                .collect::<Result<_, _>>()?;
            let q = Quat::from_xyzw(v[3], v[4], v[5], v[6]);
            let length = q.length();
            if !(length > 0.0 && length.is_finite()) {
                return Err(PathError::ZeroQuaternion { path: path(), line });
            }
            let placement = Placement::new(Vec3::new(v[0], v[1], v[2]), q / length);
            let list = keys.entry(object.to_string()).or_default();
            if let Some(&(previous, _)) = list.last()
                && time <= previous
            {
                return Err(PathError::TimeOrder {
                    path: path(),
                    line,
                    object: object.into(),
                    time,
                    previous,
                });
            }
            list.push((time, placement));
        }
        if !header_seen {
            return Err(PathError::NoHeader {
                path: path(),
                expected,
            });
        }
        Ok(ObjectPaths {
            source: source.into(),
            keys,
        })
    }

    /// Refuses a path for an object the scene does not have.
    pub fn check(&self, scene: &Scene) -> Result<(), PathError> {
        match self.keys.keys().find(|o| scene.object_index(o).is_none()) {
            Some(object) => Err(PathError::UnknownObject {
                path: self.source.clone(),
                object: object.clone(),
                scene: scene.name.clone(),
            }),
            None => Ok(()),
        }
    }

    /// Where `object` stands at time `t` (seconds): its first key before the first, its
    /// last after the last, and between two keys the straight line and the shorter arc;
    /// `None` when the file has no path for it.
    pub fn placement_at(&self, object: &str, t: f64) -> Option<Placement> {
        let keys = self.keys.get(object)?;
        let next = keys.partition_point(|(time, _)| *time <= t);
        Some(if next == 0 {
            keys[0].1
        } else if next == keys.len() {
            keys[next - 1].1
        } else {
            let ((t0, a), (t1, b)) = (keys[next - 1], keys[next]);
            a.lerp(&b, ((t - t0) / (t1 - t0)) as f32)
        })
    }

    /// Every object of `scene` at time `t`, in [`Scene::objects`] order; objects without
    /// a path stand where they were loaded.
    pub fn placements_at(&self, scene: &Scene, t: f64) -> Vec<Placement> {
        scene
            .objects()
            .iter()
            .map(|o| self.placement_at(&o.name, t).unwrap_or(o.rest))
            .collect()
    }
}
