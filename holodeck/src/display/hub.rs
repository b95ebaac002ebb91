//! The displays subscribed to a server's samples, and the rule that each sample is sent to
//! each display once: a subscriber remembers how many samples of each beam it has been
//! sent (a prefix, since beams only grow at the end). A repeated request is answered with
//! only the samples after that prefix; new samples of a beam are sent to every display
//! that has all the earlier ones, even when another display asked for them (they are
//! welcome: the render cache keeps what fits its views); a display behind on a beam gets
//! the rest when it asks again.
//!
//! The hub sits next to the [`Server`] and is locked after it.

use std::collections::BTreeMap;
use std::sync::Arc;

use super::{Arrival, EyeRequest, SLOTS};
use crate::beam_index::BeamKey;
use crate::cache::BeamMap;
use crate::server::{BeamSamples, DisplayId, Server, ServerError};

/// Hands a display its samples; returns false once the display is gone.
pub type Deliver = Box<dyn Fn(Arrival) -> bool + Send>;

/// What one display (all its subscriptions together) has been given.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DisplayTally {
    /// EyeSphere requests served.
    pub requests: u64,
    /// Samples handed to it (stored ones answering requests and new ones).
    pub samples: u64,
}

struct Subscriber {
    display: u32,
    /// Per beam, how many of its samples (the first ones) this display has been sent.
    sent: BeamMap<BeamKey, u32>,
    deliver: Deliver,
}

/// The displays subscribed to a server's samples.
#[derive(Default)]
pub struct Hub {
    subs: BTreeMap<u64, Subscriber>,
    next: u64,
    tally: BTreeMap<u32, DisplayTally>,
}

impl Hub {
    /// Adds a display; `deliver` hands it samples and returns false once it is gone.
    pub fn subscribe(&mut self, display: u32, deliver: Deliver) -> u64 {
        let token = self.next;
        self.next += 1;
        self.subs.insert(
            token,
            Subscriber {
                display,
                sent: BeamMap::default(),
                deliver,
            },
        );
        token
    }

    /// Removes a display and its requests.
    pub fn unsubscribe(&mut self, server: &mut Server, token: u64) {
        if let Some(s) = self.subs.remove(&token) {
            let still = self.subs.values().any(|o| o.display == s.display);
            if !still {
                for k in 0..SLOTS {
                    server.remove_display(s.display * SLOTS + k);
                }
            }
        }
    }

    pub fn is_empty(&self) -> bool {
        self.subs.is_empty()
    }

    /// What display `display` has been given so far.
    pub fn tally(&self, display: u32) -> DisplayTally {
        self.tally.get(&display).copied().unwrap_or_default()
    }

    /// Serves one eye's request: sets it on the server and sends the display the stored
    /// samples it has not been sent yet.
    pub fn request(
        &mut self,
        server: &mut Server,
        token: u64,
        req: EyeRequest,
    ) -> Result<(), ServerError> {
        let Some(sub) = self.subs.get_mut(&token) else {
            return Ok(());
        };
        let id: DisplayId = sub.display * SLOTS + u32::from(req.slot) % SLOTS;
        let beams: Vec<BeamKey> = req.wanted.iter().map(|w| w.0).collect();
        server.set_requests(id, req.wanted, req.eye)?;
        let sent = &sub.sent;
        let got = server.stored_samples(beams, |k| sent.get(&k).copied().unwrap_or(0))?;
        for b in &got {
            *sub.sent.entry(b.key).or_default() += b.samples.len() as u32;
        }
        let tally = self.tally.entry(sub.display).or_default();
        tally.requests += 1;
        if got.is_empty() {
            return Ok(());
        }
        tally.samples += got.iter().map(|b| b.samples.len() as u64).sum::<u64>();
        if !(sub.deliver)(Arc::new(got)) {
            self.unsubscribe(server, token);
        }
        Ok(())
    }

    /// Sends new samples (as [`Server::complete`] returned them, already added) to every
    /// display up to date on their beams.
    pub fn distribute(&mut self, server: &mut Server, new: &[BeamSamples]) {
        if new.is_empty() || self.subs.is_empty() {
            return;
        }
        let mut gone = Vec::new();
        // One packet may hold several bundles of a beam: what is new per beam.
        let mut added: BeamMap<BeamKey, u32> = BeamMap::default();
        for b in new {
            *added.entry(b.key).or_default() += b.samples.len() as u32;
        }
        for (&token, sub) in &mut self.subs {
            let mut out = Vec::new();
            for b in new {
                let n = server.cache().count(b.key);
                let before = n.saturating_sub(added[&b.key]);
                let k = sub.sent.entry(b.key).or_default();
                if *k == before {
                    *k = n;
                }
                // Sent only to displays that have all the earlier samples (the others ask
                // again and get the rest with what they lack).
                if *k == n {
                    out.push(b.clone());
                }
            }
            if out.is_empty() {
                continue;
            }
            self.tally.entry(sub.display).or_default().samples +=
                out.iter().map(|b| b.samples.len() as u64).sum::<u64>();
            if !(sub.deliver)(Arc::new(out)) {
                gone.push(token);
            }
        }
        for t in gone {
            self.unsubscribe(server, t);
        }
    }
}
