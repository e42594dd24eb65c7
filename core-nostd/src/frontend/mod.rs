//! Front end: input sanitation, anti-alias decimation and framing, block by block.

pub mod block_decimator;
pub mod decimator;
pub mod framer;
pub mod front_end;
pub mod input_guard;
