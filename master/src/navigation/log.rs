//! `navigation.csv`: the room → scene transform each frame used, one row per frame:
//! `frame,time_ns,tx,ty,tz,qx,qy,qz,qw` (time on the master's clock; translation in scene
//! metres; rotation a unit quaternion). Numbers are written in their shortest exact form,
//! so equal transforms give equal files.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::placement::Placement;

/// The file's header line.
pub const HEADER: &str = "frame,time_ns,tx,ty,tz,qx,qy,qz,qw";
/// Its name in an output folder.
pub const FILE_NAME: &str = "navigation.csv";

/// Writes `navigation.csv`.
pub struct NavigationLog {
    out: BufWriter<std::fs::File>,
    path: PathBuf,
}

impl NavigationLog {
    pub fn create(path: &Path) -> std::io::Result<NavigationLog> {
        let mut out = BufWriter::new(std::fs::File::create(path)?);
        writeln!(out, "{HEADER}")?;
        Ok(NavigationLog {
            out,
            path: path.to_owned(),
        })
    }

    /// Opens `path` to go on with it (a resumed session): a last row that a killed master
    /// left half-written is cut off first, and a missing or empty file gets its header.
    pub fn append(path: &Path) -> std::io::Result<NavigationLog> {
        let text = match std::fs::read(path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
            Err(e) => return Err(e),
        };
        let whole = text.iter().rposition(|&b| b == b'\n').map_or(0, |k| k + 1);
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)?;
        file.set_len(whole as u64)?;
        let mut out = BufWriter::new(file);
        if whole == 0 {
            writeln!(out, "{HEADER}")?;
        }
        Ok(NavigationLog {
            out,
            path: path.to_owned(),
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn row(&mut self, frame: u64, time_ns: u64, p: &Placement) -> std::io::Result<()> {
        let (t, q) = (p.translation, p.rotation);
        writeln!(
            self.out,
            "{frame},{time_ns},{},{},{},{},{},{},{}",
            t.x, t.y, t.z, q.x, q.y, q.z, q.w
        )
    }

    pub fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// One row read back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    pub frame: u64,
    pub time_ns: u64,
    pub translation: [f64; 3],
    pub rotation: [f64; 4],
}

/// Reads a `navigation.csv`; a bad row is an error naming its line.
pub fn read(text: &str) -> Result<Vec<Row>, String> {
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, h)) if h == HEADER => {}
        other => {
            return Err(format!(
                "line 1: expected the header `{HEADER}`, got {other:?}"
            ));
        }
    }
    lines
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            let f: Vec<&str> = l.split(',').collect();
            let bad = || format!("line {}: `{l}` is not a navigation row", i + 1);
            if f.len() != 9 {
                return Err(bad());
            }
            let n = |k: usize| f[k].parse::<f64>().map_err(|_| bad());
            Ok(Row {
                frame: f[0].parse().map_err(|_| bad())?,
                time_ns: f[1].parse().map_err(|_| bad())?,
                translation: [n(2)?, n(3)?, n(4)?],
                rotation: [n(5)?, n(6)?, n(7)?, n(8)?],
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat4, DVec3};

    /// A resumed session's log goes on after the rows a killed master wrote whole; the
    /// row it left half-written is cut off, and the file reads back row by row.
    #[test]
    fn a_resumed_log_cuts_the_half_written_row_and_goes_on() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(FILE_NAME);
        let place = Placement::from_mat4(&DMat4::from_translation(DVec3::new(1.0, 0.0, -2.0)));
        let mut log = NavigationLog::create(&path).unwrap();
        for frame in 0..3 {
            log.row(frame, frame * 50, &place).unwrap();
        }
        log.flush().unwrap();
        drop(log);
        let mut text = std::fs::read_to_string(&path).unwrap();
        text.push_str("3,150,1,0,-");
        std::fs::write(&path, text).unwrap();
        let mut log = NavigationLog::append(&path).unwrap();
        log.row(4, 200, &place).unwrap();
        log.flush().unwrap();
        let rows = read(&std::fs::read_to_string(&path).unwrap()).unwrap();
        let frames: Vec<u64> = rows.iter().map(|r| r.frame).collect();
        assert_eq!(frames, [0, 1, 2, 4]);
        assert_eq!(rows[3].translation, [1.0, 0.0, -2.0]);
        let fresh = dir.path().join("missing.csv");
        NavigationLog::append(&fresh).unwrap().flush().unwrap();
        assert_eq!(
            std::fs::read_to_string(&fresh).unwrap(),
            format!("{HEADER}\n")
        );
    }
}
