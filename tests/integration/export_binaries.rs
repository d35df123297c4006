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
fn another_platform_comes_in_addition_to_the_chosen_ones() {
    let s = Scratch::new("added");
    let fmu = s.0.join("added.fmu");
    // this platform's library named by CONTACT_FMU_LIBRARY, only this platform by --platforms
    let o = Command::new(env!("CARGO_BIN_EXE_contact-fmu"))
        .args(["export", SCENE, "-o"])
        .arg(&fmu)
        .args(["--platforms", contact_fmu::export::PLATFORM])
        .args(["--binary", &format!("win32={}", s.path("contact_fmu.dll"))])
        .env("CONTACT_FMU_LIBRARY", s.path("libcontact_fmu.so"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // a stand-in is no contact-fmu library: the exporter says so (and packs it, as named)
    assert!(String::from_utf8_lossy(&o.stderr).contains("is not a contact-fmu library"));
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

/// A copy of the exporter in `<scratch>/target/release/`, so that its `dist` libraries are
/// looked for in `<scratch>/target/<triple>/dist/`, where the test puts files of its choice.
fn exporter_in(s: &Scratch) -> PathBuf {
    let exe = s.0.join("target").join("release").join("contact-fmu");
    std::fs::create_dir_all(exe.parent().unwrap()).unwrap();
    std::fs::copy(env!("CARGO_BIN_EXE_contact-fmu"), &exe).unwrap();
    exe
}

fn dist_file(s: &Scratch, triple: &str, file: &str) -> PathBuf {
    let p = s.0.join("target").join(triple).join("dist").join(file);
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    p
}

#[test]
fn the_default_libraries_are_the_dist_builds_of_these_sources_or_nothing() {
    let s = Scratch::new("defaults");
    let exe = exporter_in(&s);
    let fmu = s.0.join("defaults.fmu");
    let run = || {
        Command::new(&exe)
            .args(["export", SCENE, "-o"])
            .arg(&fmu)
            .env_remove("CONTACT_FMU_LIBRARY")
            .output()
            .unwrap()
    };
    let so = dist_file(&s, "x86_64-unknown-linux-gnu", "libcontact_fmu.so");
    let dll = dist_file(&s, "x86_64-pc-windows-gnu", "contact_fmu.dll");
    // nothing built: refused, saying how to build them and how to name another library
    let o = run();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("no linux64 library")
            && err.contains("scripts/build_fmu_library.sh")
            && err.contains("CONTACT_FMU_LIBRARY")
            && err.contains("--platforms"),
        "{err}"
    );
    assert!(!fmu.exists());
    // built from other sources: refused, whatever the file times
    let other = b"\0\0contact-fmu 0.0.9 (sources 0123456789abcdef)\0".to_vec();
    let mine = format!("\0ELF..{}..\0", contact_fmu::guid::BUILD).into_bytes();
    std::fs::write(&so, &mine).unwrap();
    std::fs::write(&dll, &other).unwrap();
    let o = run();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("was built from other sources") && err.contains("contact_fmu.dll"),
        "{err}"
    );
    assert!(!fmu.exists());
    // both built from these sources: packed, one per default platform
    std::fs::write(&dll, &mine).unwrap();
    let o = run();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let names: Vec<String> = binaries_in(&fmu).into_iter().map(|(n, _)| n).collect();
    assert_eq!(
        names,
        ["binaries/linux64/bouncing_ball.so", "binaries/win64/bouncing_ball.dll"]
    );
    // --platforms leaves one out
    std::fs::remove_file(&dll).unwrap();
    let o = Command::new(&exe)
        .args(["export", SCENE, "--platforms", "linux64", "-o"])
        .arg(&fmu)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(binaries_in(&fmu).len(), 1);
}

#[test]
fn the_build_string_is_found_in_a_library_file() {
    use contact_fmu::export::build_of;
    let text = format!("xx contact-fmu 1.2.3 ... {} yy", contact_fmu::guid::BUILD);
    assert_eq!(build_of(text.as_bytes()).as_deref(), Some(contact_fmu::guid::BUILD));
    assert_eq!(build_of(b"contact-fmu 0.1.0 (sources 0123)"), None);
    assert_eq!(build_of(b"(sources 0123456789abcdef)"), None);
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
