//! Directories and files another local user could have planted.
//!
//! The daemon's socket may live under `/tmp` (no `XDG_RUNTIME_DIR` under
//! `su`, cron or ssh without pam_systemd), and a spool may be configured
//! anywhere. Another user who creates that directory first, or plants a
//! symlink or a FIFO in it, would receive a user's jobs, make the daemon
//! write through the link, or block its start. So before the daemon uses its
//! socket or spool directory, and before a client connects, the directory is
//! checked here, and the spool opens its files without following links and
//! reads only regular files of its own user.
//!
//! The rules, as OpenSSH's `StrictModes` has them:
//! - **a directory the daemon uses is its own**: not a symlink, owned by the
//!   daemon's user, writable by no one else ([`check_own_dir`]);
//! - **a socket's directory seen by a client** is owned by the client's user
//!   or root, or by another account under a parent only root or the user can
//!   write (`/run/plotd`, made by systemd for the `plotd` user), and no one
//!   else can write it ([`check_socket_dir`]);
//! - **every directory above** is owned by root or the user, and one that
//!   others can write has the sticky bit (`/tmp`), so nobody can swap the
//!   directory below it.

use nix::sys::stat::Mode;
use nix::unistd::Uid;
use std::fs::{File, Metadata, OpenOptions};
use std::io::Read;
use std::os::unix::fs::{MetadataExt, OpenOptionsExt};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// A path that someone other than its rightful user could have made or changed.
#[derive(Debug, Error)]
#[error("{path}: {problem}")]
pub struct UntrustedPath {
    /// The directory or file.
    pub path: PathBuf,
    /// What is wrong, and what to do.
    pub problem: Problem,
}

/// What is wrong with an [`UntrustedPath`].
#[derive(Debug, Error)]
pub enum Problem {
    /// It cannot be looked at.
    #[error("{0}")]
    Unreadable(std::io::Error),
    /// A symbolic link where a directory or file must be.
    #[error("is a symbolic link; another user may have planted it: remove it")]
    Symlink,
    /// Not a directory.
    #[error("is not a directory")]
    NotDirectory,
    /// Not a regular file (a FIFO, a device, a socket...).
    #[error("is not a regular file; another user may have planted it: remove it")]
    NotRegularFile,
    /// Owned by another user.
    #[error(
        "is owned by uid {owner}, not by uid {expected} who uses it; another user may have made it to receive the jobs: \
         remove it (as root), or choose another path"
    )]
    Owner {
        /// Its owner.
        owner: u32,
        /// Who should own it.
        expected: u32,
    },
    /// Others can write it.
    #[error("can be written by other users (mode {mode:04o}): chmod go-w it, or choose another path")]
    Writable {
        /// Its permission bits.
        mode: u32,
    },
}

fn untrusted(path: &Path, problem: Problem) -> UntrustedPath {
    UntrustedPath { path: path.to_owned(), problem }
}

const GROUP_WRITE: u32 = 0o020;
const OTHER_WRITE: u32 = 0o002;

/// `dir` itself, not a link: a directory.
fn dir_metadata(dir: &Path) -> Result<Metadata, UntrustedPath> {
    let meta = std::fs::symlink_metadata(dir).map_err(|e| untrusted(dir, Problem::Unreadable(e)))?;
    if meta.file_type().is_symlink() {
        return Err(untrusted(dir, Problem::Symlink));
    }
    if !meta.is_dir() {
        return Err(untrusted(dir, Problem::NotDirectory));
    }
    Ok(meta)
}

/// Checks the directories above `dir` (links in them resolved, as the
/// kernel resolves them): each owned by root or `uid`, and sticky where
/// others may write it. Returns whether `dir`'s own parent is one only root
/// or `uid` can write (then it vouches for an owner of its children).
fn check_ancestors(dir: &Path, uid: u32) -> Result<bool, UntrustedPath> {
    let Some(parent) = dir.parent().filter(|p| !p.as_os_str().is_empty()) else { return Ok(true) };
    let parent = parent.canonicalize().map_err(|e| untrusted(parent, Problem::Unreadable(e)))?;
    let mut closed = None;
    for ancestor in parent.ancestors() {
        let meta = std::fs::metadata(ancestor).map_err(|e| untrusted(ancestor, Problem::Unreadable(e)))?;
        if meta.uid() != 0 && meta.uid() != uid {
            return Err(untrusted(ancestor, Problem::Owner { owner: meta.uid(), expected: uid }));
        }
        let mode = meta.mode() & 0o7777;
        let sticky = mode & Mode::S_ISVTX.bits() != 0;
        if mode & OTHER_WRITE != 0 && !sticky {
            return Err(untrusted(ancestor, Problem::Writable { mode }));
        }
        closed.get_or_insert(mode & (GROUP_WRITE | OTHER_WRITE) == 0);
    }
    Ok(closed.unwrap_or(true))
}

