//! A light field for any time of a day or a season from bakes made ahead: a **bake set** is
//! a folder of `.vlf` files of one scene at the same settings, each baked for its own time
//! (`holocave vlf bake --when T`) and named by it, `YYYY-MM-DDTHH-MM.vlf` (local standard
//! time). The field of a time between two of them is their blend by time ([`blend`]): the
//! field is linear in the sun and sky that lit it, so the blend is the field of the two
//! hours' light mixed — the sun's patches half here and half there, not the sun between
//! them. Its error against a bake at the exact time: `docs/performance/vlf.md`.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use chrono::{NaiveDateTime, Timelike};

use crate::bake::State;
use crate::baked::{Blended, Opened};
use crate::file::VlfFile;

/// The file-name form of a bake's time.
const NAME_FORMAT: &str = "%Y-%m-%dT%H-%M";

/// The file name of the bake of `time` in a set.
pub fn file_name(time: NaiveDateTime) -> String {
    format!("{}.vlf", time.format(NAME_FORMAT))
}

/// The times of a set from `first` to `last` (both included when `last` is on the step),
/// `step_minutes` apart. Error: a first time with seconds (a set's files are named to the
/// minute, and each is opened at the time its name says).
pub fn times(
    first: NaiveDateTime,
    last: NaiveDateTime,
    step_minutes: u32,
) -> Result<Vec<NaiveDateTime>, String> {
    if first.second() != 0 || first.nanosecond() != 0 {
        return Err(format!(
            "a bake set's times are whole minutes: {first} has seconds"
        ));
    }
    let step = chrono::Duration::minutes(i64::from(step_minutes.max(1)));
    Ok(std::iter::successors(Some(first), |t| Some(*t + step))
        .take_while(|t| *t <= last)
        .collect())
}

/// One machine's share of a set's bakes, `K/N`: the K-th of every N times (1-based), so
/// N machines running the same command with shares 1/N … N/N bake the set between them,
/// each time once, into folders that together make the set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Share {
    pub k: u32,
    pub n: u32,
}

impl std::str::FromStr for Share {
    type Err = String;

    fn from_str(s: &str) -> Result<Share, String> {
        let bad = || format!("share {s:?}: write K/N, with 1 ≤ K ≤ N (this machine's part of N)");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (k, n): (u32, u32) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if k == 0 || k > n {
            return Err(bad());
        }
        Ok(Share { k, n })
    }
}

impl Share {
    /// The times of `times` that are this share's.
    pub fn of(&self, times: &[NaiveDateTime]) -> Vec<NaiveDateTime> {
        (times.iter().enumerate())
            .filter(|(i, _)| *i as u32 % self.n == self.k - 1)
            .map(|(_, t)| *t)
            .collect()
    }
}

/// A folder of bakes, each at its time, in time order.
#[derive(Clone, Debug)]
pub struct BakeSet {
    pub dir: PathBuf,
    pub bakes: Vec<(NaiveDateTime, PathBuf)>,
}

/// The two bakes around a time and the weight of the later one.
#[derive(Clone, Debug, PartialEq)]
pub struct Bracket {
    pub before: (NaiveDateTime, PathBuf),
    pub after: (NaiveDateTime, PathBuf),
    /// 0 at `before`'s time, 1 at `after`'s.
    pub t: f32,
}

impl BakeSet {
    /// The set in `dir`: every `.vlf` file, named by its time (a `.vlf` file named
    /// otherwise is an error naming it, so a misnamed bake is not silently left out; other
    /// files are passed over).
    pub fn read(dir: &Path) -> Result<BakeSet, String> {
        let entries = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let mut bakes = Vec::new();
        for e in entries {
            let path = e.map_err(|e| format!("{}: {e}", dir.display()))?.path();
            if path.extension().is_none_or(|x| x != "vlf") {
                continue;
            }
            let stem = path.file_stem().unwrap_or_default().to_string_lossy();
            let time = NaiveDateTime::parse_from_str(&stem, NAME_FORMAT).map_err(|_| {
                format!(
                    "{}: a bake set's file is named by its time, YYYY-MM-DDTHH-MM.vlf",
                    path.display()
                )
            })?;
            bakes.push((time, path));
        }
        bakes.sort();
        if bakes.is_empty() {
            return Err(format!(
                "{}: no bakes (YYYY-MM-DDTHH-MM.vlf) in it",
                dir.display()
            ));
        }
        Ok(BakeSet {
            dir: dir.to_owned(),
            bakes,
        })
    }

    /// The first bake after `time`, if any: the one a step forward from `time` needs
    /// next (a node reads it ahead).
    pub fn next_after(&self, time: NaiveDateTime) -> Option<&(NaiveDateTime, PathBuf)> {
        self.bakes.iter().find(|(t, _)| *t > time)
    }

