//! What an output path can be: under folders named in any script (the EXR header keeps the scene's
//! path as UTF-8, which OpenEXR's Python bindings read), and never a node that is not a regular
//! file (a device, a FIFO, a directory), which the write-then-rename step would replace.

use crate::support::{ftpd3d_in, in_ci, scene_path, skip_without, temp_dir};
use std::os::unix::fs::FileTypeExt;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The flags of a small quiet slice (with its PNG previews).
const SMALL: [&str; 9] = [
    "--slice", "z=0", "--res", "8", "--spp", "4", "--seed", "3", "--quiet",
];

/// The Cornell box copied into `dir/folder` as `name` (with its `.mtl`).
fn copy_scene(dir: &Path, folder: &str, name: &str) -> String {
    let to = dir.join(folder);
    std::fs::create_dir_all(&to).unwrap();
    std::fs::copy(scene_path("cornell_mirror.obj"), to.join(name)).unwrap();
    std::fs::copy(
        scene_path("cornell_mirror.mtl"),
        to.join("cornell_mirror.mtl"),
    )
    .unwrap();
    format!("{folder}/{name}")
}

/// The text attribute `key` of part 0 of an EXR as OpenEXR's Python bindings give it (`None`:
/// python3 with OpenEXR is not here; the reason is printed, and CI fails instead).
fn python_attribute(path: &Path, key: &str) -> Option<String> {
    let probe = Command::new("python3")
        .args(["-c", "import OpenEXR"])
        .output();
    let missing = match probe {
        Err(e) => Some(format!("python3: {e}")),
        Ok(o) if !o.status.success() => Some("python3 cannot import OpenEXR".to_string()),
        Ok(_) => None,
    };
    if skip_without("output_paths::python_attribute", missing, in_ci()) {
        return None;
    }
    let script = "import OpenEXR, sys\n\
                  f = OpenEXR.File(sys.argv[1], separate_channels=True)\n\
                  sys.stdout.buffer.write(f.parts[0].header[sys.argv[2]].encode('utf-8'))\n";
    let out = Command::new("python3")
        .args(["-c", script])
        .arg(path)
        .arg(key)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "OpenEXR could not read {key} of {}: {}",
        path.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    Some(String::from_utf8(out.stdout).unwrap())
}

/// A scene under a folder named in Latin-1, CJK or emoji characters (and an output named so) runs
/// to the end, and the EXR's header gives the scene's path back as given, through the project's
/// reader and through Python OpenEXR.
#[test]
fn scene_paths_in_any_script_round_trip() {
    let dir = temp_dir("output_paths", "scripts");
    for (folder, name, out) in [
        ("scène", "café.obj", "résultat/é.exr"),
        ("目录", "場景.obj", "结果/场.exr"),
        ("🎉 emoji", "🌍.obj", "🎨/🖼.exr"),
    ] {
        let scene = copy_scene(&dir, folder, name);
        let mut args = vec!["--scene", &scene];
        args.extend_from_slice(&SMALL);
        args.extend_from_slice(&["-o", out]);
        let r = ftpd3d_in(&dir, &args);
        assert!(r.ok, "{scene}: {}", r.err);
        let file = dir.join(out);
        let field = ftpd3d::output::exr::read_exr(&file).unwrap();
        assert_eq!(field.meta["scene"], scene);
        assert!(dir.join(out).with_extension("png").is_file());
        if let Some(read) = python_attribute(&file, "ftpd3d.scene") {
            assert_eq!(read, scene, "Python OpenEXR reads the header back");
        }
    }
}

/// The kind of the node at `path`, as `ls -l` shows its first letter.
fn kind(path: &Path) -> char {
    let t = std::fs::symlink_metadata(path).unwrap().file_type();
    match () {
        _ if t.is_char_device() => 'c',
        _ if t.is_fifo() => 'p',
        _ if t.is_dir() => 'd',
        _ if t.is_file() => '-',
        _ => '?',
    }
}

/// Runs the binary in `dir` with `args`, and fails if it has not returned within 30 s (a run that
/// opened a FIFO would wait for a reader for ever): exit success and stderr.
fn run_bounded(dir: &Path, args: &[&str]) -> (bool, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_ftpd3d"))
        .current_dir(dir)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > Duration::from_secs(30) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("ftpd3d {args:?} had not returned after 30 s");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
    (status.success(), err)
}

/// Makes a node with the command `cmd` (`mknod NAME c 1 3`, `mkfifo NAME`) in `dir`: whether it
/// could (else the reason is printed, and CI fails instead).
fn make_node(dir: &Path, test: &str, cmd: &[&str]) -> bool {
    let out = Command::new(cmd[0])
        .current_dir(dir)
        .args(&cmd[1..])
        .output();
    let missing = match out {
        Err(e) => Some(format!("{}: {e}", cmd[0])),
        Ok(o) if !o.status.success() => Some(format!(
            "{} not permitted: {}",
            cmd.join(" "),
            String::from_utf8_lossy(&o.stderr).trim()
        )),
        Ok(_) => None,
    };
    !skip_without(test, missing, in_ci())
}

/// `-o` onto a character device, a FIFO or a directory, or an output whose preview `X.png` is a
/// FIFO, is refused at once with a message naming `-o` and the path: the node is still what it
/// was, nothing is written, and the run returns (a FIFO is never opened).
#[test]
fn outputs_that_are_not_regular_files_are_refused() {
    let dir = temp_dir("output_paths", "not_regular");
    let test = "output_paths::outputs_that_are_not_regular_files_are_refused";
    let mut cases: Vec<(&str, &str, &str, char)> = Vec::new();
    if make_node(&dir, test, &["mknod", "device.exr", "c", "1", "3"]) {
        cases.push(("device.exr", "device.exr", "character device", 'c'));
    }
    if make_node(&dir, test, &["mkfifo", "fifo.exr"]) {
        cases.push(("fifo.exr", "fifo.exr", "FIFO", 'p'));
    }
    if make_node(&dir, test, &["mkfifo", "out.png"]) {
        cases.push(("out.exr", "out.png", "FIFO", 'p'));
    }
    std::fs::create_dir(dir.join("folder.exr")).unwrap();
    cases.push(("folder.exr", "folder.exr", "directory", 'd'));
    let scene = scene_path("cornell_mirror.obj");
    for (output, node, what, was) in cases {
        // A camera image's output is checked before the scene loads, a slice's once its plane is
        // resolved: both before the run.
        for domain in [
            &["--slice", "z=0", "--res", "8"][..],
            &["--camera", "--size", "8,8"],
        ] {
            let mut args = vec!["--scene", scene.to_str().unwrap()];
            args.extend_from_slice(domain);
            args.extend_from_slice(&["--spp", "4", "--quiet", "-o", output]);
            let (ok, err) = run_bounded(&dir, &args);
            assert!(!ok, "-o {output} ({node} a {what}) was accepted");
            assert!(
                err.contains(&format!("-o {output}")) && err.contains(node) && err.contains(what),
                "{err}"
            );
            assert_eq!(kind(&dir.join(node)), was, "{node} is still a {what}");
            if output != node {
                assert!(!dir.join(output).exists(), "nothing written beside {node}");
            }
        }
    }
}
