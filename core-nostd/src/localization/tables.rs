//! Constant tables generated at build time (`build.rs`): window, decimator taps, ideal reference features.
//! They are `static`, so they live once in flash.

include!(concat!(env!("OUT_DIR"), "/tables.rs"));
