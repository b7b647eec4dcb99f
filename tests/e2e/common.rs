//! Helpers shared by the end-to-end tests.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository's test data folder.
pub fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(rel)
}

/// Asserts that two runs wrote the same programs, as many and each byte for byte, naming
/// the first that differs (without printing the programs: they run to megabytes).
pub fn assert_same_programs(a: &[String], b: &[String]) {
    assert_eq!(a.len(), b.len(), "the runs wrote different numbers of programs");
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(x == y, "program {} differs", k + 1);
    }
}

/// Every closed mesh of the bundled corpus (the OpenSCAD parts, the bunny, the gear).
pub fn closed_meshes() -> Vec<PathBuf> {
    let mut v = stl_files("meshes/openscad");
    v.push(data("meshes/classic/stanford_bunny.stl"));
    v.push(data("meshes/classic/gearwheel_40t.bin.stl"));
    v
}

/// `s2g mill`'s default policy: the learned one shipped in the crate, or the heuristic
/// without the `learn` feature.
pub fn default_policy() -> Box<dyn shape2gcode::Policy> {
    #[cfg(feature = "learn")]
    return Box::new(shape2gcode::LearnedPolicy::bundled().unwrap());
    #[cfg(not(feature = "learn"))]
    return Box::new(shape2gcode::HeuristicPolicy::default());
}

/// The stress corpus of our own (tests/data/meshes/stress, remade by
/// `scripts/stress_corpus.sh`): turned parts with 32-256 facets per circle, thin walls,
/// holes of one or two voxels, nearly coplanar faces, parts 100 times longer than thick.
pub fn stress_meshes() -> Vec<PathBuf> {
    stl_files("meshes/stress")
}

/// The STL files of a folder of tests/data, sorted.
fn stl_files(rel: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(data(rel))
        .unwrap_or_else(|e| panic!("tests/data/{rel}: {e}"))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "stl"))
        .collect();
    v.sort();
    v
}

/// `rs274` keeps its tool table in `$HOME/.tool.mmap` and writes `rs274ngc.var` in its
/// working folder: each run gets the program's folder as both, and runs in this process
/// are serialised.
static RS274: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Runs LinuxCNC's `rs274` on `program` with tools 0-99 in its table and returns its
/// error lines (it stops at the first error with a non-zero status), if any. Panics with
/// an install hint when `rs274` is missing.
pub fn rs274_errors(program: &Path) -> Vec<String> {
    let tools: String = (0..100).map(|t| format!("T{t} P{t} Z0 D0\n")).collect();
    rs274_errors_with_table(program, &tools)
}

/// As [`rs274_errors`], with the tool table `tools` (LinuxCNC's format).
pub fn rs274_errors_with_table(program: &Path, tools: &str) -> Vec<String> {
    let dir = program.parent().expect("program has a folder");
    let table = dir.join("tools.tbl");
    std::fs::write(&table, tools).expect("write tool table");
    let _one_at_a_time = RS274.lock().unwrap_or_else(|e| e.into_inner());
    let run = || {
        Command::new("rs274")
            .arg("-g")
            .arg("-t")
            .arg(&table)
            .arg(program)
            .env("HOME", dir)
            .current_dir(dir)
            .stdin(std::process::Stdio::null())
            .output()
            .expect("rs274 is required: apt-get install linuxcnc-uspace (scripts/test installs it)")
    };
    let mut out = run();
    if out.status.code().is_none() {
        // Killed by a signal (it maps its tool table into memory): one more try.
        out = run();
    }
    if out.status.success() {
        return Vec::new();
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    let mut errors: Vec<String> = stderr
        .lines()
        .filter(|l| !l.trim().is_empty() && l.trim() != "executing")
        .map(str::to_owned)
        .collect();
    if errors.is_empty() {
        errors.push(format!("rs274 exited with {}", out.status));
    }
    errors
}
