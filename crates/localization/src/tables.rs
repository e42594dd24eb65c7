//! Reference tables generated at build time (`build.rs`): the ideal-model features and, with
//! `CMA_TABLE`, a measured table's.
//! They are `static`, so they live once in flash.

include!(concat!(env!("OUT_DIR"), "/tables.rs"));
