//! Constant tables generated at build time (`build.rs`): the analysis window, the twiddles of the
//! direct DFT and of the x86_64 FFT, and the half-band decimator's coefficients. They are `static`,
//! so they live once in flash.

include!(concat!(env!("OUT_DIR"), "/tables.rs"));
