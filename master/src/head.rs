//! The tracked head as the master sees it: raw samples from a tracker source, through the
//! tracking pipeline (guard, hemisphere, filter, predictor), mapped to room coordinates and
//! predicted to a frame's display time.
//!
//! Two clocks: *live*, where a sample's arrival is the master's clock when the tracker's
//! reader got it (not when the frame loop read it from the reader), and
//! *replay*, where the master's clock is virtual (frame × period) and a log's samples
//! arrive at their own time since the log's first sample — the same log then gives the
//! same poses, bit for bit, however fast the machine is. In both, the pose is predicted
//! to `sample time + (display time − arrival time)` of the newest sample, so sources
//! whose timestamps are on another clock (a VRPN server, a recorded log) work unchanged.

use std::time::Instant;

use glam::{DMat4, Quat, Vec3};
use holocave_tracking::predict::PredictorKind;
use holocave_tracking::source::{Next, Pacing, SourceError, SourceSpec, TrackerSource, open};
use holocave_tracking::{HeadTracker, Pose, Sample};

use holocave_cave::Cave;

/// Fastest plausible head motion (m/s); a prediction further from its newest sample than
/// this allows for the look-ahead is discarded.
pub const MAX_HEAD_SPEED: f32 = 3.0;
/// Fastest plausible head turn (rad/s), about two turns a second.
pub const MAX_HEAD_TURN: f32 = 4.0 * std::f32::consts::PI;

/// How the head source is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Clock {
    /// Samples as they arrive; the master's clock is real.
    Live,
    /// Samples at their own times since the first; the master's clock is virtual.
    Replay,
}

/// The head: its source, pipeline and the transform into the room.
pub struct Head {
    source: Box<dyn TrackerSource>,
    tracker: HeadTracker,
    clock: Clock,
    /// A sample read but not yet due (replay), with its arrival.
    pending: Option<(Sample, Instant)>,
    /// The first sample's time (replay's time origin).
    t0: Option<u64>,
    /// The newest accepted sample and its arrival on the master's clock.
    newest: Option<(Sample, u64)>,
    /// Predictions discarded as implausible (see [`MAX_HEAD_SPEED`]).
    pub implausible: u64,
    tracker_to_room: DMat4,
    /// Where the first position is moved to (logs recorded in another room).
    recenter: Option<Vec3>,
    origin: Option<Vec3>,
    last: Pose,
    ended: bool,
    /// Raw samples read.
    pub samples: u64,
}

impl Head {
    /// Opens `spec` (the config's source when `None`). `predict` chooses the config's
    /// predictor or none; `recenter` moves the first position to the room's inside point.
    pub fn open(
        cave: &Cave,
        spec: Option<&SourceSpec>,
        clock: Clock,
        predict: bool,
        recenter: bool,
    ) -> Result<Head, SourceError> {
        let spec = spec.unwrap_or(&cave.source);
        let pacing = match clock {
            Clock::Live => Pacing::RealTime,
            Clock::Replay => Pacing::AsFastAsPossible,
        };
        Ok(Head::with_source(
            cave,
            open(spec, pacing, None)?,
            clock,
            predict,
            recenter,
        ))
    }

    /// The head over an open tracker source.
    pub fn with_source(
        cave: &Cave,
        source: Box<dyn TrackerSource>,
        clock: Clock,
        predict: bool,
        recenter: bool,
    ) -> Head {
        Head {
            source,
            tracker: if predict {
                HeadTracker::new(&cave.tracking)
            } else {
                HeadTracker::with_predictor(&cave.tracking, PredictorKind::None)
            },
            clock,
            pending: None,
            t0: None,
            newest: None,
            implausible: 0,
            tracker_to_room: cave.tracker_to_room,
            recenter: recenter.then(|| cave.inside.as_vec3()),
            origin: None,
            last: Pose::new(cave.inside.as_vec3(), Quat::IDENTITY),
            ended: false,
            samples: 0,
        }
    }

