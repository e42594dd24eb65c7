//! A board's serial stream on the host: the lines a board sends for a recording (what `emit`, a
//! stand-in board, writes), and the decoder, counters and views of `monitor`.

pub mod board_lines;
pub mod monitor;