    /// The bakes around `time` (the same bake twice at a baked time). Error: a time
    /// outside the set's.
    pub fn bracket(&self, time: NaiveDateTime) -> Result<Bracket, String> {
        let (Some(first), Some(last)) = (self.bakes.first(), self.bakes.last()) else {
            return Err(format!("{}: no bakes in the set", self.dir.display()));
        };
        if time < first.0 || time > last.0 {
            return Err(format!(
                "{} holds bakes from {} to {}: {time} is outside",
                self.dir.display(),
                first.0,
                last.0
            ));
        }
        let after = self.bakes.partition_point(|(t, _)| *t < time);
        let after = &self.bakes[after];
        let before = self
            .bakes
            .iter()
            .rev()
            .find(|(t, _)| *t <= time)
            .unwrap_or(after);
        let span = (after.0 - before.0).num_seconds();
        let t = if span == 0 {
            0.0
        } else {
            (time - before.0).num_seconds() as f32 / span as f32
        };
        Ok(Bracket {
            before: before.clone(),
            after: after.clone(),
            t,
        })
    }
}

/// `a` and `b` mixed, `(1 − t) a + t b`, every part of the field alike. Error: states of
/// different layouts (another scene's geometry or other settings), naming the part.
pub fn blend(a: &State, b: &State, t: f32) -> Result<State, String> {
    let mix = |name: &str, x: &[[f32; 3]], y: &[[f32; 3]]| {
        if x.len() != y.len() {
            return Err(format!(
                "the bakes' {name} differ in size ({} and {}): not the same scene and settings",
                x.len(),
                y.len()
            ));
        }
        Ok(mix(x, y, t))
    };
    Ok(State {
        bounces: a.bounces.max(b.bounces),
        irradiance: mix("elements", &a.irradiance, &b.irradiance)?,
        last: mix("last bounces", &a.last, &b.last)?,
        tiles: mix("tiles", &a.tiles, &b.tiles)?,
        tiles_last: mix("tiles' last bounces", &a.tiles_last, &b.tiles_last)?,
        direct: mix("direct parts", &a.direct, &b.direct)?,
        tiles_direct: mix("tiles' direct parts", &a.tiles_direct, &b.tiles_direct)?,
        sky: mix("sky parts", &a.sky, &b.sky)?,
        tiles_sky: mix("tiles' sky parts", &a.tiles_sky, &b.tiles_sky)?,
        caustics: mix("caustics", &a.caustics, &b.caustics)?,
        arrived: f64::from(1.0 - t) * a.arrived + f64::from(t) * b.arrived,
        residuals: if t < 0.5 {
            a.residuals.clone()
        } else {
            b.residuals.clone()
        },
        converged: a.converged && b.converged,
    })
}

/// `(1 − t)·x + t·y`, value by value (of two arrays of one layout).
pub fn mix(x: &[[f32; 3]], y: &[[f32; 3]], t: f32) -> Vec<[f32; 3]> {
    (x.iter().zip(y))
        .map(|(p, q)| std::array::from_fn(|i| (1.0 - t) * p[i] + t * q[i]))
        .collect()
}

/// Two opened bakes of a set mixed as [`blend`] mixes their states; `before`'s layout
/// (its elements and tiles: the same geometry and settings) is kept, and both bakes are
/// kept beside the blend ([`Blended`]), shared, not copied.
pub fn blend_opened(before: Arc<Opened>, after: Arc<Opened>, t: f32) -> Result<Opened, String> {
    let state = blend(&before.file.state, &after.file.state, t)?;
    let f = &before.file;
    let file = VlfFile {
        scene: f.scene.clone(),
        fingerprint: f.fingerprint,
        settings: f.settings,
        element_size: f.element_size,
        state,
    };
    Ok(Opened {
        file,
        elements: before.elements.clone(),
        tiles: before.tiles.clone(),
        blended: Some(Arc::new(Blended { before, after, t })),
    })
}

