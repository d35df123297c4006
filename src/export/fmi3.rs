//! The FMI 3.0 `modelDescription.xml` of a scene: the same variable table, names, value
//! references, units, start values, ranges and dependencies as the FMI 2.0 description
//! (`super::description::write_model_description`), in FMI 3.0's schema:
//!
//! - `fmiVersion="3.0"` and `instantiationToken` (the value of FMI 2.0's `guid`);
//! - `CoSimulation` with FMI 3.0's capabilities: variable communication steps, FMU states,
//!   `mightReturnEarlyFromDoStep` (a step may end at a contact event when the host allows it),
//!   no event mode, no intermediate update, no derivatives;
//! - `EnumerationType` for the enumerations; `Float64`, `Int32`, `Boolean` and `Enumeration`
//!   variables (FMI 2.0's Real, Integer, Boolean, Enumeration), and the independent variable
//!   `time` that FMI 3.0 requires, whose value reference follows the table's (so that every
//!   other variable keeps its FMI 2.0 value reference);
//! - `ModelStructure` with `Output` and `InitialUnknown` naming value references (FMI 2.0
//!   names 1-based indices), the outputs with their `dependencies`.

use super::description::{
    empty, model_structure, output_dependencies, used_units, variable_attributes, write_document, Layout,
};
use crate::fmi::lifecycle::Version;
use crate::scene::Scene;
use crate::variables::{VarType, Variable, VariableTable};
use quick_xml::Writer;
use std::io;

/// The FMI 3.0 `modelDescription.xml` of a scene without `generationDateAndTime`: a pure
/// function of the scene text (kept in `modelDescription/fmi3/`).
pub fn model_description_xml(scene: &Scene, scene_text: &str) -> String {
    model_description_xml_dated(scene, scene_text, None)
}

/// The FMI 3.0 `modelDescription.xml` with `generationDateAndTime` set to `generated`, as
/// packed into the FMU.
pub fn model_description_xml_dated(scene: &Scene, scene_text: &str, generated: Option<&str>) -> String {
    let bytes = write(scene, scene_text, generated).expect("writing XML into a Vec<u8> cannot fail");
    String::from_utf8(bytes).expect("quick-xml writes the UTF-8 it is given")
}

fn write(scene: &Scene, scene_text: &str, generated: Option<&str>) -> io::Result<Vec<u8>> {
    write_document(scene, scene_text, generated, &FMI3)
}

/// FMI 3.0's way.
const FMI3: Layout = Layout {
    version: Version::Fmi3,
    capabilities: &[
        ("canBeInstantiatedOnlyOncePerProcess", "false"),
        ("canGetAndSetFMUState", "true"),
        ("canSerializeFMUState", "true"),
        ("providesDirectionalDerivatives", "false"),
        ("providesAdjointDerivatives", "false"),
        ("providesPerElementDependencies", "false"),
        ("canHandleVariableCommunicationStepSize", "true"),
        ("maxOutputDerivativeOrder", "0"),
        ("providesIntermediateUpdate", "false"),
        ("mightReturnEarlyFromDoStep", "true"),
        ("canReturnEarlyAfterIntermediateUpdate", "false"),
        ("hasEventMode", "false"),
        ("providesEvaluateDiscreteStates", "false"),
    ],
    independent: Some(write_time),
    variable: write_variable,
    structure: write_structure,
};

/// FMI 3.0's one independent variable, after the table's value references.
fn write_time(w: &mut Writer<Vec<u8>>, table: &VariableTable) -> io::Result<()> {
    let time_vr = table.vars.len().to_string();
    let mut time = vec![
        ("name", "time"),
        ("valueReference", time_vr.as_str()),
        ("description", "Simulation time"),
        ("causality", "independent"),
        ("variability", "continuous"),
    ];
    if used_units(table).iter().any(|u| u.name == "s") {
        time.push(("unit", "s"));
    }
    empty(w, "Float64", time)
}

/// `ModelStructure`: every output with the value references it depends on directly, then the
/// initial unknowns (their dependencies left to FMI's default, as in FMI 2.0).
fn write_structure(w: &mut Writer<Vec<u8>>, table: &VariableTable) -> io::Result<()> {
    let (outputs, initial) = model_structure(table);
    w.create_element("ModelStructure").write_inner_content(|w| {
        for &i in &outputs {
            let vr = (i - 1).to_string();
            let deps: Vec<String> = output_dependencies(table, i - 1)
                .iter()
                .map(|d| (d - 1).to_string())
                .collect();
            let deps = deps.join(" ");
            empty(
                w,
                "Output",
                [("valueReference", vr.as_str()), ("dependencies", deps.as_str())],
            )?;
        }
        for &i in &initial {
            let vr = (i - 1).to_string();
            empty(w, "InitialUnknown", [("valueReference", vr.as_str())])?;
        }
        Ok(())
    })?;
    Ok(())
}

/// One variable: the element of its type with FMI 3.0's attributes (the same values as the
/// FMI 2.0 `ScalarVariable`).
fn write_variable(w: &mut Writer<Vec<u8>>, vr: usize, v: &Variable) -> io::Result<()> {
    let [mut a, typed] = variable_attributes(vr, v);
    if let VarType::Enumeration(e) = v.vtype {
        a.insert(2, ("declaredType", e.type_name().to_string()));
    }
    a.extend(typed);
    empty(w, Version::Fmi3.type_element(v.vtype), a)
}
