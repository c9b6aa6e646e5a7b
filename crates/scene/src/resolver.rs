//! Where a scene's named files come from: one small trait between the
//! loaders and the bytes, so the same loaders read from disk (`plotd
//! render`) or from the files a client sent with a job (the daemon, which
//! must never open a path a scene names).

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::path::{Component, Path, PathBuf};
use thiserror::Error;

/// Why a named file could not be had.
#[derive(Debug, Error)]
pub enum ReadError {
    /// The file could not be read.
    #[error("cannot read the file: {0}")]
    Io(#[source] std::io::Error),
    /// The file is larger than the loader's limit.
    #[error("file is {size} bytes, more than the limit of {limit}")]
    TooLarge {
        /// Its size.
        size: u64,
        /// The limit.
        limit: u64,
    },
    /// The resolver does not serve this path (not attached, absolute, or
    /// leaving the scene's directory).
    #[error("{0}")]
    Refused(String),
}

/// Reads the files a scene names. `path` is the scene's directory joined with
/// the name as written in the scene (so exactly the name as written when the
/// scene's path has no directory).
pub trait Resolver {
    /// The whole file, refusing more than `limit` bytes.
    ///
    /// # Errors
    /// [`ReadError`].
    fn read(&self, path: &Path, limit: u64) -> Result<Vec<u8>, ReadError>;
}

/// The default: the local file system.
#[derive(Clone, Copy, Debug, Default)]
pub struct FileSystem;

impl Resolver for FileSystem {
    fn read(&self, path: &Path, limit: u64) -> Result<Vec<u8>, ReadError> {
        let size = std::fs::metadata(path).map_err(ReadError::Io)?.len();
        if size > limit {
            return Err(ReadError::TooLarge { size, limit });
        }
        std::fs::read(path).map_err(ReadError::Io)
    }
}

/// The key a named file travels under: the relative name as written, `.`
/// components dropped, `/`-separated.
///
/// # Errors
/// The path is absolute, has a `..` component, or is not UTF-8: such a name
/// could reach outside the scene's directory, so it is never attached or served.
pub fn attachment_key(path: &Path) -> Result<String, String> {
    let mut parts = Vec::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::Normal(p) => parts.push(p.to_str().ok_or_else(|| format!("`{}` is not UTF-8", crate::excerpt::shown_path(path)))?),
            Component::ParentDir => return Err(format!("`{}` leaves the scene's directory (`..`)", crate::excerpt::shown_path(path))),
            Component::RootDir | Component::Prefix(_) => return Err(format!("`{}` is an absolute path", crate::excerpt::shown_path(path))),
        }
    }
    if parts.is_empty() {
        return Err(format!("`{}` names no file", crate::excerpt::shown_path(path)));
    }
    Ok(parts.join("/"))
}

/// Files held in memory by [`attachment_key`]: what a daemon renders a
/// submitted scene with. Serves those and nothing else; never touches the
/// file system.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Attached {
    /// Contents by key.
    pub files: BTreeMap<String, Vec<u8>>,
}

impl Resolver for Attached {
    fn read(&self, path: &Path, limit: u64) -> Result<Vec<u8>, ReadError> {
        let refused =
            |why: String| ReadError::Refused(format!("not served: {why}; only files sent with the job are read, by relative name"));
        let key = attachment_key(path).map_err(refused)?;
        let bytes = self.files.get(&key).ok_or_else(|| {
            // Names are the client's: a few of them, each cut short.
            let mut sent: Vec<String> = self.files.keys().take(5).map(|k| crate::excerpt::excerpt(k)).collect();
            if self.files.len() > 5 {
                sent.push(format!("and {} more", self.files.len() - 5));
            }
            let sent = if sent.is_empty() { "none".to_owned() } else { sent.join(", ") };
            refused(format!("`{}` was not sent with the job (sent: {sent})", crate::excerpt::excerpt(&key)))
        })?;
        let size = bytes.len() as u64;
        if size > limit {
            return Err(ReadError::TooLarge { size, limit });
        }
        Ok(bytes.clone())
    }
}

/// Reads from `dir` on disk and keeps a copy of every file read under its
/// [`attachment_key`]: load a scene through it (with the scene's path given
/// without a directory) and [`Recorder::into_files`] holds exactly the files
/// the scene needs, ready to attach to a job.
#[derive(Debug)]
pub struct Recorder {
    dir: PathBuf,
    files: RefCell<BTreeMap<String, Vec<u8>>>,
}

impl Recorder {
    /// Records files read relative to `dir` (the scene file's directory).
    #[must_use]
    pub fn new(dir: impl Into<PathBuf>) -> Recorder {
        Recorder { dir: dir.into(), files: RefCell::default() }
    }

    /// The files read so far, by key.
    #[must_use]
    pub fn into_files(self) -> BTreeMap<String, Vec<u8>> {
        self.files.into_inner()
    }
}

impl Resolver for Recorder {
    fn read(&self, path: &Path, limit: u64) -> Result<Vec<u8>, ReadError> {
        let key = attachment_key(path).map_err(|why| {
            ReadError::Refused(format!("cannot be sent to the daemon: {why}; name files relative to the scene, inside its directory"))
        })?;
        let bytes = FileSystem.read(&self.dir.join(path), limit)?;
        self.files.borrow_mut().insert(key, bytes.clone());
        Ok(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_relative_names_as_written() {
        assert_eq!(attachment_key(Path::new("a.csv")).unwrap(), "a.csv");
        assert_eq!(attachment_key(Path::new("./map/a.csv")).unwrap(), "map/a.csv");
        assert!(attachment_key(Path::new("/etc/passwd")).unwrap_err().contains("absolute"));
        assert!(attachment_key(Path::new("map/../../x")).unwrap_err().contains(".."));
        assert!(attachment_key(Path::new("")).is_err());
    }

    #[test]
    fn attached_serves_only_its_files() {
        let a = Attached { files: BTreeMap::from([("map/a.csv".to_owned(), b"x,y\n".to_vec())]) };
        assert_eq!(a.read(Path::new("./map/a.csv"), 100).unwrap(), b"x,y\n");
        assert!(matches!(a.read(Path::new("map/a.csv"), 2), Err(ReadError::TooLarge { size: 4, limit: 2 })));
        for p in ["/etc/passwd", "../a.csv", "b.csv"] {
            let e = a.read(Path::new(p), 100).unwrap_err().to_string();
            assert!(e.contains("not served") && e.contains(p.trim_start_matches("../")), "{e}");
        }
        // An attachment keyed like an escape is never reachable.
        let evil = Attached { files: BTreeMap::from([("../x".to_owned(), vec![1])]) };
        assert!(evil.read(Path::new("../x"), 100).is_err());
    }

    #[test]
    fn recorder_keeps_what_was_read() {
        let dir = std::env::temp_dir().join(format!("hiddenline-recorder-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("m")).unwrap();
        std::fs::write(dir.join("m/p.csv"), b"name,x,y,value\n").unwrap();
        let r = Recorder::new(&dir);
        assert_eq!(r.read(Path::new("m/p.csv"), 100).unwrap(), b"name,x,y,value\n");
        assert!(r.read(Path::new("/etc/hostname"), 100).unwrap_err().to_string().contains("absolute"));
        assert!(matches!(r.read(Path::new("missing.csv"), 100), Err(ReadError::Io(_))));
        assert_eq!(r.into_files().into_keys().collect::<Vec<_>>(), ["m/p.csv"]);
        std::fs::remove_dir_all(&dir).ok();
    }
}
