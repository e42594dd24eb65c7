//! The boards, one module each behind the board contract ([`crate::board_api::Board`]); the
//! build's `board-*` feature selects one, [`Selected`], which the application ([`crate::app`])
//! runs on. Target only.

#[cfg(feature = "board-f411")]
pub mod f411;
#[cfg(feature = "board-f446")]
pub mod f446;
#[cfg(feature = "board-mps2")]
pub mod mps2;
#[cfg(any(feature = "board-f411", feature = "board-f446"))]
mod stm32_drivers;

#[cfg(feature = "board-f411")]
pub use f411::Selected;
#[cfg(feature = "board-f446")]
pub use f446::Selected;
#[cfg(feature = "board-mps2")]
pub use mps2::Selected;
