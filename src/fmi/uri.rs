//! `fmuResourceLocation`: the URI of the unzipped FMU's `resources` folder.
//!
//! Hosts disagree on its form: fmpy passes `file:///tmp/x/resources` (percent-encoded), the
//! FMI 2.0 text also allows `file:/tmp/x/resources`, OMSimulator produces
//! `file:////tmp/x/resources`, and some pass `file://localhost/...`. All are accepted, with or
//! without a trailing slash, and percent escapes (`%20` for a space) are decoded. A plain
//! absolute path is accepted too.
//!
//! On Windows the same URIs name a drive (`file:///C:/Users/x/resources`,
//! `file:/C:/...`, the old `file:///C|/...`) or a share (`file://server/share/...`,
//! `file:////server/share/...`) and become `C:\Users\x\resources` or
//! `\\server\share\...`. [`resource_path`] is the conversion as a pure function of the text
//! and the operating system's path style, so both styles are tested on any machine;
//! [`resource_dir`] applies the style of the system the library was built for.

use std::path::PathBuf;

/// How the operating system writes paths.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PathStyle {
    /// `/dir/file`: Linux, macOS and the other Unix systems.
    Unix,
    /// `C:\dir\file` or `\\server\share\file`.
    Windows,
}

impl PathStyle {
    /// The style of the system this library was built for.
    pub const HOST: PathStyle = if cfg!(windows) {
        PathStyle::Windows
    } else {
        PathStyle::Unix
    };
}

/// Turns a resource location into a local directory path, or says why it cannot.
pub fn resource_dir(location: &str) -> Result<PathBuf, String> {
    resource_path(location, PathStyle::HOST).map(bytes_to_path)
}

/// FMI 3.0's `resourcePath`: the folder's path as it is (no percent-decoding: a `%` is a
/// character of the name), with or without a trailing separator. A `file:` URI, which FMI 2.0
/// hosts pass, is decoded as [`resource_dir`] does.
pub fn resource_folder(path: &str) -> Result<PathBuf, String> {
    if path.trim().is_empty() {
        return Err("the resource path is empty".into());
    }
    if path.get(..5).is_some_and(|p| p.eq_ignore_ascii_case("file:")) {
        return resource_dir(path);
    }
    Ok(PathBuf::from(path))
}

/// The directory a resource location names, as the bytes of a path in `style` (UTF-8 for
/// Windows; any bytes for Unix, whose file names need not be UTF-8).
pub fn resource_path(location: &str, style: PathStyle) -> Result<Vec<u8>, String> {
    let location = location.trim();
    if location.is_empty() {
        return Err("the resource location is empty".into());
    }
    let (host, path_part) = match strip_prefix_ignore_case(location, "file:") {
        Some(rest) => match rest.strip_prefix("//") {
            // "//authority/path": the authority is empty (file:///), "localhost", a server
            // (Windows shares), or absent because the path itself starts with slashes
            // (file:////).
            Some(after) if !after.starts_with('/') => {
                let end = after.find('/').unwrap_or(after.len());
                let authority = &after[..end];
                let local = authority.is_empty() || authority.eq_ignore_ascii_case("localhost");
                let host = (!local).then_some(authority);
                (host, &after[end..])
            }
            Some(after) => (None, after),
            None => (None, rest),
        },
        None => {
            if location.contains("://") {
                return Err(format!("resource location {location:?} is not a file: URI"));
            }
            (None, location)
        }
    };
    // Strip any query or fragment (not meaningful for a folder).
    let path_part = path_part.split(['?', '#']).next().unwrap_or("");
    let bytes = percent_decode(path_part).map_err(|e| format!("resource location {location:?}: {e}"))?;
    let path = match style {
        PathStyle::Unix => unix_path(host, bytes),
        PathStyle::Windows => windows_path(host, bytes),
    }
    .map_err(|e| format!("resource location {location:?} {e}"))?;
    if path.is_empty() {
        return Err(format!("resource location {location:?} has an empty path"));
    }
    Ok(path)
}

/// A Unix path: only local files; the leading slashes of `file:////tmp` collapse to one.
fn unix_path(host: Option<&str>, mut bytes: Vec<u8>) -> Result<Vec<u8>, String> {
    if let Some(host) = host {
        return Err(format!(
            "names the host {host:?}; only local files (file:///...) are supported"
        ));
    }
    if bytes.starts_with(b"//") {
        let slashes = bytes.iter().take_while(|&&b| b == b'/').count();
        bytes.drain(..slashes - 1);
    }
    Ok(bytes)
}

