//! Command-line arguments that would make a check meaningless are refused by the parser
//! (exit code 2, naming the value and the valid range), and `gen rooms` creates a
//! missing parent folder (as `gen thesis` and `run` do). Found by a new-user trial, session 26.

use std::process::Command;

fn pf(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_portalfind"))
        .args(args)
        .output()
        .expect("run portalfind")
}

fn model() -> String {
    format!("{}/models/thesis/four_room_optimized.obj", env!("CARGO_MANIFEST_DIR"))
}

/// `run MODEL --out OUT EXTRA..` is refused by the argument parser (exit code 2), its error
/// contains `needle`, and nothing is written.
fn assert_run_refused(extra: &[&str], needle: &str) {
    let out = std::env::temp_dir().join(format!("portalfind-test-{}-refused", std::process::id()));
    let model = model();
    let mut args = vec!["run", model.as_str(), "--out", out.to_str().unwrap()];
    args.extend(extra);
    let o = pf(&args);
    assert_eq!(o.status.code(), Some(2), "{extra:?}");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains(needle), "{extra:?}: {err}");
    assert!(!out.exists(), "{extra:?}: nothing written");
}

#[test]
fn fields_of_view_outside_0_to_180_degrees_are_refused() {
    for fov in ["400", "nan", "0", "-5", "180", "inf"] {
        assert_run_refused(&["--walkthrough", &format!("--fov={fov}")], "not a field of view");
    }
}

#[test]
fn sampling_counts_of_zero_are_refused() {
    for flag in ["--points-per-cell", "--rays-per-point"] {
        assert_run_refused(&["--evaluate", flag, "0"], "at least 1");
    }
}

#[test]
fn gen_rooms_creates_a_missing_parent_folder() {
    let dir = std::env::temp_dir().join(format!("portalfind-test-{}-genrooms", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let path = dir.join("a/b/rooms.obj");
    let o = pf(&[
        "gen",
        "rooms",
        "--nx",
        "2",
        "--ny",
        "1",
        "--out",
        path.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(portalfind::model::load_model(&path).is_ok());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_bad_seal_size_names_every_valid_form_including_off() {
    let o = pf(&["complex", &model(), "--seal-holes", "xyz"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    for form in ["0.25", "1%", "auto", "off"] {
        assert!(err.contains(form), "{form}: {err}");
    }
}

/// `--stop cells:K` with K above the active cells collapses nothing: the run says so (a
/// warning naming both counts) instead of reporting "K cells reached"; the result is still
/// written (it is the unmerged complex, which has at most K cells).
#[test]
fn a_cells_target_above_the_active_cells_is_reported() {
    let out = std::env::temp_dir().join(format!("portalfind-test-{}-cells-above", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let o = pf(&[
        "run",
        &model(),
        "--stop",
        "cells:100000",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (stdout, stderr) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(!stdout.contains("100000 cells reached"), "{stdout}");
    assert!(stdout.contains("nothing collapsed"), "{stdout}");
    assert!(
        stderr.contains("warning: the stop rule cells:100000 asks for more cells than the run started with"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// A negative seal size reaches the value parser (its message names the valid forms),
/// instead of clap's tip to pass `-1` after `--`; a missing size before the next option
/// is still "a value is required". Found by a new-user trial.
#[test]
fn a_negative_seal_size_gets_the_parsers_message() {
    let o = pf(&["complex", &model(), "--seal-holes", "--no-validate"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("a value is required"));
    for cmd in ["complex", "run"] {
        for size in ["-1", "-0.5"] {
            let o = if cmd == "run" {
                let out = std::env::temp_dir().join(format!("portalfind-test-{}-negseal", std::process::id()));
                let o = pf(&["run", &model(), "--seal-holes", size, "--out", out.to_str().unwrap()]);
                assert!(!out.exists(), "nothing written");
                o
            } else {
                pf(&["complex", &model(), "--seal-holes", size])
            };
            assert_eq!(o.status.code(), Some(2), "{cmd} {size}");
            let err = String::from_utf8_lossy(&o.stderr);
            assert!(!err.contains("-- "), "{cmd} {size}: {err}");
            assert!(
                err.contains(&format!("bad hole size \"{size}\"")) && err.contains("positive size"),
                "{cmd} {size}: {err}"
            );
        }
    }
}

/// `--out afile/sub` with `afile` a file is refused naming the file, not as "cannot read".
/// Found by a new-user trial.
#[test]
fn an_output_path_through_a_file_names_the_file() {
    let base = std::env::temp_dir().join(format!("portalfind-test-{}-outfile", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    std::fs::create_dir_all(&base).unwrap();
    let afile = base.join("afile");
    std::fs::write(&afile, "not a folder").unwrap();
    for sub in ["sub", "sub/deeper"] {
        let out = afile.join(sub);
        let o = pf(&["run", &model(), "--out", out.to_str().unwrap()]);
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains(&format!("{} is a file, not a folder", afile.display())) && !err.contains("cannot read"),
            "{err}"
        );
    }
    assert_eq!(std::fs::read_to_string(&afile).unwrap(), "not a folder");
    std::fs::remove_dir_all(&base).unwrap();
}

/// `bench stress --seeds` names a seed the suite does not have instead of skipping it
/// (seeds 9,11 ran seed 9 alone, silently).
#[test]
fn a_stress_seed_outside_the_suite_is_refused() {
    let o = pf(&[
        "bench",
        "stress",
        "--seeds",
        "9,20",
        "--out",
        "/nonexistent/never-written",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("20") && err.contains("0..20"), "{err}");
}