    /// Reads every sample that has arrived by `now_ns` on the master's clock (live: without
    /// waiting; replay: every sample up to `now_ns` after the first).
    pub fn advance(&mut self, now_ns: u64) {
        loop {
            let (s, arrived) = match self.pending.take() {
                Some(p) => p,
                None if self.ended => return,
                None => {
                    let deadline = match self.clock {
                        Clock::Live => Instant::now(),
                        // Recorded sources answer at once; the margin only guards a
                        // synthetic source's first call.
                        Clock::Replay => Instant::now() + std::time::Duration::from_millis(100),
                    };
                    match self.source.next(deadline) {
                        Next::Sample(s, at) => {
                            self.samples += 1;
                            (s, at)
                        }
                        Next::Idle => return,
                        Next::End => {
                            self.ended = true;
                            return;
                        }
                    }
                }
            };
            let arrival = match self.clock {
                // When the tracker's reader got it, on the master's clock: `now_ns` less
                // how long ago that was.
                Clock::Live => now_ns.saturating_sub(arrived.elapsed().as_nanos() as u64),
                Clock::Replay => {
                    let t0 = *self.t0.get_or_insert(s.t_ns);
                    let at = s.t_ns.saturating_sub(t0);
                    if at > now_ns {
                        self.pending = Some((s, arrived));
                        return;
                    }
                    at
                }
            };
            if let holocave_tracking::guard::Checked::Accepted { sample, .. } = self.tracker.push(s)
            {
                self.newest = Some((sample, arrival));
            }
        }
    }

    /// The head pose in room coordinates expected at `display_ns` on the master's clock,
    /// and the arrival time of the newest sample it rests on. Before any good sample (or
    /// when the prediction is not finite) it is the last good pose.
    pub fn pose_at(&mut self, display_ns: u64) -> (Pose, Option<u64>) {
        let Some((newest, arrival)) = self.newest else {
            return (self.last, None);
        };
        let ahead = display_ns.saturating_sub(arrival);
        let at = newest.t_ns.saturating_add(ahead);
        if let Some(mut p) = self.tracker.predict(at) {
            // A predictor's transient (the first samples, a burst after a gap) can throw
            // the pose metres away; no head moves that fast, so show the sample instead.
            let s = ahead as f32 * 1e-9;
            let far = p.position.distance(newest.pose.position) > MAX_HEAD_SPEED * s + 0.01;
            let turned = p.orientation.angle_between(newest.pose.orientation)
                > MAX_HEAD_TURN * s + 2f32.to_radians();
            if far || turned || !p.is_finite() {
                self.implausible += 1;
                p = newest.pose;
            }
            let m = self.tracker_to_room;
            let q = m.as_mat4().to_scale_rotation_translation().1;
            let mut pos = m.transform_point3(p.position.as_dvec3()).as_vec3();
            if let Some(inside) = self.recenter {
                let o = *self.origin.get_or_insert(pos);
                pos = inside + (pos - o);
            }
            let pose = Pose::new(pos, (q * p.orientation).normalize());
            if pose.is_finite() {
                self.last = pose;
            }
        }
        (self.last, Some(arrival))
    }

    /// How far `--recenter` moved the tracker's positions (room metres): other devices on
    /// the same tracker (a wand) move with the head. Zero without recentring.
    pub fn recentring(&self) -> Vec3 {
        match (self.recenter, self.origin) {
            (Some(inside), Some(o)) => inside - o,
            _ => Vec3::ZERO,
        }
    }

    /// The first position that `--recenter` moved to the room's inside point (room
    /// metres), once read: what a resumed session recentres by.
    pub fn recentred_from(&self) -> Option<Vec3> {
        self.origin
    }

    /// Recentres by a resumed session's first position, as the session did.
    pub fn resume_recentring(&mut self, origin: Vec3) {
        self.origin = Some(origin);
    }

    /// True once a recorded source has no more samples.
    pub fn ended(&self) -> bool {
        self.ended && self.pending.is_none()
    }

