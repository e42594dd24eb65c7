//! Making a reference table: the exponential sine sweep and the table measured from its recordings,
//! or the table of a self-calibration estimate; and the plot of a table.

pub mod measured_table;
pub mod selfcal_table;
pub mod sweep;
pub mod table_plot;
