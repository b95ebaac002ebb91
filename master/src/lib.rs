//! The holocave master: the tracked head (tracker, filter, prediction), the frame clock,
//! the frame states it sends (with the moving objects' placements), pacing, the swap barrier (frame lock) and node membership. The physical CAVE it
//! drives (config, walls, frusta) is `holocave_cave`.

pub mod barrier;
pub mod cluster;
pub mod frame_state;
pub mod head;
pub mod navigation;
pub mod objects;
pub mod pacing;
pub mod session;
pub mod sun_clock;
