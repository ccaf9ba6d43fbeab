//! FMUs exported from Python (PythonFMU, `pythonfmu build -f Plant.py`): their binary calls the
//! Python C API but does not link the Python runtime; it expects the host process to provide it,
//! as a Python host (fmpy) does by being Python. Loaded by smid as it is, it fails with
//! `undefined symbol: _Py_NoneStruct`. So before such a unit's binary is loaded, smid loads the
//! Python runtime's shared library (`libpython3.x.so`) with global symbol visibility, once per
//! process, found through a Python interpreter: `SMID_PYTHON` if set, else `python3`, else
//! `python` on the `PATH`; the interpreter's `sysconfig` names its library. The unit's Python
//! code then runs in that interpreter's installation (its standard library and packages).
//!
//! This is the one place of the crate that calls the platform loader directly (`dlopen` with
//! `RTLD_GLOBAL`, which the `fmi` crate's loader does not offer), hence its `unsafe`.
#![allow(unsafe_code)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// Whether the unit was exported by PythonFMU: its `generationTool`, or the module file PythonFMU
/// writes into the resources.
pub(crate) fn is_python_fmu(generation_tool: Option<&str>, unpacked: &Path) -> bool {
    generation_tool.is_some_and(|t| t.trim_start().starts_with("PythonFMU"))
        || unpacked.join("resources").join("slavemodule.txt").is_file()
}

static RUNTIME: OnceLock<Result<PathBuf, String>> = OnceLock::new();

/// Load the Python runtime with global symbols (once per process): its path, or why no usable
/// runtime was found (every interpreter and library tried, and what to do).
pub(crate) fn ensure_runtime() -> Result<PathBuf, String> {
    RUNTIME.get_or_init(load_runtime).clone()
}

/// The interpreters to ask, in order.
fn interpreters() -> Vec<String> {
    match std::env::var("SMID_PYTHON") {
        Ok(p) if !p.trim().is_empty() => vec![p],
        _ => vec!["python3".into(), "python".into()],
    }
}

/// Asks an interpreter for its shared library: `LIBDIR/INSTSONAME`, `LIBDIR/LDLIBRARY`, and
/// the same names in the multiarch directory of Debian-like systems.
const ASK: &str = "import sysconfig as s, os
v = s.get_config_var
for d in (v('LIBDIR'), os.path.join(v('LIBDIR') or '', v('MULTIARCH') or '')):
    for n in (v('INSTSONAME'), v('LDLIBRARY')):
        if d and n:
            print(os.path.join(d, n))
";

/// A shared library (not the static `libpython3.x.a` of a static build).
fn is_shared_lib(p: &Path) -> bool {
    let name = p
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    p.is_file() && (name.contains(".so") || name.ends_with(".dylib"))
}

fn load_runtime() -> Result<PathBuf, String> {
    let mut tried: Vec<String> = Vec::new();
    for py in interpreters() {
        let out = match Command::new(&py).args(["-c", ASK]).output() {
            Ok(o) if o.status.success() => o,
            Ok(o) => {
                tried.push(format!(
                    "`{py}` failed: {}",
                    String::from_utf8_lossy(&o.stderr).trim()
                ));
                continue;
            }
            Err(e) => {
                tried.push(format!("`{py}`: {e}"));
                continue;
            }
        };
        let candidates: Vec<PathBuf> = String::from_utf8_lossy(&out.stdout)
            .lines()
            .map(PathBuf::from)
            .filter(|p| is_shared_lib(p))
            .collect();
        if candidates.is_empty() {
            tried.push(format!(
                "`{py}` has no shared Python library (a statically linked interpreter)"
            ));
        }
        for lib in candidates {
            match open_global(&lib) {
                Ok(()) => return Ok(lib),
                Err(e) => tried.push(format!("{}: {e}", lib.display())),
            }
        }
    }
    Err(format!(
        "this FMU was exported from Python (PythonFMU) and needs a Python runtime with a shared \
         libpython, but none was usable ({}); install Python with its shared library (and the \
         packages the unit imports) or set SMID_PYTHON to such an interpreter",
        tried.join("; ")
    ))
}

#[cfg(unix)]
fn open_global(lib: &Path) -> Result<(), String> {
    use libloading::os::unix::{Library, RTLD_GLOBAL, RTLD_NOW};
    // SAFETY: loading libpython runs only its ELF initialisers, which set up no Python state
    // (the interpreter is initialised by the FMU's own code when it is instantiated).
    let lib =
        unsafe { Library::open(Some(lib), RTLD_NOW | RTLD_GLOBAL) }.map_err(|e| e.to_string())?;
    // Kept for the life of the process: the FMU's binary resolves its symbols against it.
    std::mem::forget(lib);
    Ok(())
}

#[cfg(not(unix))]
fn open_global(_lib: &Path) -> Result<(), String> {
    Err(
        "loading a Python runtime for PythonFMU units is supported on Unix-like systems only"
            .into(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recognises_pythonfmu_by_generation_tool_or_resources() {
        let dir = std::env::temp_dir().join(format!("smid-pyfmu-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("resources")).unwrap();
        assert!(is_python_fmu(Some("PythonFMU 0.7.0"), &dir));
        assert!(!is_python_fmu(Some("smid fmus/"), &dir));
        assert!(!is_python_fmu(None, &dir));
        std::fs::write(dir.join("resources/slavemodule.txt"), "Plant").unwrap();
        assert!(is_python_fmu(None, &dir));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
