//! A render node's life: following a cluster's master frame by frame (the link, ready and
//! swap: [`follow`]), joining and rejoining it with the display the master's holodeck and
//! light field call for ([`cluster`]), or running one wall by itself on its own clock and
//! head poses ([`standalone`]); and the keyboard and mouse of its windows ([`desk`]).

pub mod cluster;
pub mod desk;
pub mod follow;
pub mod standalone;
