//! The evaluation manifest: `manifest.csv` with `file,set,score_from_s,score_to_s,note`.

use crate::error::{Result, SimError};
use std::path::{Path, PathBuf};

/// One scene of an evaluation folder.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// WAV path relative to the folder.
    pub file: PathBuf,
    /// Set name (e.g. `anechoic`, `room`, `jump`, `moving`).
    pub set: String,
    /// Start of the scored interval, s.
    pub score_from_s: f64,
    /// End of the scored interval, s.
    pub score_to_s: f64,
    /// Free text.
    pub note: String,
}

impl Entry {
    /// Path of the truth file: `NAME.pos.csv` beside `NAME.wav`.
    #[must_use]
    pub fn truth_path(&self, dir: &Path) -> PathBuf {
        dir.join(self.file.with_extension("pos.csv"))
    }

    /// Scene name: the file stem.
    #[must_use]
    pub fn name(&self) -> String {
        self.file
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    }
}

/// Splits one CSV line, honouring double quotes.
fn split_csv(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(std::mem::take(&mut cur)),
            c => cur.push(c),
        }
    }
    out.push(cur);
    out
}

/// Reads `dir/manifest.csv`.
pub fn read(dir: &Path) -> Result<Vec<Entry>> {
    let path = dir.join("manifest.csv");
    let text = crate::io::text_file::read(&path)?;
    let bad = |line: usize, reason: String| SimError::BadCsv {
        path: path.clone(),
        line,
        reason,
    };
    let mut lines = text.lines().enumerate();
    let (_, header) = lines
        .next()
        .ok_or_else(|| bad(1, "empty manifest".into()))?;
    let cols = split_csv(header);
    let want = ["file", "set", "score_from_s", "score_to_s"];
    if cols.len() < 4 || cols[..4].iter().zip(want).any(|(c, w)| c.trim() != w) {
        return Err(bad(
            1,
            format!("expected header file,set,score_from_s,score_to_s[,note], got `{header}`"),
        ));
    }
    let mut out = Vec::new();
    for (i, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let f = split_csv(line);
        if f.len() < 4 {
            return Err(bad(
                i + 1,
                format!("expected at least 4 fields, got {}", f.len()),
            ));
        }
        let num = |s: &str| {
            s.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(i + 1, format!("`{s}` is not a number")))
        };
        let (from, to) = (num(&f[2])?, num(&f[3])?);
        if to < from {
            return Err(bad(i + 1, format!("score_to_s {to} < score_from_s {from}")));
        }
        out.push(Entry {
            file: PathBuf::from(f[0].trim()),
            set: f[1].trim().to_string(),
            score_from_s: from,
            score_to_s: to,
            note: f.get(4).cloned().unwrap_or_default(),
        });
    }
    if out.is_empty() {
        return Err(bad(2, "manifest lists no scenes".into()));
    }
    Ok(out)
}

/// The path a manifest in `manifest`'s folder names `wav` by: relative to that folder when `wav`
/// lies below it, else `wav`'s absolute path (the manifest's reader joins a row's file to its
/// folder, which leaves an absolute path as it is).
#[must_use]
pub fn scene_path(manifest: &Path, wav: &Path) -> std::path::PathBuf {
    let dir = crate::io::output_file::folder_of(manifest);
    let (Ok(dir), Ok(wav_abs)) = (std::path::absolute(dir), std::path::absolute(wav)) else {
        return wav.to_path_buf();
    };
    let normal = |p: &Path| -> std::path::PathBuf {
        p.components()
            .filter(|c| !matches!(c, std::path::Component::CurDir))
            .collect()
    };
    match normal(&wav_abs).strip_prefix(normal(&dir)) {
        Ok(rel) => rel.to_path_buf(),
        Err(_) => wav_abs,
    }
}

/// Removes `path` when it is a regular file that starts with the line `header`: a truth file an
/// earlier scene of the same name left, which the new scene does not replace (fewer talkers, no
/// noise source). Anything else at `path` is left alone.
pub fn remove_stale(path: &Path, header: &str) -> Result<()> {
    let is_file = std::fs::symlink_metadata(path).is_ok_and(|m| m.is_file());
    if !is_file {
        return Ok(());
    }
    let ours = std::fs::read_to_string(path)
        .ok()
        .is_some_and(|t| t.lines().next().map(str::trim) == Some(header));
    match ours {
        true => std::fs::remove_file(path).map_err(|e| SimError::io(path, e)),
        false => Ok(()),
    }
}

/// Checks, before a scene is rendered, that `manifest` can take its row: the folder exists, and a
/// manifest that exists already starts with `header`, the one `kind` scenes (single-talker or
/// multi-talker) write: they keep manifests of their own, `host-sim eval` reads one kind per folder.
pub fn check_appendable(manifest: &Path, header: &str, kind: &str) -> Result<()> {
    crate::io::output_file::check_folder(manifest)?;
    if !manifest.exists() {
        return Ok(());
    }
    let text = crate::io::text_file::read(manifest)?;
    let first = text.lines().next().map(str::trim).unwrap_or_default();
    if first == header {
        return Ok(());
    }
    Err(SimError::Usage(format!(
        "--manifest {}: its header is `{first}`, not the {kind} scenes' `{header}`; give the scene a \
         manifest of its own (in another folder)",
        manifest.display()
    )))
}

/// Appends the line `row` to the manifest file `manifest`, creating it with the line `header`
/// first when it does not exist.
pub fn append_row(manifest: &Path, header: &str, row: &str) -> Result<()> {
    use std::io::Write;
    let new = !manifest.exists();
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(manifest)
        .map_err(|e| SimError::writing(manifest, e))?;
    if new {
        writeln!(f, "{header}").map_err(|e| SimError::writing(manifest, e))?;
    }
    writeln!(f, "{row}").map_err(|e| SimError::writing(manifest, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quoted_fields() {
        assert_eq!(
            split_csv(r#"a,b,"c, ""d""",e"#),
            vec!["a", "b", "c, \"d\"", "e"]
        );
    }
}
