//! The master's session state, kept on disk so that a new master resumes a session whose
//! master died: the last frame sent, where the clock and the replayed tracker were, where
//! the room stood in the scene, where the moving objects stood, and the time of day.
//!
//! `DIR/session.json` is replaced whole for every frame (written beside it, synced, then
//! renamed over it), on a thread of its own while the walls draw; the frame's Swap waits
//! until its state is on disk. So after a crash the file holds a frame at least as new as
//! any frame a wall presented, and a resumed master numbering its frames from the one after
//! never shows a frame number twice.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;

use serde::{Deserialize, Serialize};

/// The state file's name in a session's output folder.
pub const FILE_NAME: &str = "session.json";
/// The version of the state file's layout this master writes and reads.
pub const VERSION: u32 = 1;

/// Which clock a session ran on (a resumed master must run on the same).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum SessionClock {
    Live,
    Replay,
}

impl std::fmt::Display for SessionClock {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SessionClock::Live => "live",
            SessionClock::Replay => "replay",
        })
    }
}

/// A moving object as the last frame placed it.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct SavedObject {
    pub name: String,
    pub position: [f32; 3],
    pub orientation: [f32; 4],
    /// The wand moved it: it no longer follows its path.
    pub off_path: bool,
}

/// Everything a new master needs to go on with a session after its last sent frame.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct SessionState {
    pub version: u32,
    /// The last frame whose state was sent: no wall presented a newer one.
    pub frame: u64,
    /// That frame's time on the master's clock and its display time (ns); a replay's
    /// position in its tracker and input logs is this time after their first sample.
    pub master_ns: u64,
    pub display_ns: u64,
    /// The frame period the session ran at (ns).
    pub period_ns: u64,
    pub clock: SessionClock,
    /// Tracker samples the master that wrote it had read (a replay's: every sample up to
    /// its position).
    pub tracker_samples: u64,
    /// The tracker's first position, which `--recenter` moved to the room's inside point.
    pub recentred_from: Option<[f32; 3]>,
    /// The room → scene transform of that frame (column-major 4×4).
    pub navigation: [f64; 16],
    /// The moving objects' placements at that frame, in the scene's order.
    pub objects: Vec<SavedObject>,
    /// The scene's time of day at the session's start (`--when`), if it has one.
    pub when: Option<String>,
    /// Its time of day at that frame (the start's, stepped by keys or a replayed log).
    #[serde(default)]
    pub time_of_day: Option<String>,
}

/// Why a state file could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    #[error("{}: {error}", path.display())]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{}: not a session state file (truncated or damaged?): {error}", path.display())]
    Parse {
        path: PathBuf,
        error: serde_json::Error,
    },
    #[error("{}: a session state of version {found}; this master reads version {VERSION}", path.display())]
    Version { path: PathBuf, found: u32 },
}

impl SessionState {
    /// Reads `path`; a missing, truncated, damaged or other-version file is an error that
    /// names it and says what is wrong.
    pub fn read(path: &Path) -> Result<SessionState, SessionError> {
        let bytes = std::fs::read(path).map_err(|error| SessionError::Io {
            path: path.to_owned(),
            error,
        })?;
        let parse = |error| SessionError::Parse {
            path: path.to_owned(),
            error,
        };
        #[derive(Deserialize)]
        struct Versioned {
            version: u32,
        }
        let v: Versioned = serde_json::from_slice(&bytes).map_err(parse)?;
        if v.version != VERSION {
            return Err(SessionError::Version {
                path: path.to_owned(),
                found: v.version,
            });
        }
        serde_json::from_slice(&bytes).map_err(parse)
    }

    /// Replaces `path` with this state, crash-safe: written to `path.tmp`, synced, renamed
    /// over `path`, and the folder synced, so `path` is always one whole state.
    pub fn write(&self, path: &Path) -> Result<(), SessionError> {
        let io = |error| SessionError::Io {
            path: path.to_owned(),
            error,
        };
        let tmp = path.with_extension("json.tmp");
        let bytes = serde_json::to_vec_pretty(self).map_err(|e| io(std::io::Error::other(e)))?;
        let mut f = std::fs::File::create(&tmp).map_err(io)?;
        f.write_all(&bytes).map_err(io)?;
        f.sync_all().map_err(io)?;
        std::fs::rename(&tmp, path).map_err(io)?;
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::File::open(dir)
                .and_then(|d| d.sync_all())
                .map_err(io)?;
        }
        Ok(())
    }
}

