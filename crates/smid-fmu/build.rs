//! Builds the bundled plant FMUs: every `fmus/<name>/` of the workspace that holds
//! `modelDescription.xml` and `<name>.c` is compiled (with the C compiler the `cc` crate finds,
//! `-shared -fPIC -O2 -ffp-contract=off`, against the vendored FMI 2.0 headers of
//! `fmus/include` and the frame of `fmus/common`) and zipped with its model description into
//! `$OUT_DIR/fmus/<name>.fmu`. The directory is exported to the crate as `SMID_FMU_DIR`.
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    let fmus = manifest.join("../../fmus");
    let fmus = fmus.canonicalize().unwrap_or(fmus);
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("OUT_DIR")).join("fmus");
    std::fs::create_dir_all(&out).expect("create $OUT_DIR/fmus");
    println!("cargo:rerun-if-changed={}", fmus.display());
    println!("cargo:rustc-env=SMID_FMU_DIR={}", out.display());
    println!("cargo:rustc-env=SMID_FMU_SOURCE_DIR={}", fmus.display());

    let os = std::env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    let arch = std::env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let (platform, suffix) = match (os.as_str(), arch.as_str()) {
        ("linux", "x86_64" | "aarch64") => ("linux64", "so"),
        ("linux", "x86") => ("linux32", "so"),
        ("macos", _) => ("darwin64", "dylib"),
        ("windows", "x86_64") => ("win64", "dll"),
        _ => {
            println!("cargo:warning=smid-fmu: no FMU platform folder for {os}/{arch}; bundled FMUs not built");
            return;
        }
    };
    let compiler = cc::Build::new()
        .cargo_metadata(false)
        .cargo_warnings(false)
        .get_compiler();

    let mut entries: Vec<PathBuf> = std::fs::read_dir(&fmus)
        .unwrap_or_else(|e| panic!("{}: {e}", fmus.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("modelDescription.xml").is_file())
        .collect();
    entries.sort();
    for dir in entries {
        let name = dir
            .file_name()
            .and_then(|n| n.to_str())
            .expect("utf-8 FMU name")
            .to_string();
        build_one(&compiler, &fmus, &dir, &name, &out, platform, suffix);
    }
}

fn build_one(
    compiler: &cc::Tool,
    fmus: &Path,
    dir: &Path,
    name: &str,
    out: &Path,
    platform: &str,
    suffix: &str,
) {
    let source = dir.join(format!("{name}.c"));
    let xml_path = dir.join("modelDescription.xml");
    let xml = std::fs::read_to_string(&xml_path).expect("read modelDescription.xml");
    assert!(
        xml.contains(&format!("modelIdentifier=\"{name}\"")),
        "{}: modelIdentifier must equal the directory name `{name}`",
        xml_path.display()
    );
    let c =
        std::fs::read_to_string(&source).unwrap_or_else(|e| panic!("{}: {e}", source.display()));
    let guid = xml
        .split("guid=\"")
        .nth(1)
        .and_then(|s| s.split('"').next())
        .expect("modelDescription.xml has a guid");
    assert!(
        c.contains(&format!("#define MODEL_GUID \"{guid}\"")),
        "{}: MODEL_GUID must equal the guid {guid} of modelDescription.xml",
        source.display()
    );
    let lib = out.join(format!("{name}.{suffix}"));
    let mut cmd: Command = compiler.to_command();
    cmd.args([
        "-shared",
        "-fPIC",
        "-O2",
        "-ffp-contract=off",
        "-std=c99",
        "-D_DEFAULT_SOURCE",
    ])
    .arg("-Wall")
    .arg(format!("-I{}", fmus.join("include").display()))
    .arg(format!("-I{}", fmus.join("common").display()))
    .arg("-o")
    .arg(&lib)
    .arg(&source)
    .arg("-lm");
    let status = cmd
        .status()
        .unwrap_or_else(|e| panic!("running the C compiler for {}: {e}", source.display()));
    assert!(
        status.success(),
        "compiling {} failed: {cmd:?}",
        source.display()
    );

    let fmu = out.join(format!("{name}.fmu"));
    let tmp = out.join(format!("{name}.fmu.tmp"));
    let file = std::fs::File::create(&tmp).expect("create .fmu");
    let mut zip = zip::ZipWriter::new(file);
    let opts = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Stored)
        .last_modified_time(zip::DateTime::default())
        .unix_permissions(0o755);
    zip.start_file("modelDescription.xml", opts).expect("zip");
    zip.write_all(xml.as_bytes()).expect("zip");
    zip.start_file(format!("binaries/{platform}/{name}.{suffix}"), opts)
        .expect("zip");
    zip.write_all(&std::fs::read(&lib).expect("read built library"))
        .expect("zip");
    zip.finish().expect("zip");
    std::fs::rename(&tmp, &fmu).expect("rename .fmu");
}
