//! The token check shared by the gRPC workers (`authorization: Bearer …` metadata) and
//! the HTTP job service (the same header, or `?token=` where a browser cannot set
//! one): compared in constant time, so the time an answer takes tells nothing about
//! how much of a guess was right.

/// Whether an `authorization` value is `Bearer {token}`, compared in constant time.
pub fn bearer_matches(got: &str, token: &str) -> bool {
    let want = format!("Bearer {token}");
    let (a, b) = (got.as_bytes(), want.as_bytes());
    let mut diff = (a.len() ^ b.len()) as u8;
    for i in 0..a.len().min(b.len()) {
        diff |= a[i] ^ b[i];
    }
    diff == 0 && a.len() == b.len()
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
    }
}
