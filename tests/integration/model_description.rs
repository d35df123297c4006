//! The bundled FMUs' model descriptions are kept under version control in
//! `modelDescription/<name>.xml` (FMI 3.0's in `modelDescription/fmi3/<name>.xml`). This test fails when the exporter's output for
//! `fmu/<name>/scene.toml` differs from the checked-in file (an unintended change to a
//! variable, a unit, the GUID...). After an intended change, regenerate them with
//!
//! ```sh
//! UPDATE_MODEL_DESCRIPTION=1 cargo test --release --test integration model_description::
//! ```
//!
//! and review the diff before committing.

use crate::common;

use common::bundled_scenes;
use contact_fmu::export::model_description_xml;
use contact_fmu::scene::Scene;
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn first_difference(a: &str, b: &str) -> String {
    for (i, (x, y)) in a.lines().zip(b.lines()).enumerate() {
        if x != y {
            return format!("line {}:\n  checked in: {x}\n  exporter:   {y}", i + 1);
        }
    }
    format!("the files have {} and {} lines", a.lines().count(), b.lines().count())
}

#[test]
fn bundled_model_descriptions_are_up_to_date() {
    up_to_date(root().join("modelDescription"), model_description_xml);
}

#[test]
fn bundled_fmi3_model_descriptions_are_up_to_date() {
    up_to_date(
        root().join("modelDescription").join("fmi3"),
        contact_fmu::export::fmi3::model_description_xml,
    );
}

/// The descriptions written by `describe` for the bundled scenes against the files in `dir`
/// (written there with `UPDATE_MODEL_DESCRIPTION=1`).
fn up_to_date(dir: PathBuf, describe: fn(&Scene, &str) -> String) {
    let update = std::env::var_os("UPDATE_MODEL_DESCRIPTION").is_some_and(|v| v != "0" && !v.is_empty());
    let scenes = bundled_scenes();
    assert!(!scenes.is_empty(), "no fmu/<name>/scene.toml found");
    let mut stale = Vec::new();
    for (name, path) in &scenes {
        let text = std::fs::read_to_string(path).unwrap();
        let scene = Scene::from_str(&text, &path.display().to_string()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            &scene.model.name,
            name,
            "{}: model.name must equal the folder name",
            path.display()
        );
        let xml = describe(&scene, &text);
        let file = dir.join(format!("{name}.xml"));
        if update {
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(&file, &xml).unwrap();
            continue;
        }
        match std::fs::read_to_string(&file) {
            Ok(old) if old == xml => {}
            Ok(old) => stale.push(format!(
                "{} differs from the exporter's output at {}",
                file.display(),
                first_difference(&old, &xml)
            )),
            Err(e) => stale.push(format!("{}: {e}", file.display())),
        }
    }
    // A description whose scene is gone is stale too.
    if let Ok(entries) = std::fs::read_dir(&dir) {
        for e in entries.filter_map(|e| e.ok()) {
            let p = e.path();
            let stem = p
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            if p.extension().is_some_and(|x| x == "xml") && !scenes.iter().any(|(n, _)| *n == stem) {
                if update {
                    std::fs::remove_file(&p).unwrap();
                } else {
                    stale.push(format!("{} has no fmu/{stem}/scene.toml", p.display()));
                }
            }
        }
    }
    assert!(
        stale.is_empty(),
        "{}\n\nIf the change is intended, regenerate with\n  UPDATE_MODEL_DESCRIPTION=1 cargo test --release --test integration model_description::\nand review the diff.",
        stale.join("\n")
    );
}

/// Parses just enough of a description to check the ModelStructure rules of FMI 2.0.
fn attribute<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let key = format!(" {name}=\"");
    let start = tag.find(&key)? + key.len();
    let end = tag[start..].find('"')? + start;
    Some(&tag[start..end])
}

#[test]
fn model_structure_lists_every_output_and_exactly_the_initial_unknowns() {
    for (_, path) in bundled_scenes() {
        let text = std::fs::read_to_string(&path).unwrap();
        let scene = Scene::from_str(&text, "scene").unwrap();
        let xml = model_description_xml(&scene, &text);
        let vars: Vec<&str> = xml.split("<ScalarVariable ").skip(1).collect();
        let mut outputs = Vec::new();
        let mut initial = Vec::new();
        for (i, v) in vars.iter().enumerate() {
            let head = v.lines().next().unwrap();
            let causality = attribute(head, "causality").unwrap();
            let init = attribute(head, "initial");
            assert_eq!(attribute(head, "valueReference"), Some(i.to_string().as_str()));
            if causality == "output" {
                outputs.push(i + 1);
            }
            if (causality == "output" && matches!(init, Some("calculated") | Some("approx")))
                || causality == "calculatedParameter"
            {
                initial.push(i + 1);
            }
            let body = &v[..v.find("</ScalarVariable>").unwrap()];
            match (causality, init) {
                ("parameter", Some("exact")) | ("input", None) => {
                    assert!(body.contains(" start=\""), "{head}: needs a start")
                }
                (_, Some("calculated")) => assert!(!body.contains(" start=\""), "{head}: calculated has no start"),
                ("output", _) | ("calculatedParameter", _) => {}
                other => panic!("{head}: unexpected causality/initial {other:?}"),
            }
            if !body.contains("<Real") {
                assert_ne!(
                    attribute(head, "variability"),
                    Some("continuous"),
                    "{head}: only Real may be continuous"
                );
            }
        }
        let section = |tag: &str| -> Vec<usize> {
            let Some(s) = xml.find(&format!("<{tag}>")) else {
                return Vec::new();
            };
            let e = xml[s..].find(&format!("</{tag}>")).unwrap() + s;
            xml[s..e]
                .split("<Unknown ")
                .skip(1)
                .map(|u| attribute(&format!(" {u}"), "index").unwrap().parse().unwrap())
                .collect()
        };
        assert_eq!(section("Outputs"), outputs, "{}", path.display());
        assert_eq!(section("InitialUnknowns"), initial, "{}", path.display());
        assert!(
            !xml.contains("generationDateAndTime"),
            "the description must be deterministic"
        );
    }
}

#[test]
fn the_description_is_a_pure_function_of_the_scene_text() {
    let path = common::bundled("bouncing_ball");
    let text = std::fs::read_to_string(path).unwrap();
    let scene = Scene::from_str(&text, "scene").unwrap();
    let a = model_description_xml(&scene, &text);
    assert_eq!(a, model_description_xml(&scene, &text));
    // A comment changes the text, hence the GUID, but nothing else.
    let edited = format!("{text}\n# edited\n");
    let b = model_description_xml(&scene, &edited);
    assert_ne!(a, b);
    let strip = |s: &str| {
        s.lines()
            .filter(|l| !l.contains("guid="))
            .collect::<Vec<_>>()
            .join("\n")
    };
    assert_eq!(strip(&a), strip(&b));
}
