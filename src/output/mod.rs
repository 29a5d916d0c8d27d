//! Where a command's outputs go: what an output path may name ([`target`]), each file
//! replaced whole ([`atomic`]), one writer per output directory or file ([`lock`]), and one
//! output written in parts by several processes or cluster jobs ([`shard`]).

pub mod atomic;
pub mod lock;
pub mod shard;
pub mod target;
