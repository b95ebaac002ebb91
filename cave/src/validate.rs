//! Checking a CAVE file and turning it into the geometry the master uses. Every problem is
//! reported (not just the first), each naming its field (`wall[1].pc`, `user.ipd`, ...)
//! and, for geometry, by how much it is off.

use std::path::Path;

use glam::{DMat4, DQuat, DVec3};
use holocave_tracking::params::TrackingParams;
use holocave_tracking::source::SourceSpec;

use crate::config::{CaveFile, ClusterConfig, RigidTransform, StereoMode};
use crate::size::Size;

/// Closest an eye may come to a wall's plane (m) before its frustum is a fault, and the
/// margin (×10) the room's inside point must keep from every wall.
pub const MIN_EYE_DISTANCE: f64 = 1e-3;

/// How far (m) `pc` may sit off the perpendicular to `pa→pb` at `pa` for the corners to
/// count as a rectangle.
pub const RECTANGLE_TOLERANCE: f64 = 1e-3;

/// A CAVE file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("cannot read CAVE config {path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("CAVE config {path} is not valid TOML for a CAVE: {message}")]
    Parse { path: String, message: String },
    #[error("CAVE config {path} is invalid:\n  {}", problems.join("\n  "))]
    Invalid { path: String, problems: Vec<String> },
}

/// A checked wall with its screen basis.
#[derive(Clone, Debug, PartialEq)]
pub struct Wall {
    pub name: String,
    pub pa: DVec3,
    pub pb: DVec3,
    pub pc: DVec3,
    /// Unit vectors right (pa→pb), up (pa→pc) and normal (toward the viewer).
    pub right: DVec3,
    pub up: DVec3,
    pub normal: DVec3,
    pub width: f64,
    pub height: f64,
    pub pixels: Size,
    pub stereo: StereoMode,
    pub node: String,
    /// Where and how the wall is shown when its node opens windows.
    pub windows: Vec<crate::window::WindowSettings>,
}

impl Wall {
    /// A wall from its corners `[pa, pb, pc]` (lower-left, lower-right, upper-left as seen
    /// from the room), which must span a rectangle of non-zero size (a config is checked
    /// for that by [`validate`]); `up` is made exactly perpendicular to `right`.
    pub fn new(
        name: &str,
        [pa, pb, pc]: [DVec3; 3],
        pixels: Size,
        stereo: StereoMode,
        node: &str,
    ) -> Wall {
        let width = (pb - pa).length();
        let right = (pb - pa) / width;
        let up = (pc - pa - right * (pc - pa).dot(right)).normalize();
        Wall {
            name: name.to_owned(),
            pa,
            pb,
            pc,
            right,
            up,
            normal: right.cross(up),
            width,
            height: (pc - pa).length(),
            pixels,
            stereo,
            node: node.to_owned(),
            windows: vec![crate::window::WindowSettings::for_stereo(stereo)],
        }
    }

    /// Signed distance of `p` from the wall's plane, positive in front (the room side).
    pub fn distance(&self, p: DVec3) -> f64 {
        (p - self.pa).dot(self.normal)
    }

    /// The upper-right corner.
    pub fn pd(&self) -> DVec3 {
        self.pb + self.pc - self.pa
    }
}

/// A checked CAVE.
#[derive(Clone, Debug)]
pub struct Cave {
    pub walls: Vec<Wall>,
    pub inside: DVec3,
    pub near: f64,
    pub ipd: f64,
    pub head_to_eyes: DVec3,
    pub source: SourceSpec,
    pub tracker_to_room: DMat4,
    /// Room → scene at the start (the config's `[navigation]` transform).
    pub room_to_scene: DMat4,
    /// How the user travels from there.
    pub navigation: crate::navigation::Navigation,
    pub tracking: TrackingParams,
    pub cluster: ClusterConfig,
}

/// The highest frame rate the master's clock runs at (Hz).
pub const MAX_RATE_HZ: f64 = 1000.0;

/// A frame rate in (0, [`MAX_RATE_HZ`]].
fn check_rate(hz: f64) -> Result<(), String> {
    if hz > 0.0 && hz <= MAX_RATE_HZ {
        Ok(())
    } else {
        Err(format!("{hz} is not a frame rate (0 to {MAX_RATE_HZ} Hz)"))
    }
}

/// A dead-node timeout in (0, 10 000] ms.
fn check_dead_node_ms(ms: f64) -> Result<(), String> {
    if ms > 0.0 && ms <= 10_000.0 {
        Ok(())
    } else {
        Err(format!("{ms} must be positive and at most 10 s"))
    }
}

impl Cave {
    /// The place in the config of the wall named `name`, or an error naming the walls there
    /// are.
    pub fn wall_index(&self, name: &str) -> Result<usize, String> {
        self.walls
            .iter()
            .position(|w| w.name == name)
            .ok_or_else(|| {
                let names: Vec<&str> = self.walls.iter().map(|w| w.name.as_str()).collect();
                format!("no wall {name:?} (walls: {})", names.join(", "))
            })
    }

