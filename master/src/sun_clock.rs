//! The scene's time of day through a session. It starts at `--when` (or where a resumed
//! session left it); a replayed session's `time` rows set it, and a desk's time keys step
//! it (±15 min, ±1 h, ±1 day). Every frame state carries it, so every wall lights its scene
//! for the same time at the same frame, and a replay sets it at the same frames each run.

use chrono::{Duration, NaiveDateTime};
use holocave_scene::daylight::When;

/// The session's time of day.
#[derive(Clone, Debug, PartialEq)]
pub struct SunClock {
    /// The time the session started at (`--when`): the one its workers' holodeck and its
    /// nodes' own light were made for.
    start: When,
    now: When,
}

impl SunClock {
    pub fn new(start: When) -> SunClock {
        SunClock { start, now: start }
    }

    /// A resumed session's clock: started at `start`, now at `now`.
    pub fn resumed(start: When, now: When) -> SunClock {
        SunClock { start, now }
    }

    pub fn start(&self) -> When {
        self.start
    }

    pub fn now(&self) -> When {
        self.now
    }

    /// A frame's time inputs applied: a time set (a replayed `time` row, the site's local
    /// standard time) first, then the desk's steps (minutes). Returns whether the time
    /// changed. A step that would leave the calendar's range is not taken (and logged).
    pub fn advance(&mut self, set: Option<NaiveDateTime>, step_min: i64) -> bool {
        let before = self.now;
        if let Some(t) = set {
            self.now = When::Local(t);
        }
        if step_min != 0 {
            match stepped(self.now, step_min) {
                Some(w) => self.now = w,
                None => tracing::warn!(
                    "time of day {}: a step of {step_min} min leaves the calendar; not taken",
                    self.now
                ),
            }
        }
        self.now != before
    }

    /// The time as a session log's `time` row holds it: local standard time to the
    /// minute (`None` for a time given with its own offset, which a row cannot hold).
    pub fn local(&self) -> Option<NaiveDateTime> {
        match self.now {
            When::Local(n) => Some(n),
            When::Fixed(_) => None,
        }
    }
}

/// `when` moved by `minutes`, in its own form (`None` past chrono's range).
fn stepped(when: When, minutes: i64) -> Option<When> {
    let d = Duration::try_minutes(minutes)?;
    Some(match when {
        When::Local(n) => When::Local(n.checked_add_signed(d)?),
        When::Fixed(f) => When::Fixed(f.checked_add_signed(d)?),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(s: &str) -> When {
        s.parse().unwrap()
    }

    #[test]
    fn steps_add_up_and_a_set_time_comes_first() {
        let mut c = SunClock::new(at("2026-12-21T09:00"));
        assert!(!c.advance(None, 0));
        assert!(c.advance(None, 15));
        assert!(c.advance(None, -24 * 60));
        assert_eq!(c.now(), at("2026-12-20T09:15"));
        let noon = NaiveDateTime::parse_from_str("2026-06-21T12:00", "%Y-%m-%dT%H:%M").unwrap();
        assert!(c.advance(Some(noon), 60));
        assert_eq!(c.now(), at("2026-06-21T13:00"));
        assert_eq!(c.start(), at("2026-12-21T09:00"));
        assert!(!c.advance(Some(noon + Duration::minutes(60)), 0));
    }

    #[test]
    fn a_time_with_an_offset_keeps_it_and_a_step_off_the_calendar_is_refused() {
        let mut c = SunClock::new(at("2026-12-21T09:00+01:00"));
        c.advance(None, 60);
        assert_eq!(c.now(), at("2026-12-21T10:00+01:00"));
        assert_eq!(c.local(), None);
        let mut end = SunClock::new(When::Local(NaiveDateTime::MAX));
        assert!(!end.advance(None, 60));
        assert_eq!(end.now(), When::Local(NaiveDateTime::MAX));
    }
}
