//! The token check shared by the gRPC workers (`authorization: Bearer …` metadata) and
//! the HTTP job service (the same header, or `?token=` where a browser cannot set
//! one): compared in constant time, so the time an answer takes tells nothing about
//! how much of a guess was right.
//!
//! An empty token is no token: [`parse_token`] refuses one where it is configured
//! (a flag, `RIDGELINE_TOKEN=`, a library config), and [`bearer_matches`] never
//! matches an empty expected token, so a service or worker handed one by a path that
//! skipped the check still lets nobody in rather than everybody.

/// Longest token accepted (it travels in every request's header).
pub const MAX_TOKEN_LEN: usize = 1024;

/// Checks a configured token: refused when empty or blank, longer than
/// [`MAX_TOKEN_LEN`], or holding characters an HTTP header cannot carry (controls,
/// non-ASCII) or surrounding spaces (a header value loses them).
pub fn parse_token(s: &str) -> Result<String, String> {
    if s.trim().is_empty() {
        return Err(
            "the token is empty: an empty token is no token; give one (for example `openssl rand -hex 32`) or leave the token out".into(),
        );
    }
    if s.len() > MAX_TOKEN_LEN {
        return Err(format!("the token has {} bytes, more than {MAX_TOKEN_LEN}", s.len()));
    }
    if s.trim() != s {
        return Err("the token starts or ends with a space, which an HTTP header does not keep".into());
    }
    if let Some(c) = s.chars().find(|c| !c.is_ascii() || c.is_ascii_control()) {
        return Err(format!("the token holds {c:?}: use printable ASCII, which an HTTP header can carry"));
    }
    Ok(s.to_string())
}

/// Whether an `authorization` value is `Bearer {token}`, compared in constant time.
/// An empty `token` matches nothing.
pub fn bearer_matches(got: &str, token: &str) -> bool {
    if token.is_empty() {
        return false;
    }
    let want = format!("Bearer {token}");
    let (a, b) = (got.as_bytes(), want.as_bytes());
    let mut diff = u8::from(a.len() != b.len());
    for i in 0..a.len().min(b.len()) {
        diff |= a[i] ^ b[i];
    }
    diff == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_exact_bearer_token_matches() {
        assert!(bearer_matches("Bearer s3cret", "s3cret"));
        for wrong in ["Bearer s3cre", "Bearer s3cret!", "bearer s3cret", "s3cret", "Bearer ", ""] {
            assert!(!bearer_matches(wrong, "s3cret"), "{wrong:?}");
        }
        // a token of 256 more bytes than the guess is not matched by a length that
        // wraps around in a byte
        assert!(!bearer_matches("Bearer a", &format!("a{}", "b".repeat(256))));
    }

    #[test]
    fn an_empty_token_is_no_token() {
        for got in ["Bearer ", "Bearer", "", " "] {
            assert!(!bearer_matches(got, ""), "{got:?}");
        }
        for bad in ["", " ", "\t", " s3cret", "s3cret\n", "s\u{0}c", "söt"] {
            assert!(parse_token(bad).is_err(), "{bad:?}");
        }
        assert!(parse_token(&"x".repeat(MAX_TOKEN_LEN + 1)).is_err());
        assert_eq!(parse_token("a/b+c=").as_deref(), Ok("a/b+c="));
    }
}
