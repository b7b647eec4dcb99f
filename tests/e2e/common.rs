//! Helpers shared by the end-to-end tests.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository's test data folder.
pub fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(rel)
}

/// Every closed mesh of the bundled corpus (the OpenSCAD parts, the bunny, the gear).
pub fn closed_meshes() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(data("meshes/openscad"))
        .expect("tests/data/meshes/openscad")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "stl"))
        .collect();
    v.sort();
    v.push(data("meshes/classic/stanford_bunny.stl"));
    v.push(data("meshes/classic/gearwheel_40t.bin.stl"));
    v
}

/// Runs LinuxCNC's `rs274` on `program` with tools 1-9 in its table and returns its
/// error lines, if any. Panics with an install hint when `rs274` is missing.
pub fn rs274_errors(program: &Path) -> Vec<String> {
    let dir = program.parent().expect("program has a folder");
    let table = dir.join("tools.tbl");
    let tools: String = (1..=9).map(|t| format!("T{t} P{t} Z0 D0\n")).collect();
    std::fs::write(&table, tools).expect("write tool table");
    let out = Command::new("rs274")
        .arg("-g")
        .arg("-t")
        .arg(&table)
        .arg(program)
        .stdin(std::process::Stdio::null())
        .output()
        .expect("rs274 is required: apt-get install linuxcnc-uspace (.ci/run installs it)");
    let text = String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    text.lines()
        .filter(|l| {
            let l = l.to_ascii_lowercase();
            !l.contains("n.....")
                && (l.contains("error")
                    || l.contains("arc")
                    || l.contains("invalid")
                    || l.contains("unknown"))
        })
        .map(str::to_owned)
        .collect()
}