    /// What the tracking guard rejected so far, in one line.
    pub fn fault_line(&self) -> String {
        let r = self.tracker.report();
        format!(
            "{} rejected of {} read, {} implausible predictions",
            r.rejected(),
            self.samples,
            self.implausible
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use holocave_cave::parse_cave;

    fn cave(source: &str) -> Cave {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../configs/cave4.toml"
        ))
        .unwrap()
        .replace("vrpn://Tracker0@localhost:3883", source);
        parse_cave(&text, "cave4.toml").unwrap()
    }

    #[test]
    fn replay_gives_the_same_poses_twice_and_follows_the_log() {
        let c = cave("synthetic:walk");
        let run = || {
            let mut h = Head::open(&c, None, Clock::Replay, true, false).unwrap();
            (0..120u64)
                .map(|k| {
                    let now = k * 16_666_667;
                    h.advance(now);
                    h.pose_at(now + 16_666_667)
                })
                .collect::<Vec<_>>()
        };
        let (a, b) = (run(), run());
        assert_eq!(a, b);
        let moved = a
            .first()
            .unwrap()
            .0
            .position
            .distance(a.last().unwrap().0.position);
        assert!(moved > 0.01, "the walk moved the head {moved} m");
        assert!(a.iter().all(|(p, _)| p.is_finite()));
    }

    /// One sample that arrived a while before the frame loop reads it.
    struct ArrivedEarlier(Option<(Sample, Instant)>);

    impl TrackerSource for ArrivedEarlier {
        fn next(&mut self, _deadline: Instant) -> Next {
            match self.0.take() {
                Some((s, at)) => Next::Sample(s, at),
                None => Next::Idle,
            }
        }
        fn endless(&self) -> bool {
            true
        }
    }

    #[test]
    fn a_live_sample_arrives_when_the_reader_got_it_not_when_the_frame_read_it() {
        let c = cave("synthetic:still");
        let waited = std::time::Duration::from_millis(40);
        let Some(at) = Instant::now().checked_sub(waited) else {
            return; // a clock younger than 40 ms: nothing to measure
        };
        let sample = Sample::new(5, Pose::new(c.inside.as_vec3(), Quat::IDENTITY));
        let source = Box::new(ArrivedEarlier(Some((sample, at))));
        let mut h = Head::with_source(&c, source, Clock::Live, false, false);
        let now_ns = 1_000_000_000;
        h.advance(now_ns);
        let (_, arrival) = h.pose_at(now_ns);
        // The stamp is `now_ns` less the sample's age when the head read it: at least the
        // 40 ms it had waited, at most its age now.
        let age = now_ns - arrival.unwrap();
        let most = at.elapsed();
        assert!(
            age >= waited.as_nanos() as u64 && age <= most.as_nanos() as u64,
            "arrived {age} ns before the frame read it; it waited {waited:?}"
        );
    }

    #[test]
    fn recentring_is_the_shift_between_the_recentred_and_the_plain_head() {
        let c = cave("synthetic:walk");
        let mut plain = Head::open(&c, None, Clock::Replay, false, false).unwrap();
        let mut moved = Head::open(&c, None, Clock::Replay, false, true).unwrap();
        assert_eq!(moved.recentring(), Vec3::ZERO, "nothing read yet");
        for k in 0..30u64 {
            let now = k * 16_666_667;
            plain.advance(now);
            moved.advance(now);
            let (a, b) = (plain.pose_at(now).0, moved.pose_at(now).0);
            // f32 positions of about a metre: a few ulps.
            assert!(
                (b.position - moved.recentring() - a.position).length() < 1e-6,
                "frame {k}: {} vs {}",
                b.position - moved.recentring(),
                a.position
            );
        }
        assert!(
            moved.recentring().length() > 0.1,
            "the walk starts away from the inside point"
        );
    }

    #[test]
    fn before_any_sample_the_head_is_at_the_inside_point() {
        let c = cave("synthetic:still");
        let mut h = Head::open(&c, None, Clock::Replay, true, false).unwrap();
        let (p, arrival) = h.pose_at(0);
        assert_eq!(p.position, c.inside.as_vec3());
        assert_eq!(arrival, None);
    }
}