/// Writes each frame's state on a thread of its own: [`Self::offer`] hands it over when the
/// frame is sent, [`Self::written`] waits until it is on disk, before the frame's Swap.
pub struct StateKeeper {
    path: PathBuf,
    to_writer: Option<Sender<SessionState>>,
    written: Receiver<Result<u64, SessionError>>,
    writer: Option<JoinHandle<()>>,
    /// Frames offered and not yet confirmed.
    pending: usize,
    /// Set after a failed write: the session goes on without its state kept.
    failed: bool,
}

impl StateKeeper {
    /// Keeps the session's state in `path`.
    pub fn start(path: PathBuf) -> std::io::Result<StateKeeper> {
        let (to_writer, rx) = channel::<SessionState>();
        let (tx, written) = channel();
        let p = path.clone();
        let writer = std::thread::Builder::new()
            .name("session state".into())
            .spawn(move || {
                for state in rx {
                    let done = state.write(&p).map(|()| state.frame);
                    if tx.send(done).is_err() {
                        return;
                    }
                }
            })?;
        Ok(StateKeeper {
            path,
            to_writer: Some(to_writer),
            written,
            writer: Some(writer),
            pending: 0,
            failed: false,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Starts writing `state` (its frame was just sent).
    pub fn offer(&mut self, state: SessionState) {
        if self.failed {
            return;
        }
        if let Some(tx) = &self.to_writer
            && tx.send(state).is_ok()
        {
            self.pending += 1;
        }
    }

    /// Waits until every state offered is on disk. A failed write is logged once and the
    /// session goes on without its state kept (the walls matter more than a resume).
    pub fn written(&mut self) {
        while self.pending > 0 {
            self.pending -= 1;
            match self.written.recv() {
                Ok(Ok(_)) => {}
                Ok(Err(e)) => self.fail(&e.to_string()),
                Err(_) => self.fail("the writer stopped"),
            }
        }
    }

    fn fail(&mut self, why: &str) {
        if !self.failed {
            tracing::error!(
                "the session's state is no longer kept ({why}); a new master cannot resume \
                 this session past this frame"
            );
        }
        self.failed = true;
        self.pending = 0;
    }
}

impl Drop for StateKeeper {
    fn drop(&mut self) {
        self.to_writer = None;
        if let Some(w) = self.writer.take() {
            let _ = w.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(frame: u64) -> SessionState {
        SessionState {
            version: VERSION,
            frame,
            master_ns: frame * 50_000_000,
            display_ns: frame * 50_000_000 + 50_000_000,
            period_ns: 50_000_000,
            clock: SessionClock::Replay,
            tracker_samples: 3 * frame,
            recentred_from: Some([0.1, 1.6, 0.2]),
            navigation: glam::DMat4::from_translation(glam::DVec3::new(1.0, 0.0, -2.5))
                .to_cols_array(),
            objects: vec![SavedObject {
                name: "block".into(),
                position: [0.5, 0.0, 0.25],
                orientation: [0.0, 0.6, 0.0, 0.8],
                off_path: true,
            }],
            when: Some("2026-06-21T12:00".into()),
            time_of_day: Some("2026-06-21T13:15".into()),
        }
    }

    /// What the keeper wrote reads back equal, the newest frame's, with no temporary file
    /// left beside it.
    #[test]
    fn the_kept_state_reads_back_as_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(FILE_NAME);
        let mut keeper = StateKeeper::start(path.clone()).unwrap();
        for frame in 0..5 {
            keeper.offer(state(frame));
            keeper.written();
        }
        drop(keeper);
        assert_eq!(SessionState::read(&path).unwrap(), state(4));
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, [FILE_NAME]);
    }

    /// A missing, truncated, garbled or other-version file is an error naming the file and
    /// the problem.
    #[test]
    fn a_bad_state_file_is_named_and_explained() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(FILE_NAME);
        let e = SessionState::read(&path).unwrap_err().to_string();
        assert!(e.contains(FILE_NAME) && e.contains("No such file"), "{e}");
        state(7).write(&path).unwrap();
        let whole = std::fs::read(&path).unwrap();
        std::fs::write(&path, &whole[..whole.len() / 2]).unwrap();
        let e = SessionState::read(&path).unwrap_err().to_string();
        assert!(e.contains(FILE_NAME) && e.contains("truncated"), "{e}");
        std::fs::write(&path, b"\x00\xffgarbage").unwrap();
        let e = SessionState::read(&path).unwrap_err().to_string();
        assert!(e.contains("not a session state file"), "{e}");
        let other = String::from_utf8(whole).unwrap().replacen(
            &format!("\"version\": {VERSION}"),
            "\"version\": 99",
            1,
        );
        std::fs::write(&path, other).unwrap();
        let e = SessionState::read(&path).unwrap_err().to_string();
        assert!(e.contains("version 99"), "{e}");
    }
}