/// Checks that `dir` is the daemon's own: a directory (not a link) owned by
/// the effective user, writable by no one else, under directories no one
/// else can swap.
///
/// # Errors
/// [`UntrustedPath`] naming the directory and what is wrong.
pub fn check_own_dir(dir: &Path) -> Result<(), UntrustedPath> {
    let uid = Uid::effective().as_raw();
    let meta = dir_metadata(dir)?;
    if meta.uid() != uid {
        return Err(untrusted(dir, Problem::Owner { owner: meta.uid(), expected: uid }));
    }
    let mode = meta.mode() & 0o7777;
    if mode & (GROUP_WRITE | OTHER_WRITE) != 0 {
        return Err(untrusted(dir, Problem::Writable { mode }));
    }
    check_ancestors(dir, uid).map(|_| ())
}

/// Checks, for a client run by `uid`, the directory of the socket it is
/// about to connect to: not a link, writable by no one else, owned by `uid`
/// or root, or by another account (a system daemon's) where only root or
/// `uid` could have made it.
///
/// # Errors
/// [`UntrustedPath`] naming the directory and what is wrong.
pub fn check_socket_dir(dir: &Path, uid: u32) -> Result<(), UntrustedPath> {
    let meta = dir_metadata(dir)?;
    let mode = meta.mode() & 0o7777;
    if mode & (GROUP_WRITE | OTHER_WRITE) != 0 {
        return Err(untrusted(dir, Problem::Writable { mode }));
    }
    let vouched = check_ancestors(dir, uid)?;
    let owner = meta.uid();
    if owner != uid && owner != 0 && !vouched {
        return Err(untrusted(dir, Problem::Owner { owner, expected: uid }));
    }
    Ok(())
}

/// Opens `path` for reading if it is a regular file of the effective user,
/// without following a link and without blocking on a FIFO.
///
/// # Errors
/// The OS error, or [`std::io::ErrorKind::InvalidData`] with the
/// [`UntrustedPath`] when it is a link, not a regular file, or another
/// user's.
pub fn open_own_file(path: &Path) -> std::io::Result<File> {
    let file = OpenOptions::new().read(true).custom_flags(nix::libc::O_NOFOLLOW | nix::libc::O_NONBLOCK).open(path).map_err(|e| {
        if e.raw_os_error() == Some(nix::libc::ELOOP) {
            std::io::Error::new(std::io::ErrorKind::InvalidData, untrusted(path, Problem::Symlink))
        } else {
            e
        }
    })?;
    check_own_file(path, &file)?;
    Ok(file)
}

/// Opens `path` to write (and with `read`, to read too), created with
/// `mode` when it is not there and never truncated, without following a
/// link, if it is then a regular file of the effective user.
///
/// # Errors
/// The OS error, or [`std::io::ErrorKind::InvalidData`] with the
/// [`UntrustedPath`] when it is not a regular file, or another user's.
pub fn open_own_file_to_write(path: &Path, mode: u32, read: bool) -> std::io::Result<File> {
    let file =
        OpenOptions::new().read(read).write(true).create(true).truncate(false).custom_flags(nix::libc::O_NOFOLLOW).mode(mode).open(path)?;
    check_own_file(path, &file)?;
    Ok(file)
}

/// `file`, opened at `path`, is a regular file of the effective user.
///
/// # Errors
/// [`std::io::ErrorKind::InvalidData`] with the [`UntrustedPath`].
pub fn check_own_file(path: &Path, file: &File) -> std::io::Result<()> {
    let meta = file.metadata()?;
    let problem = if !meta.is_file() {
        Problem::NotRegularFile
    } else if meta.uid() != Uid::effective().as_raw() {
        Problem::Owner { owner: meta.uid(), expected: Uid::effective().as_raw() }
    } else {
        return Ok(());
    };
    Err(std::io::Error::new(std::io::ErrorKind::InvalidData, untrusted(path, problem)))
}

