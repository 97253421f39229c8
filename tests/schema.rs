//! `docs/schema/*.schema.json` (JSON Schema, draft 2020-12) checked against real outputs: the
//! committed experiment results (written without timings) and a fresh library run (with
//! them). The validator below implements exactly the keywords the schemas use and refuses
//! any other, so a schema cannot silently rely on an unchecked keyword.

use portalfind::decimate::{Estimator, HeuristicKind, StopRule};
use portalfind::output;
use portalfind::pipeline::{self, Settings};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn read(p: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display())))
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

const KEYWORDS: [&str; 18] = [
    "$schema",
    "$id",
    "title",
    "description",
    "$defs",
    "$ref",
    "type",
    "const",
    "enum",
    "properties",
    "required",
    "additionalProperties",
    "items",
    "minItems",
    "maxItems",
    "minimum",
    "pattern",
    "oneOf",
];

fn type_ok(t: &str, v: &Value) -> bool {
    match t {
        "object" => v.is_object(),
        "array" => v.is_array(),
        "string" => v.is_string(),
        "number" => v.is_number(),
        "integer" => v.is_u64() || v.is_i64(),
        "boolean" => v.is_boolean(),
        "null" => v.is_null(),
        _ => panic!("unknown type {t}"),
    }
}

/// Validates `v` against `s` (within the root schema `root`); errors name the JSON path.
fn validate(root: &Value, s: &Value, v: &Value, path: &str, errs: &mut Vec<String>) {
    let Some(obj) = s.as_object() else {
        panic!("schema at {path} is not an object")
    };
    for k in obj.keys() {
        assert!(KEYWORDS.contains(&k.as_str()), "unsupported keyword {k} at {path}");
    }
    if let Some(r) = obj.get("$ref").and_then(Value::as_str) {
        let name = r.strip_prefix("#/$defs/").expect("only #/$defs/ references");
        validate(root, &root["$defs"][name], v, path, errs);
    }
    if let Some(t) = obj.get("type") {
        let ok = match t {
            Value::String(t) => type_ok(t, v),
            Value::Array(ts) => ts.iter().any(|t| type_ok(t.as_str().unwrap(), v)),
            _ => panic!("bad type at {path}"),
        };
        if !ok {
            errs.push(format!("{path}: expected type {t}, found {v}"));
            return;
        }
    }
    if let Some(alts) = obj.get("oneOf").and_then(Value::as_array) {
        let fits = alts
            .iter()
            .filter(|a| {
                let mut e = Vec::new();
                validate(root, a, v, path, &mut e);
                e.is_empty()
            })
            .count();
        if fits != 1 {
            errs.push(format!(
                "{path}: fits {fits} of the {} oneOf alternatives, not one",
                alts.len()
            ));
        }
    }
    if let Some(c) = obj.get("const")
        && c != v
    {
        errs.push(format!("{path}: expected {c}, found {v}"));
    }
    if let Some(e) = obj.get("enum").and_then(Value::as_array)
        && !e.contains(v)
    {
        errs.push(format!("{path}: {v} is not one of {e:?}"));
    }
    if let Some(m) = obj.get("minimum").and_then(Value::as_f64)
        && v.as_f64().is_some_and(|x| x < m)
    {
        errs.push(format!("{path}: {v} < {m}"));
    }
    if let Some(p) = obj.get("pattern").and_then(Value::as_str) {
        assert_eq!(p, "^[0-9a-f]{16}$", "only the hash pattern is implemented");
        let s = v.as_str().unwrap_or("");
        if s.len() != 16 || !s.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b)) {
            errs.push(format!("{path}: {v} does not match {p}"));
        }
    }
    if let Some(a) = v.as_array() {
        if let Some(n) = obj.get("minItems").and_then(Value::as_u64)
            && (a.len() as u64) < n
        {
            errs.push(format!("{path}: {} items < {n}", a.len()));
        }
        if let Some(n) = obj.get("maxItems").and_then(Value::as_u64)
            && (a.len() as u64) > n
        {
            errs.push(format!("{path}: {} items > {n}", a.len()));
        }
        if let Some(items) = obj.get("items") {
            for (i, x) in a.iter().enumerate() {
                validate(root, items, x, &format!("{path}[{i}]"), errs);
            }
        }
    }
    if let Some(o) = v.as_object() {
        let props = obj.get("properties").and_then(Value::as_object);
        if let Some(req) = obj.get("required").and_then(Value::as_array) {
            for r in req {
                if !o.contains_key(r.as_str().unwrap()) {
                    errs.push(format!("{path}: missing {r}"));
                }
            }
        }
        for (k, x) in o {
            let p = format!("{path}.{k}");
            match (props.and_then(|ps| ps.get(k)), obj.get("additionalProperties")) {
                (Some(sub), _) => validate(root, sub, x, &p, errs),
                (None, Some(Value::Bool(false))) => errs.push(format!("{p}: not allowed")),
                (None, Some(Value::Bool(true))) | (None, None) => {}
                (None, Some(sub)) => validate(root, sub, x, &p, errs),
            }
        }
    }
}