    /// Declares a node out after `ms` milliseconds instead of the config's timeout.
    pub fn set_dead_node_ms(&mut self, ms: f64) -> Result<(), String> {
        check_dead_node_ms(ms)?;
        self.cluster.dead_node_ms = ms;
        Ok(())
    }

    /// Runs the master's clock at `hz` instead of the config's rate.
    pub fn set_rate(&mut self, hz: f64) -> Result<(), String> {
        check_rate(hz)?;
        self.cluster.rate_hz = hz;
        Ok(())
    }

    /// Scales the room by `scale` in the scene and moves it by `offset` (scene metres):
    /// `room_to_scene` becomes `offset + scale × room_to_scene` (for stress tests of
    /// numerical range, with the scene scaled and moved the same way).
    pub fn place_in_scene(&mut self, scale: f64, offset: DVec3) {
        self.room_to_scene = DMat4::from_translation(offset)
            * DMat4::from_scale(DVec3::splat(scale))
            * self.room_to_scene;
    }

    /// The frame period of the master's clock.
    pub fn frame_period(&self) -> std::time::Duration {
        std::time::Duration::from_secs_f64(1.0 / self.cluster.rate_hz)
    }

    /// How long the swap barrier waits for a node before declaring it out.
    pub fn dead_node_timeout(&self) -> std::time::Duration {
        std::time::Duration::from_secs_f64(self.cluster.dead_node_ms / 1e3)
    }

    /// The shared secret (`HOLOCAVE_SECRET` overrides the config's); an error naming the
    /// field when there is none.
    pub fn secret(&self) -> Result<Vec<u8>, String> {
        let s = std::env::var("HOLOCAVE_SECRET").unwrap_or_else(|_| self.cluster.secret.clone());
        if s.is_empty() {
            return Err(
                "cluster.secret: empty; a cluster needs a shared secret (or set HOLOCAVE_SECRET)"
                    .to_owned(),
            );
        }
        Ok(s.into_bytes())
    }
}

/// Reads and checks a CAVE file.
pub fn load_cave(path: &Path) -> Result<Cave, ConfigError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
        path: name.clone(),
        source,
    })?;
    parse_cave(&text, &name)
}

/// Parses and checks CAVE TOML; `name` names the input in messages.
pub fn parse_cave(text: &str, name: &str) -> Result<Cave, ConfigError> {
    let file: CaveFile = toml::from_str(text).map_err(|e| ConfigError::Parse {
        path: name.to_owned(),
        message: e.to_string(),
    })?;
    validate(&file).map_err(|problems| ConfigError::Invalid {
        path: name.to_owned(),
        problems,
    })
}

fn vec(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}

fn transform(t: &RigidTransform, field: &str, problems: &mut Vec<String>) -> DMat4 {
    let q = DQuat::from_array(t.rotation);
    let norm = q.length();
    if !(norm - 1.0).abs().le(&1e-3) {
        problems.push(format!(
            "{field}.rotation: quaternion norm is {norm}, not 1"
        ));
        return DMat4::IDENTITY;
    }
    if !t.translation.iter().all(|v| v.is_finite()) {
        problems.push(format!("{field}.translation: not finite"));
        return DMat4::IDENTITY;
    }
    DMat4::from_rotation_translation(q / norm, vec(t.translation))
}

/// Checks a parsed file; the problems found, each naming its field.
pub fn validate(file: &CaveFile) -> Result<Cave, Vec<String>> {
    let mut problems = Vec::new();
    let inside = vec(file.room.inside);
    check_room_and_user(file, inside, &mut problems);
    if file.walls.is_empty() {
        problems.push("wall: no walls given".to_owned());
    }
    let walls: Vec<Wall> = (0..file.walls.len())
        .filter_map(|i| check_wall(file, i, inside, &mut problems))
        .collect();
    let source = tracking_source(file, &mut problems);
    let tracker_to_room = transform(
        &file.tracking.tracker_to_room,
        "tracking.tracker_to_room",
        &mut problems,
    );
    let room_to_scene = transform(&file.navigation.start(), "navigation", &mut problems);
    let navigation = crate::navigation::check(&file.navigation, &mut problems);
    check_cluster(&file.cluster, &mut problems);
    if !problems.is_empty() {
        return Err(problems);
    }
    Ok(Cave {
        walls,
        inside,
        near: file.room.near,
        ipd: file.user.ipd,
        head_to_eyes: vec(file.user.head_to_eyes),
        source,
        tracker_to_room,
        room_to_scene,
        navigation,
        tracking: TrackingParams {
            guard: file.tracking.guard,
            filter: file.tracking.filter,
            prediction: file.tracking.prediction,
        },
        cluster: file.cluster.clone(),
    })
}