/// The field of `time` from the set in `dir`: the two bakes around it, each opened by
/// `open_at` (given a bake's time and path: opened with the scene lit for that time, which
/// its fingerprint was taken of), blended. Returns it with the
/// bracket it was blended from.
pub fn open_blended(
    dir: &Path,
    time: NaiveDateTime,
    open_at: impl Fn(NaiveDateTime, &Path) -> Result<Arc<Opened>, String>,
) -> Result<(Opened, Bracket), String> {
    let set = BakeSet::read(dir)?;
    let bracket = set.bracket(time)?;
    let before = open_at(bracket.before.0, &bracket.before.1)?;
    let blended = if bracket.after == bracket.before {
        Arc::unwrap_or_clone(before)
    } else {
        let after = open_at(bracket.after.0, &bracket.after.1)?;
        blend_opened(before, after, bracket.t)?
    };
    Ok((blended, bracket))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(v: f32, n: usize) -> State {
        State {
            bounces: 3,
            irradiance: vec![[v, 2.0 * v, 0.0]; n],
            last: vec![[v; 3]; n],
            tiles: vec![[v; 3]; 2],
            tiles_last: vec![[v; 3]; 2],
            direct: vec![[v; 3]; n],
            tiles_direct: vec![[v; 3]; 2],
            sky: vec![[v; 3]; n],
            tiles_sky: vec![[v; 3]; 2],
            caustics: Vec::new(),
            arrived: f64::from(v),
            residuals: vec![0.1],
            converged: true,
        }
    }

    #[test]
    fn a_blend_is_each_end_at_its_time_and_linear_between() {
        let (a, b) = (state(1.0, 4), state(3.0, 4));
        assert_eq!(blend(&a, &b, 0.0).unwrap().irradiance, a.irradiance);
        assert_eq!(blend(&a, &b, 1.0).unwrap().tiles_sky, b.tiles_sky);
        let mid = blend(&a, &b, 0.25).unwrap();
        assert_eq!(mid.irradiance[0], [1.5, 3.0, 0.0]);
        assert_eq!(mid.arrived, 1.5);
        let e = blend(&a, &state(1.0, 5), 0.5).unwrap_err();
        assert!(e.contains("elements") && e.contains("4 and 5"), "{e}");
    }

    #[test]
    fn a_sets_times_step_from_the_first_to_the_last() {
        let at = |s: &str| NaiveDateTime::parse_from_str(s, "%Y-%m-%dT%H:%M").unwrap();
        let t = times(at("2026-06-21T06:00"), at("2026-06-21T07:30"), 45).unwrap();
        assert_eq!(
            t,
            [
                at("2026-06-21T06:00"),
                at("2026-06-21T06:45"),
                at("2026-06-21T07:30")
            ]
        );
        let hour = times(at("2026-06-21T06:00"), at("2026-06-21T06:59"), 60).unwrap();
        assert_eq!(hour.len(), 1);
        let seconds = at("2026-06-21T06:00") + chrono::Duration::seconds(30);
        let e = times(seconds, at("2026-06-21T07:00"), 60).unwrap_err();
        assert!(e.contains("seconds"), "{e}");
    }

    #[test]
    fn shares_split_a_sets_times_each_to_one_machine() {
        let at = |s: &str| NaiveDateTime::parse_from_str(s, "%Y-%m-%dT%H:%M").unwrap();
        let day = times(at("2026-06-21T06:00"), at("2026-06-21T12:00"), 60).unwrap();
        let shares: Vec<Vec<NaiveDateTime>> = (1..=3)
            .map(|k| format!("{k}/3").parse::<Share>().unwrap().of(&day))
            .collect();
        assert_eq!(shares.iter().map(Vec::len).collect::<Vec<_>>(), [3, 2, 2]);
        let mut all: Vec<NaiveDateTime> = shares.concat();
        all.sort();
        assert_eq!(all, day);
        assert_eq!("1/1".parse::<Share>().unwrap().of(&day), day);
        for bad in ["0/3", "4/3", "3", "a/b", "1/0"] {
            let e = bad.parse::<Share>().unwrap_err();
            assert!(e.contains(bad) && e.contains("K/N"), "{e}");
        }
    }

    #[test]
    fn a_time_is_bracketed_by_the_bakes_around_it() {
        let dir = tempfile::tempdir().unwrap();
        for t in ["2026-06-21T10-00", "2026-06-21T11-00", "2026-06-21T09-00"] {
            std::fs::write(dir.path().join(format!("{t}.vlf")), b"").unwrap();
        }
        std::fs::write(dir.path().join("notes.txt"), b"").unwrap();
        let set = BakeSet::read(dir.path()).unwrap();
        let at = |s: &str| NaiveDateTime::parse_from_str(s, "%Y-%m-%dT%H:%M").unwrap();
        let b = set.bracket(at("2026-06-21T10:15")).unwrap();
        assert_eq!(
            (b.before.0, b.after.0, b.t),
            (at("2026-06-21T10:00"), at("2026-06-21T11:00"), 0.25)
        );
        let b = set.bracket(at("2026-06-21T11:00")).unwrap();
        assert_eq!(
            (b.before.0, b.after.0, b.t),
            (at("2026-06-21T11:00"), at("2026-06-21T11:00"), 0.0)
        );
        assert!(
            set.bracket(at("2026-06-21T08:59"))
                .unwrap_err()
                .contains("outside")
        );
        // The bake a step forward needs next: after a baked time, the following one.
        let next = |s: &str| set.next_after(at(s)).map(|b| b.0);
        assert_eq!(next("2026-06-21T10:00"), Some(at("2026-06-21T11:00")));
        assert_eq!(next("2026-06-21T09:30"), Some(at("2026-06-21T10:00")));
        assert_eq!(next("2026-06-21T11:00"), None);
        std::fs::write(dir.path().join("noon.vlf"), b"").unwrap();
        assert!(BakeSet::read(dir.path()).unwrap_err().contains("noon.vlf"));
    }
}