fn errors(schema: &Value, v: &Value) -> Vec<String> {
    let mut e = Vec::new();
    validate(schema, schema, v, "$", &mut e);
    e
}

fn schema(name: &str) -> Value {
    read(&repo().join("docs/schema").join(name))
}

#[test]
fn committed_experiment_results_match_the_schemas() {
    let (rs, ms) = (schema("result.schema.json"), schema("manifest.schema.json"));
    let mut checked = 0;
    for e in std::fs::read_dir(repo().join("results")).unwrap() {
        let dir = e.unwrap().path();
        // e1m1's result.json is git-ignored (10 MB): checked only when a run left it.
        for (file, s) in [("result.json", &rs), ("manifest.json", &ms)] {
            let p = dir.join(file);
            if p.is_file() {
                let errs = errors(s, &read(&p));
                assert!(errs.is_empty(), "{}: {errs:#?}", p.display());
                checked += 1;
            }
        }
    }
    assert!(checked >= 30, "only {checked} files checked");
}

#[test]
fn a_fresh_run_with_timings_matches_and_bad_documents_do_not() {
    let dir = std::env::temp_dir().join(format!("portalfind-schema-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let tm = portalfind::generate::thesis::by_name("four_room_optimized").unwrap();
    portalfind::generate::thesis::write(&tm, &dir).unwrap();
    let mut s = Settings::default();
    s.decimation.heuristic = HeuristicKind::Refined;
    s.decimation.estimator = Estimator::Hull;
    s.decimation.stop = StopRule::Cells(4);
    let (m, r) = pipeline::run(&dir.join("four_room_optimized.obj"), &s, &mut |_| {}).unwrap();
    let out = dir.join("out");
    output::write_outputs(&out, &m, &r.doc, &r.dec).unwrap();
    let (rs, ms) = (schema("result.schema.json"), schema("manifest.schema.json"));
    let doc = read(&out.join("result.json"));
    assert!(
        doc["stages"].as_array().is_some_and(|a| !a.is_empty()),
        "a plain run keeps its timings"
    );
    assert_eq!(errors(&rs, &doc), Vec::<String>::new());
    let manifest = read(&out.join("manifest.json"));
    assert_eq!(errors(&ms, &manifest), Vec::<String>::new());
    // A version-2 entry with a version-1 hash, or a version-1 manifest with version-2
    // entries, fits no alternative.
    let mut mixed = manifest.clone();
    let hash = mixed["files"][0]["xxh3_64"].take();
    mixed["files"][0].as_object_mut().unwrap().remove("xxh3_64");
    mixed["files"][0]["fnv1a64"] = hash;
    assert!(errors(&ms, &mixed).join("\n").contains("$: fits 0 of the 2 oneOf"));
    let mut v1 = manifest.clone();
    v1["schema_version"] = Value::from(1);
    assert!(errors(&ms, &v1).join("\n").contains("$: fits 0 of the 2 oneOf"));
    // The validator is not vacuous.
    let mut bad = doc.clone();
    bad["cells"][0]["volume"] = Value::from("big");
    bad.as_object_mut().unwrap().remove("portals");
    bad["settings"]["heuristic"] = Value::from("magic");
    bad["extra"] = Value::from(1);
    let e = errors(&rs, &bad).join("\n");
    for want in [
        "$.cells[0].volume: expected type",
        "$: missing \"portals\"",
        "$.settings.heuristic",
        "$.extra: not allowed",
    ] {
        assert!(e.contains(want), "{want} not reported in\n{e}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