/// The room's inside point and near plane, and the user's eyes.
fn check_room_and_user(file: &CaveFile, inside: DVec3, problems: &mut Vec<String>) {
    if !inside.is_finite() {
        problems.push("room.inside: not finite".to_owned());
    }
    if !(file.room.near > 0.0 && file.room.near.is_finite()) {
        problems.push(format!(
            "room.near: {} must be a positive distance",
            file.room.near
        ));
    }
    if !(file.user.ipd >= 0.0 && file.user.ipd < 0.5) {
        problems.push(format!(
            "user.ipd: {} m is not an interpupillary distance (0 to 0.5 m)",
            file.user.ipd
        ));
    }
    if !vec(file.user.head_to_eyes).is_finite() {
        problems.push("user.head_to_eyes: not finite".to_owned());
    }
}

/// Wall `i` of `file`, checked: a unique name, finite corners of a rectangle of some size,
/// positive pixel counts, its windows, and facing the room's `inside` point from far
/// enough. `None` where its corners make no wall (the problems say why).
fn check_wall(
    file: &CaveFile,
    i: usize,
    inside: DVec3,
    problems: &mut Vec<String>,
) -> Option<Wall> {
    let w = &file.walls[i];
    let at = format!("wall[{i}] ({:?})", w.name);
    if file.walls[..i].iter().any(|o| o.name == w.name) {
        problems.push(format!("{at}.name: duplicate wall name {:?}", w.name));
    }
    let (pa, pb, pc) = (vec(w.pa), vec(w.pb), vec(w.pc));
    if !(pa.is_finite() && pb.is_finite() && pc.is_finite()) {
        problems.push(format!("{at}: corners must be finite"));
        return None;
    }
    let (width, height) = ((pb - pa).length(), (pc - pa).length());
    if width < 1e-6 {
        problems.push(format!("{at}.pb: wall has zero width (pb equals pa)"));
    }
    if height < 1e-6 {
        problems.push(format!("{at}.pc: wall has zero height (pc equals pa)"));
    }
    for (k, (px, what)) in w.pixels.iter().zip(["width", "height"]).enumerate() {
        if *px <= 0 || *px > u32::MAX as i64 {
            problems.push(format!(
                "{at}.pixels[{k}]: pixel {what} {px} must be positive"
            ));
        }
    }
    if width < 1e-6 || height < 1e-6 {
        return None;
    }
    let right = (pb - pa) / width;
    let off_square = (pc - pa).dot(right);
    if off_square.abs() > RECTANGLE_TOLERANCE {
        problems.push(format!(
            "{at}.pc: corners are not a rectangle: pc is {:.1} mm off the perpendicular to pa→pb at pa (tolerance {:.1} mm)",
            off_square * 1e3,
            RECTANGLE_TOLERANCE * 1e3
        ));
        return None;
    }
    let mut wall = Wall::new(
        &w.name,
        [pa, pb, pc],
        Size::new(w.pixels[0].max(0) as u32, w.pixels[1].max(0) as u32),
        w.stereo,
        &w.node,
    );
    wall.windows = crate::window::check_windows(&at, w.stereo, &w.windows, problems);
    let d = wall.distance(inside);
    if d <= 0.0 {
        problems.push(format!(
            "{at}: its normal (pb−pa)×(pc−pa) = ({:.3}, {:.3}, {:.3}) points away from the room's inside point room.inside; are pa, pb, pc (lower-left, lower-right, upper-left as seen from inside) in the right order?",
            wall.normal.x, wall.normal.y, wall.normal.z
        ));
    } else if d < MIN_EYE_DISTANCE * 10.0 {
        problems.push(format!(
            "room.inside: only {:.1} mm in front of wall {:?}",
            d * 1e3,
            w.name
        ));
    }
    Some(wall)
}

/// The tracker's source, with `tracking.sensor` as a VRPN source's sensor (a sensor the
/// source names itself must agree with it).
fn tracking_source(file: &CaveFile, problems: &mut Vec<String>) -> SourceSpec {
    let source = file
        .tracking
        .source
        .parse::<SourceSpec>()
        .unwrap_or_else(|e| {
            problems.push(format!("tracking.source: {e}"));
            SourceSpec::Synthetic(holocave_tracking::synthetic::Motion::Still)
        });
    match source {
        SourceSpec::Vrpn(mut t) => {
            if file.tracking.source.contains('#') && t.sensor != file.tracking.sensor {
                problems.push(format!(
                    "tracking.sensor: {} disagrees with sensor #{} in tracking.source",
                    file.tracking.sensor, t.sensor
                ));
            }
            t.sensor = file.tracking.sensor;
            SourceSpec::Vrpn(t)
        }
        other => other,
    }
}

