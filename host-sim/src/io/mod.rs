//! Files and ports: WAV, reference tables, estimates, truth tracks, manifests, the self-calibration
//! file, serial ports and standard output.

pub mod estimate_output;
pub mod fixed_decimal;
pub mod ground_truth;
pub mod manifest;
pub mod output_file;
pub mod selfcal_file;
pub mod serial_link;
pub mod stdout_text;
pub mod table_io;
pub mod text_file;
pub mod wav_io;
