//! Flags shared by several commands: the localizer configuration and the checked numeric values.

pub mod arg_values;
pub mod config_args;
