//! Writing an output file the way a Unix tool is expected to.
//!
//! - A **regular file** (or a path that does not exist yet) is written atomically: the output goes to
//!   a new temporary file in the same folder (created exclusively, so nothing else's file is
//!   touched), which replaces the target by a rename only once complete. A failed command leaves the
//!   old file, or nothing, behind. A replaced file keeps its permission bits; a new one gets
//!   `0666` less the umask, as `File::create` would.
//! - A **symbolic link** is followed: its target is written (atomically if it is a regular file or
//!   does not exist yet); the link stays a link.
//! - A **device node, FIFO or socket** (`/dev/null`, `/dev/stdout`, a named pipe) is never
//!   replaced: the output is composed in a temporary file and then copied into it, so a reader sees
//!   the whole output once it is complete, or nothing if the command fails. Paths under `/dev/` and
//!   `/proc/` are always treated so (`/dev/stdout` may lead to a regular file the shell opened).
//! - A folder is an error.

use crate::error::{Result, SimError};
use std::io;
use std::path::{Path, PathBuf};

/// Longest chain of symbolic links followed (as the kernel's `MAXSYMLINKS`).
const MAX_LINKS: usize = 40;

/// Where an output goes.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Target {
    /// A regular file or a new path: written atomically at this (link-free) path.
    Replace(PathBuf),
    /// Anything else that can be opened for writing: copied into, never replaced.
    Stream(PathBuf),
}

/// Follows the symbolic links of `path` (also a dangling one, whose target is then created).
fn resolve(path: &Path) -> Result<Target> {
    let special = |p: &Path| p.starts_with("/dev") || p.starts_with("/proc");
    if special(path) {
        return Ok(Target::Stream(path.to_path_buf()));
    }
    let mut p = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        let meta = match std::fs::symlink_metadata(&p) {
            Ok(m) => m,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Target::Replace(p)),
            Err(e) => return Err(SimError::writing(path, e)),
        };
        let kind = meta.file_type();
        if kind.is_symlink() {
            let link = std::fs::read_link(&p).map_err(|e| SimError::writing(&p, e))?;
            p = match p.parent() {
                Some(dir) if link.is_relative() => dir.join(link),
                _ => link,
            };
            if special(&p) {
                return Ok(Target::Stream(p));
            }
        } else if kind.is_file() {
            return Ok(Target::Replace(p));
        } else if kind.is_dir() {
            return Err(SimError::writing(
                path,
                io::Error::new(io::ErrorKind::IsADirectory, "is a folder, not a file"),
            ));
        } else {
            return Ok(Target::Stream(p));
        }
    }
    Err(SimError::writing(
        path,
        io::Error::other(format!("more than {MAX_LINKS} symbolic links")),
    ))
}

/// Writes an output file: `write` gets a temporary path to create and fill; on success the result
/// lands at `path` as the module documentation describes, on failure nothing at `path` changes.
pub fn write(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    // An error on the temporary file names the output instead: the hidden name means nothing to
    // the user.
    let write = move |tmp: &Path| {
        write(tmp).map_err(|e| match e {
            SimError::Io {
                path: p,
                op,
                source,
            } if p == tmp => SimError::Io {
                path: path.to_path_buf(),
                op: op.or(Some("write")),
                source,
            },
            e => e,
        })
    };
    match resolve(path)? {
        Target::Replace(target) => replace(&target, write),
        Target::Stream(target) => {
            let tmp = tempfile::NamedTempFile::new().map_err(|e| SimError::writing(path, e))?;
            write(tmp.path())?;
            let mut from =
                std::fs::File::open(tmp.path()).map_err(|e| SimError::writing(path, e))?;
            let mut to = std::fs::OpenOptions::new()
                .write(true)
                .open(&target)
                .map_err(|e| SimError::writing(path, e))?;
            io::copy(&mut from, &mut to)
                .and_then(|_| io::Write::flush(&mut to))
                .map(|_| ())
                .map_err(|e| SimError::writing(path, e))
        }
    }
}

