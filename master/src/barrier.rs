//! The swap barrier's bookkeeping, without sockets or clocks: who is in the cluster, whom
//! the barrier waits for, who was ready for the frame, who was declared out.
//!
//! Frame lock: every wall swaps only when every node in the barrier is ready, however
//! slow the slowest is. The caller closes a frame early only at the dead-node timeout; a
//! node not ready by then is declared out (the others swap without it) and comes back with
//! its next Ready, for whatever frame: it is drawing again, and the frame being collected
//! waits for it. A node that joins (or reconnects) mid-run starts outside the barrier and
//! enters the same way, so no frame waits for a node that has not yet shown it is drawing;
//! before the first frame the caller holds every joined node ([`Barrier::hold_all`]), so
//! all walls start on the same frame.

use std::collections::BTreeMap;

use holocave_protocol::cluster::NodeStats;

/// A connection's number.
pub type NodeId = u64;

/// What the master knows of one node.
#[derive(Clone, Debug)]
pub struct Member {
    pub wall: String,
    /// The barrier waits for this node.
    pub in_barrier: bool,
    /// The newest frame this node said it was ready for.
    pub ready: Option<u64>,
    /// Times it was declared out (missed the dead-node timeout).
    pub outs: u64,
    /// Frames it swapped.
    pub swapped: u64,
    pub stats: NodeStats,
}

/// The outcome of one frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Closed {
    /// Nodes that get Swap.
    pub swap: Vec<NodeId>,
    /// Nodes declared out: the barrier waited for them and they were not ready.
    pub out: Vec<NodeId>,
}

/// The members and the frame being collected.
#[derive(Clone, Debug, Default)]
pub struct Barrier {
    members: BTreeMap<NodeId, Member>,
    frame: u64,
}

impl Barrier {
    pub fn members(&self) -> &BTreeMap<NodeId, Member> {
        &self.members
    }

    /// A node joined; it enters the barrier when it is first ready in time.
    pub fn join(&mut self, id: NodeId, wall: &str) {
        self.members.insert(
            id,
            Member {
                wall: wall.to_owned(),
                in_barrier: false,
                ready: None,
                outs: 0,
                swapped: 0,
                stats: NodeStats::default(),
            },
        );
    }

    pub fn leave(&mut self, id: NodeId) -> Option<Member> {
        self.members.remove(&id)
    }

    /// The frame being collected.
    pub fn frame(&self) -> u64 {
        self.frame
    }

    /// Starts collecting Ready for `frame`.
    pub fn begin(&mut self, frame: u64) {
        self.frame = frame;
    }

    /// A node is ready for `frame`. A stale answer (an older frame, from a node that was
    /// out or had just joined) shows the node is drawing again: it re-enters the barrier
    /// for the frame being collected, whose state it has and draws next.
    pub fn ready(&mut self, id: NodeId, frame: u64, stats: NodeStats) {
        if let Some(m) = self.members.get_mut(&id) {
            m.stats = stats;
            if frame == self.frame {
                m.ready = Some(frame);
            }
            m.in_barrier = true;
        }
    }

    /// Waits for every member from now on, joined or not yet drawing (the first frame:
    /// every wall starts on it).
    pub fn hold_all(&mut self) {
        for m in self.members.values_mut() {
            m.in_barrier = true;
        }
    }

    /// Every node the barrier waits for is ready (true with no such node).
    pub fn complete(&self) -> bool {
        self.members
            .values()
            .filter(|m| m.in_barrier)
            .all(|m| m.ready == Some(self.frame))
    }

    /// Ends the frame: the ready nodes swap, the others the barrier waited for are out.
    pub fn close(&mut self) -> Closed {
        let mut out = Closed::default();
        for (&id, m) in &mut self.members {
            if m.ready == Some(self.frame) {
                m.swapped += 1;
                out.swap.push(id);
            } else if m.in_barrier {
                m.in_barrier = false;
                m.outs += 1;
                out.out.push(id);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stats() -> NodeStats {
        NodeStats::default()
    }

    #[test]
    fn all_ready_swaps_all() {
        let mut b = Barrier::default();
        for id in 0..4 {
            b.join(id, "w");
        }
        b.begin(1);
        for id in 0..4 {
            b.ready(id, 1, stats());
        }
        assert!(b.complete());
        assert_eq!(b.close().swap, vec![0, 1, 2, 3]);
        b.begin(2);
        assert!(
            !b.complete(),
            "members are in the barrier once they kept up"
        );
    }

    #[test]
    fn a_node_out_at_the_timeout_leaves_the_barrier_and_rejoins_when_it_catches_up() {
        let mut b = Barrier::default();
        for id in 0..3 {
            b.join(id, "w");
        }
        b.begin(1);
        for id in 0..3 {
            b.ready(id, 1, stats());
        }
        b.close();
        b.begin(2);
        b.ready(0, 2, stats());
        b.ready(1, 2, stats());
        assert!(!b.complete());
        let c = b.close();
        assert_eq!((c.swap, c.out), (vec![0, 1], vec![2]));
        // Frame 3: nobody waits for node 2 until its answer to frame 2 (stale) shows it is
        // drawing again; then the barrier waits for it to draw frame 3 too.
        b.begin(3);
        b.ready(0, 3, stats());
        b.ready(1, 3, stats());
        assert!(b.complete(), "an out node is not waited for");
        b.ready(2, 2, stats());
        assert!(!b.complete(), "a node drawing again is waited for");
        b.ready(2, 3, stats());
        assert_eq!(b.close().swap, vec![0, 1, 2]);
        assert_eq!(b.members()[&2].outs, 1);
    }

    #[test]
    fn a_node_that_leaves_is_not_waited_for_and_a_new_one_is_not_waited_for_yet() {
        let mut b = Barrier::default();
        b.join(0, "a");
        b.join(1, "b");
        b.begin(1);
        b.ready(0, 1, stats());
        b.ready(1, 1, stats());
        b.close();
        b.begin(2);
        b.ready(0, 2, stats());
        b.leave(1);
        b.join(2, "b");
        assert!(b.complete());
        assert_eq!(b.close().swap, vec![0]);
    }

    #[test]
    fn holding_all_waits_for_nodes_outside_the_barrier() {
        let mut b = Barrier::default();
        b.join(0, "a");
        b.join(1, "b");
        b.begin(1);
        assert!(b.complete(), "nobody in the barrier yet");
        b.hold_all();
        assert!(!b.complete());
        b.ready(0, 1, stats());
        assert!(!b.complete(), "frame lock: one wall ready is not enough");
        b.ready(1, 1, stats());
        assert_eq!(b.close().swap, vec![0, 1]);
    }

    #[test]
    fn no_nodes_is_complete() {
        let mut b = Barrier::default();
        b.begin(7);
        assert!(b.complete());
        assert_eq!(b.close(), Closed::default());
    }
}
