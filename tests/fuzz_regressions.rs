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
