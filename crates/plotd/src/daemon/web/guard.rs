//! Who may use the page's API: requests for this host only (DNS
//! rebinding), from the page itself (CSRF), with the token when there is one.
//!
//! A page on another site can make a browser send requests to
//! `127.0.0.1:8765` (a form's POST, `fetch` in no-cors mode, an
//! `EventSource`), or rename its own host to ours by DNS; either would let
//! it drive the plotter. Browsers always say which page a request comes
//! from (`Origin` on every POST and cross-origin request,
//! `Sec-Fetch-Site`), and which host they think they talk to (`Host`):
//! both must be ours. Programs such as curl send no `Origin`; they need
//! the token, when the daemon has one, like the page does.

use axum::http::{header, HeaderMap, StatusCode};

/// Why a request is refused, as its status and message.
#[derive(Debug, PartialEq, Eq)]
pub struct Refusal {
    /// 403 (not from our page, or not for our host) or 401 (no token).
    pub status: StatusCode,
    /// What is wrong, for whoever reads the reply.
    pub message: String,
}

/// The checks for one listening address.
#[derive(Clone, Debug)]
pub struct Guard {
    /// The port the page is served on: a `Host` must name it.
    pub port: u16,
    /// This machine's names (its hostname, with and without `.local`), which
    /// a `Host` may use besides an IP address and `localhost`.
    pub names: Vec<String>,
    /// The bearer token, when `token_file` is set.
    pub token: Option<String>,
}

fn forbidden(message: String) -> Refusal {
    Refusal { status: StatusCode::FORBIDDEN, message }
}

impl Guard {
    /// Checks `Host` and `Origin`: every request, the page included.
    ///
    /// # Errors
    /// 403 for a host that is not this machine's (a DNS name rebound to it)
    /// or a request from another page.
    pub fn same_origin(&self, headers: &HeaderMap) -> Result<(), Refusal> {
        let host = text(headers, header::HOST.as_str()).ok_or_else(|| forbidden("no Host header".into()))?;
        if !self.is_our_host(host) {
            return Err(forbidden(format!("Host {host:?} is not this plotd's address (a name another site points here?)")));
        }
        if let Some(origin) = text(headers, header::ORIGIN.as_str()) {
            let ours = format!("http://{host}");
            if !origin.eq_ignore_ascii_case(&ours) {
                return Err(forbidden(format!("Origin {origin:?} is another site's: only the page at {ours} may use the API")));
            }
        }
        match text(headers, "sec-fetch-site") {
            None | Some("same-origin" | "none") => Ok(()),
            Some(site) => Err(forbidden(format!("a request from another site (Sec-Fetch-Site: {site})"))),
        }
    }

    /// Checks the bearer token (`Authorization: Bearer TOKEN`, or for an
    /// event stream, which a browser opens without headers of its own,
    /// `?token=TOKEN`).
    ///
    /// # Errors
    /// 401 when the daemon has a token and the request has not that one.
    pub fn authorised(&self, headers: &HeaderMap, query: Option<&str>) -> Result<(), Refusal> {
        let Some(token) = &self.token else { return Ok(()) };
        let bearer = text(headers, header::AUTHORIZATION.as_str()).and_then(|a| a.strip_prefix("Bearer "));
        let queried = query.into_iter().flat_map(|q| q.split('&')).find_map(|kv| kv.strip_prefix("token="));
        match bearer.or(queried) {
            Some(given) if same_secret(given.trim(), token) => Ok(()),
            Some(_) => Err(Refusal { status: StatusCode::UNAUTHORIZED, message: "wrong token".into() }),
            None => Err(Refusal {
                status: StatusCode::UNAUTHORIZED,
                message: "this plotd asks for its token (web.token_file): send `Authorization: Bearer TOKEN`".into(),
            }),
        }
    }

    /// An IP address, `localhost` or one of the machine's names, with our port.
    fn is_our_host(&self, host: &str) -> bool {
        let Some((name, port)) = host.rsplit_once(':') else { return false };
        if port.parse() != Ok(self.port) {
            return false;
        }
        let bare = name.strip_prefix('[').and_then(|n| n.strip_suffix(']')).unwrap_or(name);
        bare.parse::<std::net::IpAddr>().is_ok()
            || name.eq_ignore_ascii_case("localhost")
            || self.names.iter().any(|n| n.eq_ignore_ascii_case(name))
    }
}