/// The folder an output file `path` goes into (`.` for a bare name).
pub(crate) fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Checks before any work that the folder of the output `path` exists (outputs into it are written
/// at the end): the error names `path` and the missing folder. Links and device paths are left to
/// [`write()`].
pub fn check_folder(path: &Path) -> Result<()> {
    let dir = folder_of(path);
    if std::fs::symlink_metadata(path).is_err() && !dir.is_dir() {
        return Err(SimError::writing(
            path,
            io::Error::new(
                io::ErrorKind::NotFound,
                format!("the folder {} does not exist", dir.display()),
            ),
        ));
    }
    Ok(())
}

/// What a path leads to, for telling whether two paths are one file: the file's identity (device
/// and inode, links followed) when it exists, else its absolute path with the folder's links
/// resolved; `None` for device nodes, FIFOs and sockets (several outputs may go to `/dev/null`).
#[derive(Debug, PartialEq, Eq)]
enum FileKey {
    Existing(u64, u64),
    New(PathBuf),
}

fn file_key(path: &Path) -> Option<FileKey> {
    if path.as_os_str() == "-" || path.starts_with("/dev") || path.starts_with("/proc") {
        return None;
    }
    match std::fs::metadata(path) {
        Ok(meta) => {
            if !meta.is_file() {
                return None;
            }
            #[cfg(unix)]
            {
                use std::os::unix::fs::MetadataExt;
                Some(FileKey::Existing(meta.dev(), meta.ino()))
            }
            #[cfg(not(unix))]
            {
                std::fs::canonicalize(path).ok().map(FileKey::New)
            }
        }
        // A new file (or a dangling link: its target is what would be created).
        Err(_) => {
            let target = match resolve(path) {
                Ok(Target::Replace(p)) => p,
                _ => return None,
            };
            let dir = std::fs::canonicalize(folder_of(&target)).ok()?;
            Some(FileKey::New(dir.join(target.file_name()?)))
        }
    }
}

/// Refuses, before any work, a command whose outputs would overwrite one of its inputs or each
/// other: `inputs` and `outputs` are (flag, path) pairs, the flag as the user typed it (e.g.
/// `("--csv", path)`, or `("input", path)` for a positional argument). Paths are compared as the
/// files they lead to (through links, `./`, other names of the same file); standard input and
/// output, device nodes and FIFOs are left out.
pub fn check_distinct(inputs: &[(&str, &Path)], outputs: &[(&str, &Path)]) -> Result<()> {
    let keyed = |list: &[(&str, &Path)]| -> Vec<(String, PathBuf, FileKey)> {
        list.iter()
            .filter_map(|(flag, p)| file_key(p).map(|k| ((*flag).to_string(), p.to_path_buf(), k)))
            .collect()
    };
    let (ins, outs) = (keyed(inputs), keyed(outputs));
    // `--csv out.csv`, or `the input in.wav` for a positional argument.
    let named = |flag: &str, path: &Path| match flag.starts_with('-') {
        true => format!("{flag} {}", path.display()),
        false => format!("the {flag} {}", path.display()),
    };
    for (i, (flag, path, key)) in outs.iter().enumerate() {
        if let Some((in_flag, in_path, _)) = ins.iter().find(|(_, _, k)| k == key) {
            return Err(SimError::Usage(format!(
                "{} would overwrite {}: write the output to another file",
                named(flag, path),
                named(in_flag, in_path)
            )));
        }
        if let Some((other, other_path, _)) = outs[..i].iter().find(|(_, _, k)| k == key) {
            return Err(SimError::Usage(format!(
                "{} and {} are the same file: give each output its own",
                named(other, other_path),
                named(flag, path)
            )));
        }
    }
    Ok(())
}

/// Writes `target` (a regular file or a new path, no link) atomically through a temporary file in
/// its folder.
fn replace(target: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    check_folder(target)?;
    let dir = folder_of(target);
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let prefix = format!(".{name}.");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".partial");
    let existing = std::fs::metadata(target).ok().map(|m| m.permissions());
    #[cfg(unix)]
    if existing.is_none() {
        use std::os::unix::fs::PermissionsExt;
        // The mode passed to open(2), which the umask reduces, as for `File::create`.
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    // The temporary file's hidden name is no business of the user's: the error names the target.
    let tmp = builder.tempfile_in(dir).map_err(|e| {
        let text = e.to_string();
        let text = text
            .split(" at path ")
            .next()
            .unwrap_or_default()
            .to_string();
        SimError::writing(target, io::Error::new(e.kind(), text))
    })?;
    if let Some(p) = existing {
        std::fs::set_permissions(tmp.path(), p).map_err(|e| SimError::writing(target, e))?;
    }
    write(tmp.path())?;
    tmp.persist(target)
        .map(|_| ())
        .map_err(|e| SimError::writing(target, e.error))
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use std::os::unix::fs::{symlink, FileTypeExt, PermissionsExt};

    fn text(s: &'static str) -> impl FnOnce(&Path) -> Result<()> {
        move |tmp| std::fs::write(tmp, s).map_err(|e| SimError::io(tmp, e))
    }

    #[test]
    fn regular_files_are_replaced_atomically_keeping_their_mode() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.csv");
        write(&p, text("one\n")).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "one\n");
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o640)).unwrap();
        write(&p, text("two\n")).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "two\n");
        let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o640);
        // A failure leaves the old content and no temporary file.
        let e = write(&p, |_| Err(SimError::Other("failed".into()))).unwrap_err();
        assert_eq!(e.to_string(), "failed");
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "two\n");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_failed_write_names_the_output_and_the_operation_not_the_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.csv");
        let e = write(&p, |tmp| {
            Err(SimError::io(
                tmp,
                io::Error::other("no space left on device"),
            ))
        })
        .unwrap_err()
        .to_string();
        assert_eq!(
            e,
            format!("{}: cannot write: no space left on device", p.display())
        );
        let e = write(&dir.path().join("sub").join("x.csv"), text("x"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("x.csv: cannot write: the folder"), "{e}");
    }

    #[test]
    fn a_missing_folder_is_named_not_the_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("missing").join("out.csv");
        let e = write(&p, text("x")).unwrap_err().to_string();
        assert!(e.starts_with(&p.display().to_string()), "{e}");
        assert!(e.contains("missing does not exist"), "{e}");
        assert!(!e.contains(".partial"), "{e}");
        assert!(check_folder(&dir.path().join("here.csv")).is_ok());
    }

    #[test]
    fn symlinks_are_written_through() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("real.csv");
        std::fs::write(&target, "old").unwrap();
        let link = dir.path().join("link.csv");
        symlink("real.csv", &link).unwrap();
        write(&link, text("new")).unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new");
        // A dangling link: its target is created.
        let dangling = dir.path().join("dangling.csv");
        symlink(dir.path().join("sub-target.csv"), &dangling).unwrap();
        write(&dangling, text("made")).unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.path().join("sub-target.csv")).unwrap(),
            "made"
        );
        assert!(std::fs::symlink_metadata(&dangling)
            .unwrap()
            .file_type()
            .is_symlink());
    }

    #[test]
    fn device_nodes_are_written_into_not_replaced() {
        write(Path::new("/dev/null"), text("discarded")).unwrap();
        let meta = std::fs::metadata("/dev/null").unwrap();
        assert!(meta.file_type().is_char_device());
        let e = write(Path::new("/tmp"), text("x")).unwrap_err().to_string();
        assert!(e.contains("is a folder"), "{e}");
    }

    #[test]
    fn fifos_are_written_into_not_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        let status = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .expect("mkfifo runs");
        assert!(status.success());
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
        };
        write(&fifo, text("through the pipe\n")).unwrap();
        assert_eq!(reader.join().unwrap(), "through the pipe\n");
        assert!(std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo());
    }

    #[test]
    fn outputs_may_not_overwrite_inputs_or_each_other() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.wav");
        std::fs::write(&input, "RIFF").unwrap();
        let link = dir.path().join("link.csv");
        symlink("in.wav", &link).unwrap();
        let other_name = dir.path().join(".").join("in.wav");
        let new = dir.path().join("out.csv");
        let ins = [("input", input.as_path())];
        // The same file by its name, through a link and by another spelling.
        for out in [&input, &link, &other_name] {
            let e = check_distinct(&ins, &[("--csv", out)]).unwrap_err();
            assert!(matches!(e, SimError::Usage(_)), "{e:?}");
            let e = e.to_string();
            assert!(
                e.contains("--csv") && e.contains("would overwrite the input"),
                "{e}"
            );
        }
        // Two outputs into one file, new or existing.
        let e = check_distinct(&ins, &[("--tracks", &new), ("--csv", &new)])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("--tracks") && e.contains("--csv") && e.contains("same file"),
            "{e}"
        );
        // Distinct files, devices and stdout pass; nothing was written.
        let null = Path::new("/dev/null");
        let dash = Path::new("-");
        check_distinct(
            &ins,
            &[("--csv", &new), ("--tracks", null), ("--selfcal-out", null)],
        )
        .unwrap();
        check_distinct(&[("input", dash)], &[("--csv", dash)]).unwrap();
        assert_eq!(std::fs::read_to_string(&input).unwrap(), "RIFF");
        assert!(!new.exists());
    }
}