/// The whole content of [`open_own_file`]`(path)`.
///
/// # Errors
/// As [`open_own_file`], and read errors.
pub fn read_own_file(path: &Path) -> std::io::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    open_own_file(path)?.read_to_end(&mut bytes)?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    /// Another account's uid, for tests that change owners (as root only).
    const NOBODY: u32 = 65534;

    fn root() -> bool {
        Uid::effective().is_root()
    }

    /// Whether a test that needs root may run; under CI it must.
    fn needs_root(test: &str) -> bool {
        if root() {
            return true;
        }
        assert!(std::env::var_os("CI").is_none(), "{test} needs root (CI runs as root)");
        eprintln!("{test}: skipped, not root");
        false
    }

    fn chmod(p: &Path, mode: u32) {
        std::fs::set_permissions(p, std::fs::Permissions::from_mode(mode)).unwrap();
    }

    #[test]
    fn own_directories_pass_and_links_and_open_ones_do_not() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("d");
        std::fs::create_dir(&dir).unwrap();
        chmod(&dir, 0o700);
        check_own_dir(&dir).unwrap();
        chmod(&dir, 0o755);
        check_own_dir(&dir).unwrap();
        chmod(&dir, 0o777);
        let e = check_own_dir(&dir).unwrap_err();
        assert!(matches!(e.problem, Problem::Writable { mode: 0o777 }), "{e}");
        assert!(e.to_string().contains("chmod go-w"), "{e}");
        chmod(&dir, 0o770);
        assert!(matches!(check_own_dir(&dir).unwrap_err().problem, Problem::Writable { .. }));
        chmod(&dir, 0o700);
        let link = tmp.path().join("link");
        std::os::unix::fs::symlink(&dir, &link).unwrap();
        let e = check_own_dir(&link).unwrap_err();
        assert!(matches!(e.problem, Problem::Symlink), "{e}");
        assert!(matches!(check_socket_dir(&link, 0).unwrap_err().problem, Problem::Symlink));
        let file = tmp.path().join("f");
        std::fs::write(&file, "").unwrap();
        assert!(matches!(check_own_dir(&file).unwrap_err().problem, Problem::NotDirectory));
        assert!(matches!(check_own_dir(&tmp.path().join("missing")).unwrap_err().problem, Problem::Unreadable(_)));
    }

    #[test]
    fn a_directory_squatted_under_tmp_is_refused_to_daemon_and_client() {
        if !needs_root("a_directory_squatted_under_tmp_is_refused_to_daemon_and_client") {
            return;
        }
        // As another user would leave `/tmp/plotd-<uid>`: theirs, 0700 or open.
        let tmp = tempfile::tempdir().unwrap();
        chmod(tmp.path(), 0o1777);
        let squat = tmp.path().join("plotd-1000");
        std::fs::create_dir(&squat).unwrap();
        nix::unistd::chown(&squat, Some(Uid::from_raw(NOBODY)), None).unwrap();
        chmod(&squat, 0o700);
        let e = check_own_dir(&squat).unwrap_err();
        assert!(matches!(e.problem, Problem::Owner { owner: NOBODY, expected: 0 }), "{e}");
        assert!(e.to_string().contains("another user may have made it"), "{e}");
        // The client (root here) refuses it too: a world-writable parent
        // vouches for no owner.
        let e = check_socket_dir(&squat, 0).unwrap_err();
        assert!(matches!(e.problem, Problem::Owner { owner: NOBODY, .. }), "{e}");
        // A system daemon's directory (another account's, made where only
        // root can write, as systemd makes /run/plotd) is fine for clients.
        let run = tempfile::tempdir().unwrap();
        chmod(run.path(), 0o755);
        let daemon_dir = run.path().join("plotd");
        std::fs::create_dir(&daemon_dir).unwrap();
        nix::unistd::chown(&daemon_dir, Some(Uid::from_raw(NOBODY)), None).unwrap();
        chmod(&daemon_dir, 0o755);
        check_socket_dir(&daemon_dir, 1000).unwrap();
        check_socket_dir(&daemon_dir, 0).unwrap();
    }

    #[test]
    fn an_ancestor_others_can_write_without_the_sticky_bit_is_refused() {
        let tmp = tempfile::tempdir().unwrap();
        let open = tmp.path().join("open");
        std::fs::create_dir(&open).unwrap();
        let dir = open.join("spool");
        std::fs::create_dir(&dir).unwrap();
        chmod(&dir, 0o700);
        chmod(&open, 0o777);
        let e = check_own_dir(&dir).unwrap_err();
        assert_eq!(e.path, open.canonicalize().unwrap());
        assert!(matches!(e.problem, Problem::Writable { mode: 0o777 }), "{e}");
        chmod(&open, 0o1777);
        check_own_dir(&dir).unwrap();
    }

    #[test]
    fn only_regular_files_of_our_own_are_read() {
        let tmp = tempfile::tempdir().unwrap();
        let file = tmp.path().join("7.json");
        std::fs::write(&file, "{}").unwrap();
        assert_eq!(read_own_file(&file).unwrap(), b"{}");
        let link = tmp.path().join("8.json");
        std::os::unix::fs::symlink(&file, &link).unwrap();
        let e = read_own_file(&link).unwrap_err();
        assert!(e.to_string().contains("symbolic link"), "{e}");
        // A FIFO would block a plain open for reading until a writer came.
        let fifo = tmp.path().join("9.json");
        nix::unistd::mkfifo(&fifo, Mode::S_IRUSR | Mode::S_IWUSR).unwrap();
        let e = read_own_file(&fifo).unwrap_err();
        assert!(e.to_string().contains("not a regular file"), "{e}");
        if root() {
            nix::unistd::chown(&file, Some(Uid::from_raw(NOBODY)), None).unwrap();
            let e = read_own_file(&file).unwrap_err();
            assert!(e.to_string().contains("owned by uid 65534"), "{e}");
        }
    }
}
