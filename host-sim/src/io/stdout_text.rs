//! Text to standard output that ends quietly when the reader goes away (`host-sim … | head`).

use crate::error::{Result, SimError};
use std::io::Write;

/// Writes `text` to standard output; a closed pipe becomes [`SimError::Io`] on `<stdout>` with
/// [`std::io::ErrorKind::BrokenPipe`], which [`is_closed_stdout`] recognises.
pub fn print_text(text: &str) -> Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .map_err(|e| SimError::writing(STDOUT, e))
}

/// The path name used for standard output in errors.
pub const STDOUT: &str = "<stdout>";

/// True for the error of writing to a standard output whose reader has closed it: the reader
/// wanted no more (e.g. `head`), so the command ends successfully without a message.
#[must_use]
pub fn is_closed_stdout(e: &SimError) -> bool {
    matches!(e, SimError::Io { path, source, .. }
        if path.as_os_str() == STDOUT && source.kind() == std::io::ErrorKind::BrokenPipe)
}
