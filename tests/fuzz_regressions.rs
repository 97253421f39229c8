//! Every find of the fuzzer (`portalfind bench fuzz`, `src/suite/fuzz.rs`) is a file under
//! `tests/data/fuzz/<target>/`: shrunk, named by its bucket. Files directly there must pass
//! the fuzzer's own check (readers: no panic, typed errors; pipeline: a typed error or a
//! complex that validates, decimation without panic). Finds that still fail are kept in
//! `open/` (new classes) and `known/` (classes tracked elsewhere: "polygon crosses cell"),
//! checked by the ignored tests below; move a file up once it passes.

use portalfind::suite::fuzz::{Limits, Outcome, Target, check};
use std::path::PathBuf;

fn files(target: Target, sub: &str) -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/fuzz")
        .join(target.name())
        .join(sub);
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map(|d| {
            d.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_file())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Checks every file of `sub` for every target; returns the failures.
fn failures(sub: &str) -> Vec<String> {
    let mut out = Vec::new();
    for t in Target::ALL {
        for p in files(t, sub) {
            let bytes = std::fs::read(&p).unwrap();
            let o = check(t, &bytes, &Limits::default());
            eprintln!("{t} {}: {o:?}", p.display());
            if let Outcome::Fail { detail, .. } = o {
                out.push(format!("{t} {}: {detail}", p.display()));
            }
        }
    }
    out
}

#[test]
fn fixed_finds_pass() {
    let f = failures("");
    assert!(f.is_empty(), "{f:#?}");
}

/// New failure classes the fuzzer found that are not fixed yet (see the README there).
#[test]
#[ignore]
fn open_finds() {
    let f = failures("open");
    assert!(f.is_empty(), "{f:#?}");
}

/// Finds in the known class "polygon crosses cell" (issue 16; being fixed in the complex).
#[test]
#[ignore]
fn known_finds() {
    let f = failures("known");
    assert!(f.is_empty(), "{f:#?}");
}

/// The corpus itself: the readers accept or refuse every file without panicking.
#[test]
fn corpus_readers() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-corpus");
    for t in [Target::Obj, Target::Mesh] {
        for (name, bytes) in portalfind::suite::fuzz::load_corpus(&dir, t).unwrap() {
            let o = check(t, &bytes, &Limits::default());
            assert!(matches!(o, Outcome::Pass | Outcome::Refused), "{t} {name}: {o:?}");
        }
    }
}

/// The finds in `open/` and `known/` that still fail are refused by `run`: its checked
/// build (`pipeline::build_cells`, the cheap checks `run` applies before decimating) must
/// give a valid complex or `InvalidComplex` naming the violated invariant, never a
/// complex the full validation rejects, so `run` never exits 0 on them.
#[test]
fn unfixed_finds_are_refused_by_run() {
    use portalfind::pipeline::{CellSettings, PipelineError, Subdivision, build_cells};
    let mut n = 0;
    for sub_dir in ["open", "known"] {
        for p in files(Target::Pipeline, sub_dir) {
            let m = match portalfind::model::load_model(&p) {
                Ok(m) => m,
                Err(_) => continue, // refused at load: fine
            };
            for sub in Subdivision::ALL {
                match build_cells(&m, &p, &CellSettings::of(sub), &mut |_| {}) {
                    Ok(cells) => {
                        assert!(
                            cells.cx.validate(&m).is_ok(),
                            "{sub} {}: run's checks passed a complex the validation rejects",
                            p.display()
                        );
                    }
                    Err(PipelineError::InvalidComplex { source, .. }) => {
                        eprintln!("{sub} {}: refused: {source}", p.display());
                        assert!(!source.to_string().is_empty());
                        n += 1;
                    }
                    Err(e) => panic!("{sub} {}: unexpected error {e}", p.display()),
                }
            }
        }
    }
    eprintln!("{n} refusals");
}

/// On every pipeline find, in every folder, `run`'s checked build (`build_cells`: the
/// cheap checks at level 0, the full validation at the fallback levels) gives either a
/// typed error or a complex the full validation accepts, so `run` never exits 0 on an
/// invalid complex. `-d677291f` (fuzz seed 37, session 17) was such a find: a cell
/// thinner than the weld distance whose face loop crossed itself (a bowtie) passed the
/// plane tests, and its patch's open pieces exceeded the patch; faces must now be convex
/// loops (`check_faces`), so the split that made it is refused and the file validates.
#[test]
fn run_refuses_what_the_validation_rejects() {
    use portalfind::pipeline::{CellSettings, Subdivision, build_cells};
    let mut n = 0;
    for folder in ["", "fallback", "variant", "open", "known"] {
        for p in files(Target::Pipeline, folder) {
            let Ok(m) = portalfind::model::load_model(&p) else {
                continue;
            };
            for sub in Subdivision::ALL {
                if let Ok(cells) = build_cells(&m, &p, &CellSettings::of(sub), &mut |_| {}) {
                    let v = cells.cx.validate(&m);
                    assert!(
                        v.is_ok(),
                        "{sub} {}: run accepts a complex the validation rejects: {v:?}",
                        p.display()
                    );
                    n += 1;
                }
            }
        }
    }
    assert!(n > 0);
}

