//! `contact-fmu export --binary PLATFORM=PATH`: libraries for other platforms go to
//! `binaries/<platform>/<model identifier>.<dll|so|dylib>`; an unknown platform, a missing
//! file, a malformed argument or two libraries for one platform are refused with a message.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SCENE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fmu/bouncing_ball/scene.toml");

/// A scratch folder with three stand-in libraries, removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new(tag: &str) -> Scratch {
        let dir = std::env::temp_dir().join(format!("contact-fmu binaries {} {tag}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (file, content) in [
            ("contact_fmu.dll", "not a real dll"),
            ("libcontact_fmu.so", "not a real so"),
            ("libcontact_fmu.dylib", "not a real dylib"),
        ] {
            std::fs::write(dir.join(file), content).unwrap();
        }
        Scratch(dir)
    }
    fn path(&self, file: &str) -> String {
        self.0.join(file).display().to_string()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn export(out: &Path, binaries: &[String]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_contact-fmu"));
    cmd.args(["export", SCENE, "-o"]).arg(out);
    for b in binaries {
        cmd.args(["--binary", b]);
    }
    cmd.output().unwrap()
}

/// The FMU's entries under `binaries/`, with their contents.
fn binaries_in(fmu: &Path) -> Vec<(String, Vec<u8>)> {
    let mut zip = zip::ZipArchive::new(std::fs::File::open(fmu).unwrap()).unwrap();
    let mut out = Vec::new();
    for i in 0..zip.len() {
        let mut f = zip.by_index(i).unwrap();
        if f.name().starts_with("binaries/") && !f.is_dir() {
            let mut bytes = Vec::new();
            f.read_to_end(&mut bytes).unwrap();
            out.push((f.name().to_string(), bytes));
        }
    }
    out
}

#[test]
fn libraries_for_three_platforms_are_packed_under_their_names() {
    let s = Scratch::new("three");
    let fmu = s.0.join("three.fmu");
    let args = [
        format!("win64={}", s.path("contact_fmu.dll")),
        format!("linux64={}", s.path("libcontact_fmu.so")),
        format!("darwin64={}", s.path("libcontact_fmu.dylib")),
    ];
    let o = export(&fmu, &args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let got: Vec<(String, String)> = binaries_in(&fmu)
        .into_iter()
        .map(|(name, bytes)| (name, String::from_utf8(bytes).unwrap()))
        .collect();
    let want = [
        ("binaries/darwin64/bouncing_ball.dylib", "not a real dylib"),
        ("binaries/linux64/bouncing_ball.so", "not a real so"),
        ("binaries/win64/bouncing_ball.dll", "not a real dll"),
    ];
    let want: Vec<(String, String)> = want.iter().map(|(a, b)| (a.to_string(), b.to_string())).collect();
    assert_eq!(got, want);
    // the order of the arguments does not change the FMU
    let reordered = s.0.join("reordered.fmu");
    let o = export(&reordered, &[args[2].clone(), args[0].clone(), args[1].clone()]);
    assert!(o.status.success());
    assert_eq!(std::fs::read(&fmu).unwrap(), std::fs::read(&reordered).unwrap());
}

#[test]
fn another_platform_comes_in_addition_to_this_one() {
    let s = Scratch::new("added");
    let fmu = s.0.join("added.fmu");
    let o = export(&fmu, &[format!("win32={}", s.path("contact_fmu.dll"))]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let names: Vec<String> = binaries_in(&fmu).into_iter().map(|(n, _)| n).collect();
    let this = format!(
        "binaries/{}/bouncing_ball.{}",
        contact_fmu::export::PLATFORM,
        contact_fmu::export::LIBRARY_EXTENSION
    );
    assert!(
        names.contains(&"binaries/win32/bouncing_ball.dll".to_string()),
        "{names:?}"
    );
    assert!(names.contains(&this), "{names:?}");
    assert_eq!(names.len(), 2);
}

#[test]
fn bad_binary_arguments_are_refused_with_a_message() {
    let s = Scratch::new("refused");
    let fmu = s.0.join("refused.fmu");
    let missing = s.path("missing.dll");
    for (arg, message) in [
        (
            format!("win65={}", s.path("contact_fmu.dll")),
            "unknown platform \"win65\" (known: win64, win32, linux64, linux32, darwin64)",
        ),
        (format!("win64={missing}"), "missing.dll: no such file"),
        (s.path("contact_fmu.dll"), "expected PLATFORM=PATH"),
    ] {
        let o = export(&fmu, std::slice::from_ref(&arg));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{arg}");
        assert!(
            err.contains(&format!("--binary {arg}")) && err.contains(message),
            "{arg}: {err}"
        );
        assert!(!fmu.exists(), "{arg}: no FMU is written");
    }
    let twice = [
        format!("win64={}", s.path("contact_fmu.dll")),
        format!("win64={}", s.path("libcontact_fmu.so")),
    ];
    let o = export(&fmu, &twice);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("two libraries for the platform win64"));
    assert!(!fmu.exists());
}