fn text<'h>(headers: &'h HeaderMap, name: &str) -> Option<&'h str> {
    headers.get(name).and_then(|v| v.to_str().ok())
}

/// Compares a secret without stopping at the first difference, so the time
/// taken does not tell how much of a guess was right.
fn same_secret(given: &str, ours: &str) -> bool {
    given.len() == ours.len() && given.bytes().zip(ours.bytes()).fold(0u8, |acc, (a, b)| acc | (a ^ b)) == 0
}

/// This machine's names a browser on the LAN may use for it.
#[must_use]
pub fn machine_names() -> Vec<String> {
    match nix::unistd::gethostname().ok().and_then(|h| h.into_string().ok()) {
        Some(h) if !h.is_empty() => vec![format!("{h}.local"), h],
        _ => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn headers(pairs: &[(&'static str, &str)]) -> HeaderMap {
        let mut h = HeaderMap::new();
        for (k, v) in pairs {
            h.insert(*k, v.parse().unwrap());
        }
        h
    }

    fn guard(token: Option<&str>) -> Guard {
        Guard { port: 8765, names: vec!["studio".into(), "studio.local".into()], token: token.map(str::to_owned) }
    }

    #[test]
    fn only_our_host_and_our_page() {
        let g = guard(None);
        for host in ["127.0.0.1:8765", "localhost:8765", "[::1]:8765", "192.168.1.20:8765", "studio.local:8765", "STUDIO:8765"] {
            assert_eq!(g.same_origin(&headers(&[("host", host)])), Ok(()), "{host}");
            let origin = format!("http://{host}");
            assert_eq!(
                g.same_origin(&headers(&[("host", host), ("origin", &origin), ("sec-fetch-site", "same-origin")])),
                Ok(()),
                "{host}"
            );
        }
        // DNS rebinding: a name of the attacker's, pointed at 127.0.0.1.
        for host in ["evil.example:8765", "127.0.0.1:80", "localhost", "127.0.0.1.evil.example:8765"] {
            let r = g.same_origin(&headers(&[("host", host)])).unwrap_err();
            assert_eq!(r.status, StatusCode::FORBIDDEN, "{host}");
        }
        assert_eq!(g.same_origin(&HeaderMap::new()).unwrap_err().status, StatusCode::FORBIDDEN);
        // CSRF: another page, another port, an opaque origin.
        for origin in ["http://evil.example", "http://127.0.0.1:9999", "https://127.0.0.1:8765", "null"] {
            let r = g.same_origin(&headers(&[("host", "127.0.0.1:8765"), ("origin", origin)])).unwrap_err();
            assert_eq!(r.status, StatusCode::FORBIDDEN, "{origin}");
            assert!(r.message.contains("another site"), "{}", r.message);
        }
        let r = g.same_origin(&headers(&[("host", "127.0.0.1:8765"), ("sec-fetch-site", "cross-site")])).unwrap_err();
        assert_eq!(r.status, StatusCode::FORBIDDEN);
    }

    #[test]
    fn the_token_when_there_is_one() {
        assert_eq!(guard(None).authorised(&HeaderMap::new(), None), Ok(()));
        let g = guard(Some("s3cret"));
        assert_eq!(g.authorised(&HeaderMap::new(), None).unwrap_err().status, StatusCode::UNAUTHORIZED);
        assert_eq!(g.authorised(&headers(&[("authorization", "Bearer s3cret")]), None), Ok(()));
        assert_eq!(g.authorised(&headers(&[("authorization", "Bearer s3cre")]), None).unwrap_err().message, "wrong token");
        assert_eq!(g.authorised(&headers(&[("authorization", "Basic s3cret")]), None).unwrap_err().status, StatusCode::UNAUTHORIZED);
        assert_eq!(g.authorised(&HeaderMap::new(), Some("a=1&token=s3cret")), Ok(()));
        assert_eq!(g.authorised(&HeaderMap::new(), Some("token=nope")).unwrap_err().status, StatusCode::UNAUTHORIZED);
    }
}
