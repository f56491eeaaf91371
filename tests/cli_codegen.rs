//! `qpv codegen` never overwrites its inputs and writes C that compiles:
//! targets that are (by device and inode, symlinks and hard links
//! followed) the model file or the gains file are refused with nothing
//! written, a target directory leaves no half export behind, a model name
//! that would shadow a C standard header is refused at its position, and a
//! model path with trigraph sequences compiles under `-std=c99 -Werror`.

use super::common::{qpv, text};
use std::path::{Path, PathBuf};
use std::process::Command;

/// A fresh, empty directory for one test.
fn fresh(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("qpv-codegen-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// The model of tests/nostd/paper_sound.qpv (model `paper_sound`).
fn paper_sound() -> String {
    std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/nostd/paper_sound.qpv"),
    )
    .expect("model")
}

/// A gains file in the report form `qpv codegen --gains` reads (its
/// numbers are never reached: the targets are refused first).
fn gains_text() -> String {
    let l = "[[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]";
    format!(
        r#"{{"model": "paper_sound", "mode": "sound", "alpha": 10.0, "gamma": 0.1889, "P": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], "L": [{l}, {l}, {l}, {l}]}}"#
    )
}

/// The names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Runs `qpv codegen` with `args` and asserts exit 2 with `says` in the output.
fn refused(args: &[&str], says: &str) {
    let out = qpv(args);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{args:?}:\n{t}");
    assert!(t.contains(says), "{args:?}: expected `{says}` in:\n{t}");
}

#[test]
fn codegen_refuses_a_target_that_is_the_model_file() {
    let d = fresh("model-is-target");
    let model = d.join("paper_sound.c");
    std::fs::write(&model, paper_sound()).expect("model written");
    let ds = d.to_str().expect("utf-8");
    refused(
        &["codegen", model.to_str().expect("utf-8"), "--out", ds],
        "is the model file",
    );
    assert_eq!(
        std::fs::read_to_string(&model).expect("model"),
        paper_sound()
    );
    assert_eq!(listing(&d), ["paper_sound.c"], "nothing written");
}

#[test]
fn codegen_refuses_a_target_that_is_the_gains_file() {
    let d = fresh("gains-is-target");
    let model = d.join("model.qpv");
    std::fs::write(&model, paper_sound()).expect("model written");
    let gains = d.join("paper_sound.h");
    std::fs::write(&gains, gains_text()).expect("gains written");
    let ds = d.to_str().expect("utf-8");
    refused(
        &[
            "codegen",
            model.to_str().expect("utf-8"),
            "--gains",
            gains.to_str().expect("utf-8"),
            "--out",
            ds,
        ],
        "is the gains file",
    );
    assert_eq!(
        std::fs::read_to_string(&gains).expect("gains"),
        gains_text()
    );
    assert_eq!(listing(&d), ["model.qpv", "paper_sound.h"]);
}

#[cfg(unix)]
#[test]
fn codegen_refuses_symlinks_and_hard_links_to_its_inputs() {
    let d = fresh("links");
    let model = d.join("model.qpv");
    std::fs::write(&model, paper_sound()).expect("model written");
    let gains = d.join("gains.json");
    std::fs::write(&gains, gains_text()).expect("gains written");
    let m = model.to_str().expect("utf-8");
    // OUT/paper_sound.c a symlink to the model file
    let out = d.join("sym");
    std::fs::create_dir_all(&out).expect("out");
    std::os::unix::fs::symlink(&model, out.join("paper_sound.c")).expect("symlink");
    let o = out.to_str().expect("utf-8");
    refused(&["codegen", m, "--out", o], "is the model file");
    // OUT/paper_sound.h a hard link to the gains file
    let out = d.join("hard");
    std::fs::create_dir_all(&out).expect("out");
    std::fs::hard_link(&gains, out.join("paper_sound.h")).expect("hard link");
    let o = out.to_str().expect("utf-8");
    let g = gains.to_str().expect("utf-8");
    refused(
        &["codegen", m, "--gains", g, "--out", o],
        "is the gains file",
    );
    // and the model given through a symlink, OUT/paper_sound.h its hard link
    let out = d.join("both");
    std::fs::create_dir_all(&out).expect("out");
    std::fs::hard_link(&model, out.join("paper_sound.h")).expect("hard link");
    let via = d.join("via.qpv");
    std::os::unix::fs::symlink(&model, &via).expect("symlink");
    let o = out.to_str().expect("utf-8");
    refused(
        &["codegen", via.to_str().expect("utf-8"), "--out", o],
        "is the model file",
    );
    assert_eq!(
        std::fs::read_to_string(&model).expect("model"),
        paper_sound()
    );
    assert_eq!(
        std::fs::read_to_string(&gains).expect("gains"),
        gains_text()
    );
    assert_eq!(listing(&d.join("sym")), ["paper_sound.c"]);
    assert_eq!(listing(&d.join("hard")), ["paper_sound.h"]);
    assert_eq!(listing(&d.join("both")), ["paper_sound.h"]);
}

#[test]
fn codegen_writes_nothing_when_a_target_is_a_directory() {
    let d = fresh("target-dir");
    std::fs::create_dir_all(d.join("paper_sound.c")).expect("dir");
    let ds = d.to_str().expect("utf-8");
    refused(
        &["codegen", "tests/nostd/paper_sound.qpv", "--out", ds],
        "is a directory: nothing written",
    );
    assert_eq!(listing(&d), ["paper_sound.c"], "no header, no temporaries");
    assert!(listing(&d.join("paper_sound.c")).is_empty());
}

#[test]
fn codegen_refuses_a_model_name_that_shadows_a_standard_header() {
    let d = fresh("std-header");
    for name in ["limits", "math", "stdint", "Stdio"] {
        let text = paper_sound().replace("model paper_sound {", &format!("model {name} {{"));
        let model = d.join(format!("{name}.qpv"));
        std::fs::write(&model, text).expect("model written");
        let out = d.join("out");
        let (m, o) = (model.to_str().expect("utf-8"), out.to_str().expect("utf-8"));
        // positioned at the model's name (line 3, column 7)
        refused(
            &["codegen", m, "--out", o],
            &format!("{m}:3:7: model name `{name}`"),
        );
        refused(&["codegen", m, "--out", o], "shadows the C standard header");
        assert!(!out.exists(), "{name}: nothing written");
    }
}

/// `qpv codegen` of the paper_sound model from a directory whose name holds
/// the trigraph sequences `??=`, `??/`, `??(`: the path is baked into the
/// certificate, and the C must compile under `-std=c99 -Wall -Werror`
/// (`-Wtrigraphs`) and print the path unchanged.
#[test]
fn a_model_path_with_trigraphs_compiles_and_reads_back() {
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    if !Command::new(&cc)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        assert!(std::env::var_os("CI").is_none(), "no C compiler `{cc}`");
        eprintln!("SKIPPED: no C compiler `{cc}`");
        return;
    }
    let d = fresh("trigraph");
    let dir = d.join("a??=b??/c??(d?\"q\\");
    std::fs::create_dir_all(&dir).expect("dir");
    let model = dir.join("m??-.qpv");
    std::fs::write(&model, paper_sound()).expect("model written");
    let out = d.join("out");
    let run = qpv(&[
        "codegen",
        model.to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert_eq!(run.status.code(), Some(0), "{}", text(&run));
    assert_eq!(
        listing(&out),
        ["paper_sound.c", "paper_sound.h"],
        "no temporaries left"
    );
    let driver = "#include \"paper_sound.h\"\n#include <stdio.h>\n\
                  int main(void) { fputs(paper_sound_CERTIFICATE, stdout); return 0; }\n";
    std::fs::write(out.join("main.c"), driver).expect("driver");
    let exe = out.join("main");
    let c = Command::new(&cc)
        .args([
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-pedantic",
            "-Wtrigraphs",
        ])
        .arg("-I")
        .arg(&out)
        .arg(out.join("main.c"))
        .arg(out.join("paper_sound.c"))
        .arg("-o")
        .arg(&exe)
        .output()
        .expect("cc runs");
    assert!(
        c.status.success(),
        "the C does not compile:\n{}",
        String::from_utf8_lossy(&c.stderr)
    );
    let printed = Command::new(&exe).output().expect("runs");
    let printed = String::from_utf8_lossy(&printed.stdout);
    assert!(
        printed.contains(&model.display().to_string()),
        "the certificate names the model path as it is:\n{printed}"
    );
}
