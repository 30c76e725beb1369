//! Finds the system Embree (3 or 4) and generates raw bindings for the header of the library that is
//! linked, never a bundled copy (`RTCRayHit` differs in size between 3.13 and 4.3).
//!
//! Search order:
//! 1. `EMBREE_DIR` (with `include/embree{4,3}/rtcore.h` and `lib/` or `lib64/` below it);
//! 2. pkg-config `embree4`, then `embree3` (Debian's packages ship no .pc file, others do);
//! 3. the standard include directories, `embree4/rtcore.h` before `embree3/rtcore.h`.
//!
//! Exported to dependents through `links = "embree"`: `DEP_EMBREE_VERSION` (e.g. `3.13.5`) and
//! `DEP_EMBREE_MAJOR` (`3` or `4`). This crate itself gets the cfg `embree3` or `embree4`.

use std::env;
use std::path::{Path, PathBuf};

struct Found {
    /// Directory that contains `embreeN/rtcore.h`.
    include_dir: PathBuf,
    major: u32,
    version: String,
    lib_dirs: Vec<PathBuf>,
}

const STANDARD_INCLUDE_DIRS: &[&str] = &[
    "/usr/include",
    "/usr/local/include",
    "/opt/local/include",
    "/opt/homebrew/include",
];

fn main() {
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo::rustc-check-cfg=cfg(embree3)");
    println!("cargo::rustc-check-cfg=cfg(embree4)");

    let found = match find() {
        Ok(f) => f,
        Err(why) => {
            eprintln!(
                "\nerror: embree-sys could not find the Embree ray tracing library ({why}).\n\
                 Install it, e.g. on Debian/Ubuntu:  sudo apt-get install -y libembree-dev libclang-dev\n\
                 or set EMBREE_DIR to a directory that has include/embree4/rtcore.h (or embree3) and lib/.\n"
            );
            std::process::exit(1);
        }
    };

    for dir in &found.lib_dirs {
        println!("cargo:rustc-link-search=native={}", dir.display());
    }
    println!("cargo:rustc-link-lib=dylib=embree{}", found.major);
    println!("cargo:rustc-cfg=embree{}", found.major);
    // Metadata for dependents (DEP_EMBREE_*).
    println!("cargo:version={}", found.version);
    println!("cargo:rustc-env=EMBREE_SYS_VERSION={}", found.version);
    println!("cargo:major={}", found.major);
    println!("cargo:include={}", found.include_dir.display());

    let header = found
        .include_dir
        .join(format!("embree{}", found.major))
        .join("rtcore.h");
    println!("cargo:rerun-if-changed={}", header.display());
    let bindings = bindgen::Builder::default()
        .header(header.to_string_lossy())
        .clang_arg(format!("-I{}", found.include_dir.display()))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC.*")
        .derive_default(true)
        .derive_debug(true)
        .layout_tests(true)
        .rust_edition(bindgen::RustEdition::Edition2024)
        // Only the compiler reads these bindings: no rustfmt process (bindgen's default formatter).
        .formatter(bindgen::Formatter::None)
        .generate()
        .unwrap_or_else(|e| {
            eprintln!(
                "\nerror: bindgen failed on {} ({e}). Is libclang installed? \
                 (Debian/Ubuntu: sudo apt-get install -y libclang-dev)\n",
                header.display()
            );
            std::process::exit(1);
        });
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("bindings.rs");
    bindings
        .write_to_file(&out)
        .unwrap_or_else(|e| panic!("cannot write {}: {e}", out.display()));
}

fn find() -> Result<Found, String> {
    if let Ok(dir) = env::var("EMBREE_DIR") {
        let dir = PathBuf::from(dir);
        let include = dir.join("include");
        let (major, version) = probe_header_dir(&include).ok_or_else(|| {
            format!(
                "EMBREE_DIR={} has no include/embree{{4,3}}/rtcore.h",
                dir.display()
            )
        })?;
        let lib_dirs = ["lib", "lib64"]
            .iter()
            .map(|l| dir.join(l))
            .filter(|p| p.is_dir())
            .collect();
        return Ok(Found {
            include_dir: include,
            major,
            version,
            lib_dirs,
        });
    }
    for name in ["embree4", "embree3"] {
        // Only probe; pkg-config's own link lines would be emitted before we know the header.
        if let Ok(lib) = pkg_config::Config::new().cargo_metadata(false).probe(name) {
            for inc in &lib.include_paths {
                for candidate in [
                    inc.clone(),
                    inc.parent().map(Path::to_path_buf).unwrap_or_default(),
                ] {
                    if let Some((major, version)) = probe_header_dir(&candidate) {
                        return Ok(Found {
                            include_dir: candidate,
                            major,
                            version,
                            lib_dirs: lib.link_paths.clone(),
                        });
                    }
                }
            }
        }
    }
    for dir in STANDARD_INCLUDE_DIRS {
        if let Some((major, version)) = probe_header_dir(Path::new(dir)) {
            return Ok(Found {
                include_dir: PathBuf::from(dir),
                major,
                version,
                lib_dirs: Vec::new(),
            });
        }
    }
    Err("no embree4/rtcore.h or embree3/rtcore.h in EMBREE_DIR, pkg-config or the standard include directories".into())
}

/// Looks for `embree4/rtcore.h`, then `embree3/rtcore.h` below `dir`; returns the major version and the
/// full version string read from `rtcore_config.h`.
fn probe_header_dir(dir: &Path) -> Option<(u32, String)> {
    for major in [4u32, 3] {
        let sub = dir.join(format!("embree{major}"));
        if sub.join("rtcore.h").is_file() {
            let config = std::fs::read_to_string(sub.join("rtcore_config.h")).unwrap_or_default();
            let version = read_version(&config).unwrap_or_else(|| format!("{major}"));
            return Some((major, version));
        }
    }
    None
}

fn read_version(config: &str) -> Option<String> {
    let field = |name: &str| -> Option<String> {
        config.lines().find_map(|l| {
            let mut it = l.split_whitespace();
            (it.next() == Some("#define") && it.next() == Some(name))
                .then(|| it.next().map(str::to_string))?
        })
    };
    if let Some(s) = field("RTC_VERSION_STRING") {
        return Some(s.trim_matches('"').to_string());
    }
    Some(format!(
        "{}.{}.{}",
        field("RTC_VERSION_MAJOR")?,
        field("RTC_VERSION_MINOR")?,
        field("RTC_VERSION_PATCH")?
    ))
}
