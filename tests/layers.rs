//! The layering rules, checked on the manifests: behaviours, the executive and the planner know
//! the robot and each other only through `orsa-interfaces`, and the interfaces only through the
//! framework. A new dependency that breaks a layer fails here, not in review.

use std::collections::BTreeSet;
use std::path::Path;

/// The orsa crates a package depends on, in every dependency table (normal, dev, build).
fn orsa_dependencies(package: &str) -> BTreeSet<String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(package).join("Cargo.toml");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let manifest: toml::Table = toml::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    ["dependencies", "dev-dependencies", "build-dependencies"]
        .iter()
        .filter_map(|t| manifest.get(*t).and_then(toml::Value::as_table))
        .flat_map(|t| t.keys().cloned())
        .filter(|k| k.starts_with("orsa"))
        .collect()
}

fn set(names: &[&str]) -> BTreeSet<String> {
    names.iter().map(|s| s.to_string()).collect()
}

#[test]
fn deciding_layers_depend_only_on_the_framework_and_the_interfaces() {
    for package in ["reactive", "executive"] {
        assert_eq!(
            orsa_dependencies(package),
            set(&["orsa-actors", "orsa-interfaces"]),
            "{package} may depend only on orsa-actors and orsa-interfaces"
        );
    }
    // The planner plans on the map: the navigation layer is the one below it it may use.
    assert_eq!(
        orsa_dependencies("planner"),
        set(&["orsa-actors", "orsa-interfaces", "orsa-navigation"]),
        "the planner may depend only on orsa-actors, orsa-interfaces and orsa-navigation"
    );
    // Navigation works on any robot's map and readings: it knows no robot crate either.
    let navigation = orsa_dependencies("navigation");
    assert!(
        navigation.is_subset(&set(&["orsa-actors", "orsa-interfaces"])),
        "navigation depends on {navigation:?}"
    );
}

#[test]
fn interfaces_depend_only_on_the_framework() {
    assert_eq!(orsa_dependencies("interfaces"), set(&["orsa-actors"]));
    assert_eq!(orsa_dependencies("actors"), set(&[]), "the framework depends on no orsa crate");
}

/// The external crates a package depends on, in its normal dependencies.
fn dependencies(package: &str) -> BTreeSet<String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(package).join("Cargo.toml");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let manifest: toml::Table = toml::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    manifest
        .get("dependencies")
        .and_then(toml::Value::as_table)
        .into_iter()
        .flat_map(|t| t.keys().cloned())
        .collect()
}

/// The product crates stack in one direction: the system assembly, then the recording crate
/// (which replays through the assembly), then the `orsa` library, then the binary at the root.
#[test]
fn the_product_crates_stack_assembly_record_library_binary() {
    let below_assembly = set(&[
        "orsa-actors",
        "orsa-interfaces",
        "orsa-hardware",
        "orsa-reactive",
        "orsa-executive",
        "orsa-planner",
        "orsa-navigation",
        "orsa-net",
    ]);
    let assembly = orsa_dependencies("assembly");
    assert!(assembly.is_subset(&below_assembly), "orsa-assembly depends on {assembly:?}");
    let record = orsa_dependencies("record");
    assert!(record.contains("orsa-assembly"), "replay runs a recorded system through the assembly");
    for above in ["orsa", "orsa-cli"] {
        assert!(!record.contains(above), "orsa-record must not depend on {above}");
        assert!(!assembly.contains(above), "orsa-assembly must not depend on {above}");
    }
    let library = orsa_dependencies("orsa");
    assert!(library.contains("orsa-record") && !library.contains("orsa-cli"), "{library:?}");
}

/// The command line is the binary's: no library crate depends on clap.
#[test]
fn only_the_binary_knows_the_command_line() {
    for package in ["orsa", "record", "assembly"] {
        assert!(!dependencies(package).contains("clap"), "{package} depends on clap");
    }
    assert!(dependencies(".").contains("clap"));
}