/// The cluster's rate, dead-node timeout and master address.
fn check_cluster(c: &ClusterConfig, problems: &mut Vec<String>) {
    if let Err(e) = check_rate(c.rate_hz) {
        problems.push(format!("cluster.rate_hz: {e}"));
    }
    if let Err(e) = check_dead_node_ms(c.dead_node_ms) {
        problems.push(format!("cluster.dead_node_ms: {e}"));
    }
    if c.master.parse::<std::net::SocketAddr>().is_err() && !c.master.contains(':') {
        problems.push(format!("cluster.master: {:?} is not HOST:PORT", c.master));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(name: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../configs")
            .join(name)
    }

    #[test]
    fn shipped_configs_are_valid() {
        let cave = load_cave(&config("cave4.toml")).unwrap();
        let names: Vec<&str> = cave.walls.iter().map(|w| w.name.as_str()).collect();
        assert_eq!(names, ["front", "left", "right", "floor"]);
        for w in &cave.walls {
            assert!(
                (w.width - 3.0).abs() < 1e-12 && (w.height - 3.0).abs() < 1e-12,
                "{}",
                w.name
            );
            assert!(w.distance(DVec3::new(0.0, 1.5, 0.0)) > 1.4);
        }
        assert_eq!(cave.walls[0].pixels, Size::new(1024, 768));
        assert_eq!(cave.walls[3].pixels, Size::new(1024, 1024));
        assert_eq!(cave.walls[0].normal, DVec3::Z);
        assert_eq!(cave.walls[3].normal, DVec3::Y);
        assert_eq!(cave.ipd, 0.064);
        assert_eq!(
            cave.tracking,
            TrackingParams::default(),
            "the config carries the tuned defaults"
        );
        // The windows: a squeezed side-by-side projector, a rear-projected wall, and
        // passive stereo with a projector per eye.
        use crate::window::{Fullscreen, Layout, Monitor};
        let front = &cave.walls[0].windows;
        assert_eq!(front.len(), 1);
        assert_eq!(front[0].layout, Layout::SideBySide);
        assert!(front[0].squeezed);
        assert_eq!(front[0].fullscreen, Fullscreen::Borderless);
        assert_eq!(
            front[0].window_size(Size::new(1024, 768)),
            Size::new(1024, 768)
        );
        assert!(cave.walls[2].windows[0].flip_x);
        let floor = &cave.walls[3].windows;
        assert_eq!(
            floor.iter().map(|w| w.layout).collect::<Vec<_>>(),
            [Layout::Left, Layout::Right]
        );
        assert_eq!(floor[1].monitor, Some(Monitor::Index(1)));
        let desk = load_cave(&config("desk.toml")).unwrap();
        assert_eq!(desk.walls.len(), 1);
    }

    #[test]
    fn problems_name_their_fields() {
        let text = std::fs::read_to_string(config("cave4.toml")).unwrap();
        let broken = text
            .replacen("pc = [-1.5, 3.0, -1.5]", "pc = [-1.49, 3.0, -1.5]", 1) // front: 10 mm off square
            .replacen("name = \"left\"", "name = \"front\"", 1)
            .replacen("pixels = [1024, 1024]", "pixels = [0, -5]", 1)
            .replacen("ipd = 0.064", "ipd = -0.064", 1)
            .replace(
                "source = \"vrpn://Tracker0@localhost:3883\"",
                "source = \"ftp://x\"",
            );
        let err = parse_cave(&broken, "broken.toml").unwrap_err().to_string();
        for expected in [
            "broken.toml",
            "wall[0] (\"front\").pc: corners are not a rectangle: pc is 10.0 mm off",
            "wall[1] (\"front\").name: duplicate wall name",
            "wall[3] (\"floor\").pixels[0]: pixel width 0 must be positive",
            "wall[3] (\"floor\").pixels[1]: pixel height -5 must be positive",
            "user.ipd",
            "tracking.source",
        ] {
            assert!(err.contains(expected), "missing {expected:?} in:\n{err}");
        }
        // A wall seen from behind: the right wall with pa and pb swapped.
        let flipped = text.replacen(
            "pa = [1.5, 0.0, -1.5]\npb = [1.5, 0.0, 1.5]\npc = [1.5, 3.0, -1.5]",
            "pa = [1.5, 0.0, 1.5]\npb = [1.5, 0.0, -1.5]\npc = [1.5, 3.0, 1.5]",
            1,
        );
        assert_ne!(flipped, text);
        let err = parse_cave(&flipped, "f.toml").unwrap_err().to_string();
        assert!(
            err.contains("wall[2] (\"right\"): its normal") && err.contains("points away"),
            "{err}"
        );
        let err = parse_cave("[room]\nnear = 1\n", "t.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains("t.toml") && err.contains("tracking"), "{err}");
    }
}
