//! The web page's bearer token (`[web] token_file`): read, or made once.

use std::io::{Read, Write};
use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
use std::path::Path;

/// Random bytes in a new token (64 hexadecimal digits).
const TOKEN_BYTES: usize = 32;

/// The token in `path`; when the file is missing, a new random one written
/// there with mode 0600 and logged once, for the person to paste into the page.
///
/// # Errors
/// What is wrong with the file, naming it: unreadable, empty, or readable
/// by other users (anyone who can read it can drive the plotters).
pub fn load_or_create(path: &Path) -> Result<String, String> {
    let name = path.display();
    match std::fs::OpenOptions::new().write(true).create_new(true).mode(0o600).open(path) {
        Ok(mut file) => {
            let token = random_token().map_err(|e| format!("{name}: cannot make a token: {e}"))?;
            file.write_all(format!("{token}\n").as_bytes()).map_err(|e| format!("{name}: {e}"))?;
            file.sync_all().map_err(|e| format!("{name}: {e}"))?;
            tracing::warn!(token_file = %name, token = %token, "web token made; give it to the page when it asks (shown this once)");
            return Ok(token);
        }
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
        Err(e) => return Err(format!("{name}: cannot create it: {e}")),
    }
    let meta = std::fs::metadata(path).map_err(|e| format!("{name}: {e}"))?;
    if meta.permissions().mode() & 0o077 != 0 {
        return Err(format!("{name}: other users can read it (mode {:o}); `chmod 600` it", meta.permissions().mode() & 0o777));
    }
    let text = std::fs::read_to_string(path).map_err(|e| format!("{name}: {e}"))?;
    let token = text.trim();
    if token.is_empty() || token.chars().any(|c| c.is_whitespace() || c.is_control()) {
        return Err(format!("{name}: no token in it (one line, no spaces, expected)"));
    }
    Ok(token.to_owned())
}

fn random_token() -> std::io::Result<String> {
    let mut bytes = [0u8; TOKEN_BYTES];
    std::fs::File::open("/dev/urandom")?.read_exact(&mut bytes)?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn made_private_once_then_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("web.token");
        let made = load_or_create(&path).unwrap();
        assert_eq!(made.len(), 2 * TOKEN_BYTES);
        assert_eq!(std::fs::metadata(&path).unwrap().permissions().mode() & 0o777, 0o600);
        assert_eq!(load_or_create(&path).unwrap(), made);
        assert_ne!(load_or_create(&dir.path().join("other")).unwrap(), made);

        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o644)).unwrap();
        let e = load_or_create(&path).unwrap_err();
        assert!(e.contains("web.token") && e.contains("other users can read it"), "{e}");
        std::fs::write(dir.path().join("empty"), "\n").unwrap();
        std::fs::set_permissions(dir.path().join("empty"), std::fs::Permissions::from_mode(0o600)).unwrap();
        assert!(load_or_create(&dir.path().join("empty")).unwrap_err().contains("no token"));
        let e = load_or_create(&dir.path().join("no/such/dir/t")).unwrap_err();
        assert!(e.contains("cannot create it"), "{e}");
    }
}
