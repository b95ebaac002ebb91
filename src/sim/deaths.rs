//! The summary's lines on the nodes and workers that died during a `sim` run: when, how,
//! when each was started again, and for a node, when its wall presented again and how many
//! frames it missed.

use std::collections::{BTreeMap, BTreeSet};
use std::time::Instant;

use super::{Aftermath, node_name};

/// The lines: how many died and were started again (`restarting`: whether they were to
/// be), then each death. Times are seconds from the processes' start; `presented` holds
/// each wall's presented frames.
pub fn report(
    ended: &Aftermath,
    restarting: bool,
    presented: &BTreeMap<String, BTreeSet<u64>>,
) -> Vec<String> {
    let restarted = (ended.deaths.iter())
        .filter(|d| d.restarted.is_some())
        .count();
    let off = if restarting { "" } else { " (--no-restart)" };
    let mut lines = vec![format!(
        "  processes that died: {}, started again: {restarted}{off}",
        ended.deaths.len()
    )];
    let all: BTreeSet<u64> = presented.values().flatten().copied().collect();
    let sent = &ended.sent;
    for d in &ended.deaths {
        let secs = |t: Instant| t.saturating_duration_since(ended.origin).as_secs_f64();
        // The first frame whose state was made after the death.
        let next = sent.partition_point(|&t| t <= d.at) as u64;
        let back = match d.restarted {
            Some(t) => format!("started again at {:.2} s", secs(t)),
            None => "not started again".to_owned(),
        };
        let wall = (presented.iter()).find(|(wall, _)| node_name(wall) == d.name);
        let shown = wall.map_or(String::new(), |(name, shown)| {
            let again = wall_again(shown, &all, next, (sent, d.at));
            format!("; wall {name} {again}")
        });
        lines.push(format!(
            "    {} died at {:.2} s before frame {next} ({}, after running {:.2} s); {back}{shown}",
            d.name,
            secs(d.at),
            d.how,
            d.ran.as_secs_f64()
        ));
    }
    lines
}

/// Whether a wall (its presented frames `shown`) presented again after its node died at
/// `died` before frame `next`, from which frame and how long after the death (to when that
/// frame's state was made, by `sent`); and how many of the frames some wall presented
/// (`all`) it missed from its last frame before the death to its first after.
fn wall_again(
    shown: &BTreeSet<u64>,
    all: &BTreeSet<u64>,
    next: u64,
    (sent, died): (&[Instant], Instant),
) -> String {
    let from = shown.range(..next).next_back().map_or(0, |f| f + 1);
    let again = shown.range(next..).next().copied();
    let missed = (all.range(from..again.unwrap_or(u64::MAX)))
        .filter(|f| !shown.contains(f))
        .count();
    let Some(again) = again else {
        return format!("presented no frame after it: {missed} frames missed");
    };
    let after = sent.get(again as usize).map_or(String::new(), |t| {
        let s = t.saturating_duration_since(died).as_secs_f64();
        format!(", {s:.2} s after the death")
    });
    format!("presenting again from frame {again}{after}: {missed} frames missed")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn a_wall_back_after_a_death_counts_the_frames_it_missed() {
        let t0 = Instant::now();
        let sent: Vec<Instant> = (0..10)
            .map(|i| t0 + Duration::from_millis(100 * i))
            .collect();
        let all: BTreeSet<u64> = (0..10).collect();
        let shown: BTreeSet<u64> = [0, 1, 2, 6, 7, 8, 9].into();
        let died = t0 + Duration::from_millis(250);
        let line = wall_again(&shown, &all, 3, (&sent, died));
        assert_eq!(
            line,
            "presenting again from frame 6, 0.35 s after the death: 3 frames missed"
        );
        let gone: BTreeSet<u64> = [0, 1, 2].into();
        let line = wall_again(&gone, &all, 3, (&sent, died));
        assert_eq!(line, "presented no frame after it: 7 frames missed");
    }
}
