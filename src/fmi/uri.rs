//! `fmuResourceLocation`: the URI of the unzipped FMU's `resources` folder.
//!
//! Hosts disagree on its form: fmpy passes `file:///tmp/x/resources` (percent-encoded), the
//! FMI 2.0 text also allows `file:/tmp/x/resources`, OMSimulator produces
//! `file:////tmp/x/resources`, and some pass `file://localhost/...`. All are accepted, with or
//! without a trailing slash, and percent escapes (`%20` for a space) are decoded. A plain
//! absolute path is accepted too.

use std::path::PathBuf;

/// Turns a resource location into a local directory path, or says why it cannot.
pub fn resource_dir(location: &str) -> Result<PathBuf, String> {
    let location = location.trim();
    if location.is_empty() {
        return Err("the resource location is empty".into());
    }
    let path_part = match strip_prefix_ignore_case(location, "file:") {
        Some(rest) => {
            if let Some(after) = rest.strip_prefix("//") {
                // "//authority/path": the authority is empty (file:///), "localhost", or absent
                // because the path itself starts with slashes (file:////).
                if after.starts_with('/') {
                    after
                } else {
                    let end = after.find('/').unwrap_or(after.len());
                    let authority = &after[..end];
                    if !authority.eq_ignore_ascii_case("localhost") {
                        return Err(format!(
                            "resource location {location:?} names the host {authority:?}; only local files (file:///...) are supported"
                        ));
                    }
                    &after[end..]
                }
            } else {
                rest
            }
        }
        None => {
            if location.contains("://") {
                return Err(format!("resource location {location:?} is not a file: URI"));
            }
            location
        }
    };
    // Strip any query or fragment (not meaningful for a folder).
    let path_part = path_part.split(['?', '#']).next().unwrap_or("");
    let bytes = percent_decode(path_part).map_err(|e| format!("resource location {location:?}: {e}"))?;
    let mut path = bytes_to_path(bytes);
    // Collapse the leading slashes of `file:////tmp` and drop a trailing slash.
    let text = path.to_string_lossy().into_owned();
    if text.starts_with("//") {
        path = PathBuf::from(format!("/{}", text.trim_start_matches('/')));
    }
    if path.as_os_str().is_empty() {
        return Err(format!("resource location {location:?} has an empty path"));
    }
    Ok(path)
}

fn strip_prefix_ignore_case<'a>(s: &'a str, prefix: &str) -> Option<&'a str> {
    if s.len() >= prefix.len() && s.is_char_boundary(prefix.len()) && s[..prefix.len()].eq_ignore_ascii_case(prefix) {
        Some(&s[prefix.len()..])
    } else {
        None
    }
}

/// Decodes `%XX` escapes into bytes.
fn percent_decode(s: &str) -> Result<Vec<u8>, String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = b.get(i + 1..i + 3).and_then(|h| std::str::from_utf8(h).ok());
            match hex.and_then(|h| u8::from_str_radix(h, 16).ok()) {
                Some(v) => {
                    out.push(v);
                    i += 3;
                }
                None => return Err(format!("invalid percent escape at byte {i}")),
            }
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    Ok(out)
}

#[cfg(unix)]
fn bytes_to_path(bytes: Vec<u8>) -> PathBuf {
    use std::os::unix::ffi::OsStringExt;
    PathBuf::from(std::ffi::OsString::from_vec(bytes))
}

#[cfg(not(unix))]
fn bytes_to_path(bytes: Vec<u8>) -> PathBuf {
    PathBuf::from(String::from_utf8_lossy(&bytes).into_owned())
}

#[cfg(test)]
mod tests {
    use super::resource_dir;
    use std::path::PathBuf;

    #[test]
    fn accepts_every_file_uri_form() {
        let want = PathBuf::from("/tmp/my fmu/resources");
        for uri in [
            "file:///tmp/my%20fmu/resources",
            "file:/tmp/my%20fmu/resources",
            "file:////tmp/my%20fmu/resources",
            "file://localhost/tmp/my%20fmu/resources",
            "FILE:///tmp/my%20fmu/resources/",
            "file:///tmp/my fmu/resources",
            "/tmp/my fmu/resources",
        ] {
            let got = resource_dir(uri).unwrap_or_else(|e| panic!("{uri}: {e}"));
            assert_eq!(
                got.components().collect::<Vec<_>>(),
                want.components().collect::<Vec<_>>(),
                "{uri}"
            );
        }
    }

    #[test]
    fn decodes_non_ascii_escapes() {
        let p = resource_dir("file:///tmp/%C3%BCber/resources").unwrap();
        assert_eq!(p, PathBuf::from("/tmp/über/resources"));
    }

    #[test]
    fn rejects_remote_and_broken_locations() {
        assert!(resource_dir("").is_err());
        assert!(resource_dir("http://example.org/resources").is_err());
        assert!(resource_dir("file://server/share/resources").is_err());
        assert!(resource_dir("file:///tmp/bad%2").is_err());
        assert!(resource_dir("file:///tmp/bad%zz").is_err());
    }
}