/// A Windows path: `C:\...` from `/C:/...` (or `/C|/...`), `\\server\share\...` from a host
/// or from two or more leading slashes; every `/` becomes `\`.
fn windows_path(host: Option<&str>, bytes: Vec<u8>) -> Result<Vec<u8>, String> {
    let text = String::from_utf8(bytes).map_err(|_| "is not UTF-8 once decoded".to_string())?;
    let slashes = text.chars().take_while(|&c| c == '/' || c == '\\').count();
    let rest = &text[slashes..];
    let mut drive = rest.chars();
    let has_drive = matches!(
        (drive.next(), drive.next(), drive.next()),
        (Some(letter), Some(':' | '|'), None | Some('/' | '\\')) if letter.is_ascii_alphabetic()
    );
    let path = if let Some(host) = host {
        format!("\\\\{host}\\{rest}")
    } else if has_drive {
        format!("{}:{}", &rest[..1], &rest[2..])
    } else if slashes >= 2 {
        format!("\\\\{rest}")
    } else {
        text.clone()
    };
    Ok(path.replace('/', "\\").into_bytes())
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

/// Elsewhere the path is UTF-8 (Windows: [`windows_path`] made it so).
#[cfg(not(unix))]
fn bytes_to_path(bytes: Vec<u8>) -> PathBuf {
    PathBuf::from(String::from_utf8_lossy(&bytes).into_owned())
}

#[cfg(test)]
mod tests {
    use super::{resource_dir, resource_path, PathStyle};
    use std::path::PathBuf;

    fn windows(uri: &str) -> Result<String, String> {
        resource_path(uri, PathStyle::Windows).map(|b| String::from_utf8(b).unwrap())
    }

    fn unix(uri: &str) -> Result<String, String> {
        resource_path(uri, PathStyle::Unix).map(|b| String::from_utf8(b).unwrap())
    }

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
            assert_eq!(
                unix(uri).unwrap().trim_end_matches('/'),
                "/tmp/my fmu/resources",
                "{uri}"
            );
            if cfg!(unix) {
                let got = resource_dir(uri).unwrap_or_else(|e| panic!("{uri}: {e}"));
                assert_eq!(
                    got.components().collect::<Vec<_>>(),
                    want.components().collect::<Vec<_>>(),
                    "{uri}"
                );
            }
        }
    }

    #[test]
    fn decodes_non_ascii_escapes() {
        assert_eq!(unix("file:///tmp/%C3%BCber/resources").unwrap(), "/tmp/über/resources");
        if cfg!(unix) {
            let p = resource_dir("file:///tmp/%C3%BCber/resources").unwrap();
            assert_eq!(p, PathBuf::from("/tmp/über/resources"));
        }
        // a Unix file name need not be UTF-8
        assert_eq!(resource_path("file:///tmp/%FF", PathStyle::Unix).unwrap(), b"/tmp/\xff");
    }

    #[test]
    fn rejects_remote_and_broken_locations() {
        for style in [PathStyle::Unix, PathStyle::Windows] {
            assert!(resource_path("", style).is_err());
            assert!(resource_path("   ", style).is_err());
            assert!(resource_path("http://example.org/resources", style).is_err());
            assert!(resource_path("file:///tmp/bad%2", style).is_err());
            assert!(resource_path("file:///tmp/bad%zz", style).is_err());
            assert!(resource_path("file://", style).is_err());
        }
        assert!(unix("file://server/share/resources")
            .unwrap_err()
            .contains("only local files"));
        assert!(windows("file:///C:/%FF/resources").unwrap_err().contains("UTF-8"));
    }

    #[test]
    fn windows_drive_uris_become_drive_paths() {
        let want = r"C:\Users\me\my fmu\resources";
        for uri in [
            "file:///C:/Users/me/my%20fmu/resources",
            "file:/C:/Users/me/my%20fmu/resources",
            "file://localhost/C:/Users/me/my%20fmu/resources",
            "file:////C:/Users/me/my%20fmu/resources",
            "FILE:///C:/Users/me/my fmu/resources",
            "file:///C|/Users/me/my%20fmu/resources",
            "file:///C%3A/Users/me/my%20fmu/resources",
            "file:///C:%5CUsers%5Cme%5Cmy%20fmu%5Cresources",
            r"C:\Users\me\my fmu\resources",
            "C:/Users/me/my fmu/resources",
        ] {
            assert_eq!(windows(uri).as_deref(), Ok(want), "{uri}");
        }
        assert_eq!(windows("file:///d:/x/").unwrap(), r"d:\x\");
        assert_eq!(windows("file:///D:").unwrap(), "D:");
        assert_eq!(windows("file:///D:/%C3%BCber/resources").unwrap(), r"D:\über\resources");
        // the same URIs on Unix keep the drive as a folder name
        assert_eq!(unix("file:///C:/Users/x").unwrap(), "/C:/Users/x");
    }

    #[test]
    fn windows_share_uris_become_unc_paths() {
        let want = r"\\server\share\my fmu\resources";
        for uri in [
            "file://server/share/my%20fmu/resources",
            "file:////server/share/my%20fmu/resources",
            r"\\server\share\my fmu\resources",
        ] {
            assert_eq!(windows(uri).as_deref(), Ok(want), "{uri}");
        }
        // a drive-less rooted path stays one (the current drive's)
        assert_eq!(windows("file:///Users/x").unwrap(), r"\Users\x");
    }
}