/// Finds whose complex fails the checks at the model's own tolerances and passes at a
/// fallback level of `pipeline::build_cells`' ladder (`Tolerances::fallback`): the
/// fuzzer's check (which runs the ladder, then the full validation) passes on each, and
/// each needs the ladder for at least one subdivision — when a find starts to pass at
/// level 0 (a root-cause fix in the complex), move it up to `pipeline/`.
#[test]
fn fallback_finds_pass_through_the_ladder_only() {
    use portalfind::pipeline::{CellSettings, Subdivision, build_cells_attempts};
    let f = failures("fallback");
    assert!(f.is_empty(), "{f:#?}");
    let files = files(Target::Pipeline, "fallback");
    assert!(!files.is_empty());
    for p in files {
        let m = portalfind::model::load_model(&p).expect("loads");
        let mut levels = Vec::new();
        for sub in Subdivision::ALL {
            let a = build_cells_attempts(&m, &p, &CellSettings::of(sub), &mut |_| {}).expect("builds");
            assert!(a.valid, "{sub} {}", p.display());
            assert_eq!(a.cells.cx.stats.tolerance_level as usize, a.cells.rejected.len());
            assert!(a.cells.cx.validate(&m).is_ok(), "{sub} {}", p.display());
            levels.push(a.cells.cx.stats.tolerance_level);
        }
        eprintln!("{}: levels {levels:?}", p.display());
        assert!(
            levels.iter().any(|&l| l > 0),
            "{} passes at level 0 now: move it up to pipeline/",
            p.display()
        );
    }
}

/// BSP finds invalid at every tolerance level of Teller's tree that pass with another
/// tree variant (`BspSettings::variant`, tried by `pipeline::build_cells`' ladder after the
/// tolerance levels, session 21): the fuzzer's check passes on each, the BSP complex
/// validates, and it needs a variant (when one passes with variant 0, move it up).
#[test]
fn variant_finds_pass_with_another_bsp_tree() {
    use portalfind::pipeline::{CellSettings, Subdivision, SubdivisionStats, build_cells_attempts};
    let f = failures("variant");
    assert!(f.is_empty(), "{f:#?}");
    let files = files(Target::Pipeline, "variant");
    assert!(!files.is_empty());
    for p in files {
        let m = portalfind::model::load_model(&p).expect("loads");
        let a = build_cells_attempts(&m, &p, &CellSettings::of(Subdivision::Bsp), &mut |_| {}).expect("builds");
        assert!(a.valid, "{}", p.display());
        assert!(a.cells.cx.validate(&m).is_ok(), "{}", p.display());
        let SubdivisionStats::Bsp(stats) = &a.cells.stats else {
            panic!("not a BSP")
        };
        eprintln!("{}: variant {}", p.display(), stats.variant);
        assert!(
            stats.variant > 0,
            "{} passes with variant 0 now: move it up",
            p.display()
        );
        // Every tolerance level of variant 0 was rejected first.
        let plain = a
            .cells
            .cx
            .stats
            .rejected_levels
            .iter()
            .filter(|r| !r.contains("BSP tree variant"))
            .count();
        assert_eq!(plain, 4, "{:?}", a.cells.cx.stats.rejected_levels);
    }
}

/// `run` on a find that needs the ladder: exits 0, warns with level 0's violation and the
/// level used, and records both in `result.json`; the base binary before the ladder
/// refused it with `InvalidComplex`.
#[test]
fn run_reports_the_fallback_level() {
    let model = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/fuzz/pipeline/fallback/delaunay_validate_model_polygon_n_crosses_the_in-ef417962.obj");
    let out = std::env::temp_dir().join(format!("portalfind-fallback-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_portalfind"))
        .arg("run")
        .arg(&model)
        .arg("--out")
        .arg(&out)
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("invalid at tolerance level 0: model polygon"), "{err}");
    assert!(err.contains("fallback tolerance level 1"), "{err}");
    let doc: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("result.json")).unwrap()).unwrap();
    assert_eq!(doc["complex"]["tolerance_level"], 1);
    let why = doc["complex"]["rejected_levels"][0].as_str().unwrap();
    assert!(why.starts_with("level 0: model polygon"), "{why}");
    std::fs::remove_dir_all(&out).unwrap();
}
