//! A run's files as one set: staged in a hidden sibling directory, then swapped in, with
//! `manifest.json` written last naming every file (size and XXH3-64 hash; manifests of
//! version 1 hold FNV-1a hashes, still read).
//!
//! - **Staging.** Every exporter writes into `PARENT/.NAME.portalfind-PID-N/`. An error
//!   there (disk full, a failing exporter) or an interrupt removes the staging directory and
//!   the parent directories this call created; the output directory is not touched.
//! - **Swap.** A new output directory is the staging directory renamed (one atomic step).
//!   Into an existing one, the previous set is first marked incomplete (its manifest is
//!   replaced by one with `complete: false` naming both sets), then moved aside, the new
//!   files are renamed in and the complete manifest is written last; an error in between
//!   moves the previous set back. A process killed in between leaves the incomplete
//!   manifest, which readers ([`super::read_result`], so `locate`) refuse, and which the
//!   next run replaces as a whole.
//! - **Ownership.** Only files of the previous set (named by its manifest; for output
//!   written before manifests existed, files with output names beside a `result.json` of
//!   ours or a caller's [`SetOptions::later`] file) are replaced or removed. A file with an
//!   output name that no manifest lists makes the run refuse before it writes anything;
//!   other files are left alone and reported ([`Written::foreign`]).
//! - **Interrupts.** [`interrupt`] (the binary calls it on Ctrl-C) stops any write in
//!   progress at its next file, removes what it staged, and blocks further writes.

use super::{ExportContext, Exporter, OutputError, RESULT_FILE, ResultDoc, Snapshot};
use crate::decimate::Decimation;
use crate::model::Model;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, MutexGuard};

/// The manifest's file name in an output directory.
pub const MANIFEST_FILE: &str = "manifest.json";
/// Value of [`Manifest::schema`].
pub const MANIFEST_SCHEMA: &str = "portalfind-manifest";
/// Value of [`Manifest::schema_version`] written: 2 (files hashed with XXH3-64).
pub const MANIFEST_VERSION: u32 = 2;
/// The oldest [`Manifest::schema_version`] read: 1 (files hashed with FNV-1a 64, one byte
/// per step: about 0.6 s of CPU for the 700 MB a million-triangle run writes).
pub const MANIFEST_VERSION_MIN: u32 = 1;

/// `manifest.json`: the files of one run (schema in `docs/result-schema.md`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Manifest {
    /// Always [`MANIFEST_SCHEMA`].
    pub schema: String,
    /// [`MANIFEST_VERSION`] when written; [`MANIFEST_VERSION_MIN`] to it when read.
    pub schema_version: u32,
    /// `portalfind` version that wrote it.
    pub generator: String,
    /// `false` while the set is being swapped in (a reader must refuse the directory).
    pub complete: bool,
    /// The run's files, in the order of the exporters.
    pub files: Vec<FileEntry>,
    /// Files that the caller writes after the set (the experiment runner's
    /// `evaluation.json`): part of the set, not hashed.
    #[serde(default)]
    pub later: Vec<String>,
    /// While incomplete: the previous set's files, which may still be in the directory.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub replacing: Vec<String>,
}

/// One file of a [`Manifest`].
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileEntry {
    /// File name in the output directory.
    pub name: String,
    /// Size in bytes.
    pub bytes: u64,
    /// XXH3 64-bit hash (seed 0) of the content, 16 lower-case hex digits: what `xxhsum
    /// -H3 FILE` prints. Written by version 2.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub xxh3_64: Option<String>,
    /// FNV-1a 64-bit hash of the content, 16 lower-case hex digits: version 1 manifests
    /// (read, never written).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fnv1a64: Option<String>,
}

/// The hash functions a [`FileEntry`] may hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum HashKind {
    /// XXH3-64, seed 0 (written).
    Xxh3,
    /// FNV-1a 64 (version 1 manifests).
    Fnv1a,
}

/// A streaming hash of one [`HashKind`].
enum Digest {
    Xxh3(Box<xxhash_rust::xxh3::Xxh3Default>),
    Fnv1a(u64),
}

impl Digest {
    fn new(kind: HashKind) -> Self {
        match kind {
            HashKind::Xxh3 => Digest::Xxh3(Box::new(xxhash_rust::xxh3::Xxh3Default::new())),
            HashKind::Fnv1a => Digest::Fnv1a(0xcbf2_9ce4_8422_2325),
        }
    }

    fn update(&mut self, bytes: &[u8]) {
        match self {
            Digest::Xxh3(h) => h.update(bytes),
            Digest::Fnv1a(h) => *h = fnv1a64_from(*h, bytes),
        }
    }

    /// The entry of `bytes` bytes hashed so, under `name`.
    fn entry(&self, name: &str, bytes: u64) -> FileEntry {
        let (xxh3_64, fnv1a64) = match self {
            Digest::Xxh3(h) => (Some(format!("{:016x}", h.digest())), None),
            Digest::Fnv1a(h) => (None, Some(format!("{h:016x}"))),
        };
        FileEntry {
            name: name.to_string(),
            bytes,
            xxh3_64,
            fnv1a64,
        }
    }
}

impl FileEntry {
    /// The hash this entry holds (XXH3 when it holds both).
    fn kind(&self) -> HashKind {
        if self.xxh3_64.is_none() && self.fnv1a64.is_some() {
            HashKind::Fnv1a
        } else {
            HashKind::Xxh3
        }
    }
}

/// Options of [`write_run`].
#[derive(Clone, Copy, Debug, Default)]
pub struct SetOptions<'a> {
    /// File names the caller writes into the directory after the set; they belong to the
    /// run (replaced with it, never taken for foreign files).
    pub later: &'a [&'a str],
    /// The cell complex, for the opt-in formats that read cell geometry.
    pub cx: Option<&'a crate::complex::CellComplex>,
    /// Opt-in formats to write as well (`prt`, `obj`, `gltf`, `dot`, `html`; see
    /// [`super::opt_in_formats`]); an unknown name is an error before anything is written.
    pub export: &'a [String],
    /// Annotations for the pictures (full run, first room join, ground truth).
    pub notes: super::Notes<'a>,
    /// Leave machine-dependent figures (timings) out of `result.json`, so that a rerun on
    /// another machine writes the same bytes (the experiments' committed results).
    pub strip_timings: bool,
}

/// What [`write_run`] did.
#[derive(Clone, Debug, Default)]
pub struct Written {
    /// The run's files (final paths, in the order of the exporters), without the manifest.
    pub files: Vec<PathBuf>,
    /// Files of the previous run's set that this run does not write again, removed.
    pub removed: Vec<String>,
    /// Other entries of the directory, left untouched (sorted).
    pub foreign: Vec<String>,
    /// Staging directories of interrupted runs (dead processes) that were removed.
    pub swept: Vec<PathBuf>,
}

/// Held while a set is written or removed, and by [`interrupt`] until the process exits.
static LOCK: Mutex<()> = Mutex::new(());
static INTERRUPTED: AtomicBool = AtomicBool::new(false);
static STAGING_SEQ: AtomicUsize = AtomicUsize::new(0);

fn lock() -> MutexGuard<'static, ()> {
    LOCK.lock().unwrap_or_else(|p| p.into_inner())
}

/// Stops output writing for good: a write in progress removes what it staged (at its next
/// file) and returns [`OutputError::Interrupted`], as does every later one. Returns once
/// no write is in progress; hold the guard until the process exits (the binary's Ctrl-C
/// handler does this, then exits), so that nothing starts afterwards.
pub fn interrupt() -> MutexGuard<'static, ()> {
    INTERRUPTED.store(true, Ordering::SeqCst);
    lock()
}

fn interrupted() -> Result<(), OutputError> {
    if INTERRUPTED.load(Ordering::SeqCst) {
        Err(OutputError::Interrupted)
    } else {
        Ok(())
    }
}

/// FNV-1a, 64 bits, of `bytes` continued from state `h`.
fn fnv1a64_from(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// FNV-1a, 64 bits.
#[cfg(test)]
fn fnv1a64(bytes: &[u8]) -> u64 {
    fnv1a64_from(0xcbf2_9ce4_8422_2325, bytes)
}

/// [`entry_of`] for the file at `path`, streamed in blocks (a run's `result.json` is a
/// few hundred MB at a million triangles: reading it whole raised the run's peak memory),
/// with the hash of `kind`.
fn entry_of_file(name: &str, path: &Path, kind: HashKind) -> Result<FileEntry, OutputError> {
    use std::io::Read;
    let mut f = std::fs::File::open(path).map_err(io_read(path))?;
    let mut buf = vec![0u8; 1 << 16];
    let (mut h, mut n) = (Digest::new(kind), 0u64);
    loop {
        let k = match f.read(&mut buf) {
            Ok(0) => break,
            Ok(k) => k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(io_read(path)(e)),
        };
        h.update(&buf[..k]);
        n += k as u64;
    }
    Ok(h.entry(name, n))
}

/// A writer that passes bytes on and hashes them on the way (XXH3-64, as
/// [`entry_of_file`] would read them back): an exporter that writes through it records the
/// manifest entry itself ([`ExportContext::hashed`]), saving the read-back of a large file.
pub struct HashingWriter<W> {
    inner: W,
    hash: Digest,
    bytes: u64,
}

impl<W: std::io::Write> HashingWriter<W> {
    /// Wraps `inner`.
    pub fn new(inner: W) -> Self {
        HashingWriter {
            inner,
            hash: Digest::new(HashKind::Xxh3),
            bytes: 0,
        }
    }

    /// The manifest entry of what was written, under `name`, and the inner writer.
    pub fn finish(self, name: &str) -> (FileEntry, W) {
        (self.hash.entry(name, self.bytes), self.inner)
    }
}

impl<W: std::io::Write> std::io::Write for HashingWriter<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let k = self.inner.write(buf)?;
        self.hash.update(&buf[..k]);
        self.bytes += k as u64;
        Ok(k)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// The entry of `bytes` under `name`, with the hash of `kind`.
fn entry_of(name: &str, bytes: &[u8], kind: HashKind) -> FileEntry {
    let mut h = Digest::new(kind);
    h.update(bytes);
    h.entry(name, bytes.len() as u64)
}

fn io_read(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Read {
        path: path.to_path_buf(),
        source,
    }
}

/// The manifest of `dir`: `Ok(None)` if there is none; an error if it is unreadable or
/// not ours.
pub fn read_manifest(dir: &Path) -> Result<Option<Manifest>, OutputError> {
    let path = dir.join(MANIFEST_FILE);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(io_read(&path)(e)),
    };
    let m: Manifest = serde_json::from_str(&text).map_err(|source| OutputError::Parse {
        path: path.clone(),
        source,
    })?;
    if m.schema != MANIFEST_SCHEMA || !(MANIFEST_VERSION_MIN..=MANIFEST_VERSION).contains(&m.schema_version) {
        return Err(OutputError::ManifestSchema {
            path,
            schema: m.schema,
            version: m.schema_version,
        });
    }
    Ok(Some(m))
}

/// Checks `bytes`, read from `dir/name`, against `dir`'s manifest: fine without a manifest
/// (output of a version before manifests); an error if the manifest is incomplete (an
/// interrupted run), does not list `name`, or lists other content.
pub fn verify_file(dir: &Path, name: &str, bytes: &[u8]) -> Result<(), OutputError> {
    let Some(m) = read_manifest(dir)? else {
        return Ok(());
    };
    if !m.complete {
        return Err(OutputError::IncompleteRun { dir: dir.to_path_buf() });
    }
    if !m
        .files
        .iter()
        .find(|e| e.name == name)
        .is_some_and(|e| *e == entry_of(name, bytes, e.kind()))
    {
        return Err(OutputError::NotInManifest { path: dir.join(name) });
    }
    Ok(())
}

/// Checks every file of `dir`'s manifest (present, same size and hash) and returns the
/// manifest; an error if there is none.
pub fn check_run(dir: &Path) -> Result<Manifest, OutputError> {
    let m = read_manifest(dir)?.ok_or_else(|| OutputError::NoManifest { dir: dir.to_path_buf() })?;
    if !m.complete {
        return Err(OutputError::IncompleteRun { dir: dir.to_path_buf() });
    }
    for e in &m.files {
        let p = dir.join(&e.name);
        if entry_of_file(&e.name, &p, e.kind())? != *e {
            return Err(OutputError::NotInManifest { path: p });
        }
    }
    Ok(m)
}

/// The names of the files of an earlier run in `dir` (which exists): its manifest's, or for
/// output written before manifests existed, the files with output names when `dir` holds a
/// `result.json` of ours or one of `later`. `Ok(None)` when a `manifest.json` there is not
/// ours (then it is a foreign file).
fn previous_set(dir: &Path, list: &[Box<dyn Exporter>], later: &[&str]) -> Result<Vec<String>, OutputError> {
    match read_manifest(dir) {
        Ok(Some(m)) => {
            let mut names: Vec<String> = m.files.into_iter().map(|e| e.name).collect();
            names.extend(m.later);
            names.extend(m.replacing);
            names.push(MANIFEST_FILE.into());
            return Ok(names);
        }
        Ok(None) => {}
        // Not a manifest of ours: no set is known, and the file is a conflict.
        Err(OutputError::Parse { .. } | OutputError::ManifestSchema { .. }) => return Ok(Vec::new()),
        Err(e) => return Err(e),
    }
    let ours = |name: &str| {
        let mut head = [0u8; 64];
        let n = std::fs::File::open(dir.join(name))
            .and_then(|mut f| std::io::Read::read(&mut f, &mut head))
            .unwrap_or(0);
        let head = String::from_utf8_lossy(&head[..n]).replace([' ', '\n', '\r', '\t'], "");
        head.starts_with(&format!("{{\"schema\":\"{}\"", super::SCHEMA))
    };
    let legacy = ours(RESULT_FILE) || later.iter().any(|l| dir.join(l).is_file());
    if !legacy {
        return Ok(Vec::new());
    }
    Ok(entries(dir)?
        .into_iter()
        .filter(|n| list.iter().any(|x| x.owns(n)) || later.contains(&n.as_str()))
        .collect())
}

/// The names in `dir` (sorted).
fn entries(dir: &Path) -> Result<Vec<String>, OutputError> {
    let rd = std::fs::read_dir(dir).map_err(io_read(dir))?;
    let mut v = Vec::new();
    for e in rd {
        let e = e.map_err(io_read(dir))?;
        v.push(e.file_name().to_string_lossy().into_owned());
    }
    v.sort();
    Ok(v)
}

/// Entries of `dir` that a run would write or that look like outputs (an exporter owns the
/// name, or it is the manifest or one of `names`), but that are not in `previous`.
fn conflicts(
    dir: &Path,
    list: &[Box<dyn Exporter>],
    names: &[String],
    later: &[&str],
    previous: &[String],
) -> Result<Vec<String>, OutputError> {
    Ok(entries(dir)?
        .into_iter()
        .filter(|n| {
            let output_name = n == MANIFEST_FILE
                || list.iter().any(|x| x.owns(n))
                || names.contains(n)
                || later.contains(&n.as_str());
            output_name && !previous.contains(n)
        })
        .collect())
}

/// `dir` as (existing-or-not parent, file name), resolving `.` and `..`.
fn split_dir(dir: &Path) -> Result<(PathBuf, String), OutputError> {
    let named = dir
        .file_name()
        .filter(|_| !matches!(dir.components().next_back(), Some(std::path::Component::ParentDir)));
    if let Some(name) = named {
        let parent = dir
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        return Ok((parent.to_path_buf(), name.to_string_lossy().into_owned()));
    }
    let abs = std::fs::canonicalize(dir).map_err(io_read(dir))?;
    match (abs.parent(), abs.file_name()) {
        (Some(p), Some(n)) => Ok((p.to_path_buf(), n.to_string_lossy().into_owned())),
        _ => Err(OutputError::NoFileName {
            path: dir.to_path_buf(),
        }),
    }
}

/// Whether `dir` is an existing directory (an error if it is something else).
fn is_dir(dir: &Path) -> Result<bool, OutputError> {
    match std::fs::metadata(dir) {
        Ok(m) if m.is_dir() => Ok(true),
        Ok(_) => Err(OutputError::NotADirectory {
            path: dir.to_path_buf(),
        }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
        Err(e) => {
            // ENOTDIR: a folder of the path is a file (`afile/sub`); say which.
            let file = dir
                .ancestors()
                .skip(1)
                .filter(|a| !a.as_os_str().is_empty())
                .find(|a| std::fs::metadata(a).is_ok_and(|m| !m.is_dir()));
            match file {
                Some(file) => Err(OutputError::ParentIsFile {
                    path: dir.to_path_buf(),
                    file: file.to_path_buf(),
                }),
                None => Err(io_read(dir)(e)),
            }
        }
    }
}

/// Refuses, before anything is computed or written, an output directory that a run could
/// not write into: one that is a file, or holds files named like outputs that no manifest
/// of an earlier run lists ([`OutputError::Foreign`]). Creates nothing.
pub fn check_output_dir(dir: &Path, opts: &SetOptions<'_>) -> Result<(), OutputError> {
    split_dir(dir)?;
    if !is_dir(dir)? {
        return Ok(());
    }
    let list = super::exporters();
    let previous = previous_set(dir, &list, opts.later)?;
    let bad = conflicts(dir, &list, &[], opts.later, &previous)?;
    if !bad.is_empty() {
        return Err(OutputError::Foreign {
            dir: dir.to_path_buf(),
            files: bad,
        });
    }
    Ok(())
}

fn staging_prefix(name: &str) -> String {
    format!(".{name}.portalfind-")
}

#[cfg(target_os = "linux")]
fn process_alive(pid: u32) -> bool {
    Path::new("/proc").join(pid.to_string()).exists()
}

#[cfg(not(target_os = "linux"))]
fn process_alive(_pid: u32) -> bool {
    true
}

/// Removes staging directories for `name` in `parent` left by processes that no longer run.
fn sweep(parent: &Path, name: &str) -> Vec<PathBuf> {
    let prefix = staging_prefix(name);
    let Ok(rd) = std::fs::read_dir(parent) else {
        return Vec::new();
    };
    let mut swept = Vec::new();
    for e in rd.flatten() {
        let n = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = n.strip_prefix(&prefix) else { continue };
        let Some((pid, seq)) = rest.split_once('-') else {
            continue;
        };
        let (Ok(pid), Ok(_)) = (pid.parse::<u32>(), seq.parse::<usize>()) else {
            continue;
        };
        if pid != std::process::id() && !process_alive(pid) && std::fs::remove_dir_all(e.path()).is_ok() {
            swept.push(e.path());
        }
    }
    swept
}

/// Creates `dir` and its missing parents; returns the ones it created, innermost first.
fn create_dirs(dir: &Path) -> Result<Vec<PathBuf>, OutputError> {
    let missing: Vec<PathBuf> = dir
        .ancestors()
        .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
        .map(Path::to_path_buf)
        .collect();
    std::fs::create_dir_all(dir).map_err(|source| OutputError::CreateDir {
        dir: dir.to_path_buf(),
        source,
    })?;
    Ok(missing)
}

fn remove_created(created: &[PathBuf]) {
    for d in created {
        // Innermost first; `remove_dir` removes only empty directories.
        let _ = std::fs::remove_dir(d);
    }
}

fn rename(from: &Path, to: &Path) -> Result<(), OutputError> {
    std::fs::rename(from, to).map_err(|source| OutputError::Rename {
        from: from.to_path_buf(),
        to: to.to_path_buf(),
        source,
    })
}

/// Test hook: `PF_FAULT_ABORT_AFTER_RENAMES=K` aborts the process (as a kill would) after
/// the K-th file renamed into an existing output directory.
fn fault_abort_after(renamed: usize) {
    if let Ok(k) = std::env::var("PF_FAULT_ABORT_AFTER_RENAMES")
        && k.parse() == Ok(renamed)
    {
        std::process::abort();
    }
}

/// Test hook: with `PF_FAULT_STALL_BEFORE_COMMIT` set, waits (up to a minute, or until
/// [`interrupt`]) once the set is staged, so a test can signal the process then.
fn fault_stall() -> Result<(), OutputError> {
    if std::env::var_os("PF_FAULT_STALL_BEFORE_COMMIT").is_some() {
        for _ in 0..3000 {
            interrupted()?;
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
    }
    Ok(())
}

fn manifest_bytes(m: &Manifest) -> Result<Vec<u8>, OutputError> {
    let mut v = serde_json::to_vec_pretty(m).map_err(|source| OutputError::Serialize {
        what: "the manifest",
        source,
    })?;
    v.push(b'\n');
    Ok(v)
}

/// Writes `bytes` as `staging/name`, then renames it to `dir/name`.
fn place(staging: &Path, dir: &Path, name: &str, bytes: &[u8]) -> Result<(), OutputError> {
    let tmp = staging.join(name);
    std::fs::write(&tmp, bytes).map_err(|source| OutputError::Write {
        file: name.to_string(),
        source: source.into(),
    })?;
    rename(&tmp, &dir.join(name))
}

/// As [`write_run_with`], with the registered [`super::exporters`].
pub fn write_run(
    dir: &Path,
    model: &Model,
    doc: &ResultDoc,
    dec: &Decimation,
    snapshots: &[(Snapshot, ResultDoc)],
    opts: &SetOptions<'_>,
) -> Result<Written, OutputError> {
    write_run_with(&super::exporters(), dir, model, doc, dec, snapshots, opts)
}

/// Writes the files of `list` for a run as one set into `dir` (created, with missing
/// parents, if it does not exist), replacing the previous run's set there as a whole; see
/// the module documentation. On an error the directory is as it was.
pub fn write_run_with(
    list: &[Box<dyn Exporter>],
    dir: &Path,
    model: &Model,
    doc: &ResultDoc,
    dec: &Decimation,
    snapshots: &[(Snapshot, ResultDoc)],
    opts: &SetOptions<'_>,
) -> Result<Written, OutputError> {
    let _guard = lock();
    interrupted()?;
    let (parent, name) = split_dir(dir)?;
    let exists = is_dir(dir)?;
    let staging = parent.join(format!(
        "{}{}-{}",
        staging_prefix(&name),
        std::process::id(),
        STAGING_SEQ.fetch_add(1, Ordering::SeqCst)
    ));
    let known = super::opt_in_formats();
    if let Some(bad) = opts.export.iter().find(|e| !known.contains(&e.as_str())) {
        return Err(OutputError::Write {
            file: format!("--export {bad}"),
            source: format!("unknown export format; use one of {}", known.join(", ")).into(),
        });
    }
    let hashed = Mutex::new(Vec::new());
    let ctx = ExportContext {
        hashed: &hashed,
        dir: &staging,
        model,
        doc,
        dec,
        snapshots,
        cx: opts.cx,
        export: opts.export,
        notes: opts.notes,
        strip_timings: opts.strip_timings,
    };
    let names: Vec<String> = list
        .iter()
        .filter(|x| chosen(x.as_ref(), opts.export))
        .flat_map(|x| x.files(&ctx))
        .collect();
    let previous = if exists {
        previous_set(dir, list, opts.later)?
    } else {
        Vec::new()
    };
    if exists {
        let bad = conflicts(dir, list, &names, opts.later, &previous)?;
        if !bad.is_empty() {
            return Err(OutputError::Foreign {
                dir: dir.to_path_buf(),
                files: bad,
            });
        }
    }
    let created = create_dirs(&parent)?;
    let swept = sweep(&parent, &name);
    if let Err(source) = std::fs::create_dir(&staging) {
        remove_created(&created);
        return Err(OutputError::CreateDir { dir: staging, source });
    }
    let abandon = |e: OutputError| {
        let _ = std::fs::remove_dir_all(&staging);
        remove_created(&created);
        e
    };
    let Staged { files, order, manifest } = stage(list, &ctx, opts).map_err(abandon)?;
    let mut written = Written {
        files: files.iter().map(|f| dir.join(f)).collect(),
        swept,
        ..Written::default()
    };
    if !exists {
        let r = manifest_bytes(&manifest).and_then(|b| {
            std::fs::write(staging.join(MANIFEST_FILE), b).map_err(|source| OutputError::Write {
                file: MANIFEST_FILE.into(),
                source: source.into(),
            })
        });
        r.map_err(abandon)?;
        match std::fs::rename(&staging, dir) {
            Ok(()) => return Ok(written),
            // Someone made the directory meanwhile: swap the files in one by one.
            Err(_) if dir.is_dir() => {
                let _ = std::fs::remove_file(staging.join(MANIFEST_FILE));
            }
            Err(source) => {
                return Err(abandon(OutputError::Rename {
                    from: staging.clone(),
                    to: dir.to_path_buf(),
                    source,
                }));
            }
        }
    }
    let previous = if exists {
        previous
    } else {
        previous_set(dir, list, opts.later).map_err(abandon)?
    };
    let r = swap_in(dir, &staging, &order, manifest, &previous);
    let _ = std::fs::remove_dir_all(&staging);
    let removed = r?;
    written.removed = removed;
    let mut set: Vec<&str> = files.iter().map(String::as_str).collect();
    set.push(MANIFEST_FILE);
    set.extend(opts.later);
    written.foreign = entries(dir)?
        .into_iter()
        .filter(|n| !set.contains(&n.as_str()))
        .collect();
    Ok(written)
}

/// The files of a staged set.
struct Staged {
    /// Names in the order of the exporters.
    files: Vec<String>,
    /// Names in the order they were written (`result.json` last), which is also the order
    /// they are renamed in.
    order: Vec<String>,
    /// The complete manifest.
    manifest: Manifest,
}

/// Runs the exporters into the staging directory `ctx.dir` (`result.json` last).
/// Whether an exporter runs: always, or when its opt-in format is named in `export`.
fn chosen(x: &dyn Exporter, export: &[String]) -> bool {
    x.opt_in().is_none_or(|k| export.iter().any(|e| e == k))
}

/// The manifest entry of a staged file (its name and hash: the one its exporter recorded
/// while writing it, else streamed back from the file).
fn hash_staged(ctx: &ExportContext<'_>, p: &Path) -> Result<(String, FileEntry), OutputError> {
    let name = p
        .file_name()
        .ok_or_else(|| OutputError::NoFileName { path: p.to_path_buf() })?
        .to_string_lossy()
        .into_owned();
    let recorded = ctx
        .hashed
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .iter()
        .find(|(q, e)| q == p && e.name == name)
        .map(|(_, e)| e.clone());
    let entry = match recorded {
        Some(e) => e,
        None => entry_of_file(&name, p, HashKind::Xxh3)?,
    };
    Ok((name, entry))
}

fn stage(list: &[Box<dyn Exporter>], ctx: &ExportContext<'_>, opts: &SetOptions<'_>) -> Result<Staged, OutputError> {
    use rayon::prelude::*;
    let mut order = Vec::new();
    let on = |i: &usize| chosen(list[*i].as_ref(), opts.export);
    // The exporters write distinct files into the staging directory and read the run
    // only, so all of them run in parallel (rayon), the `last` ones (result.json, the
    // largest) started first; the results are taken in the sequence order — the others in
    // the list's order, then the `last` ones — so file order, the first error in that
    // order and the swap order are those of one thread writing the `last` ones after the
    // others. (Staged files are invisible until the swap, and a failed stage is removed
    // whole, so result.json still exists only beside a complete set.)
    let first: Vec<usize> = (0..list.len()).filter(|&i| !list[i].last()).filter(on).collect();
    let last: Vec<usize> = (0..list.len()).filter(|&i| list[i].last()).filter(on).collect();
    let started: Vec<usize> = last.iter().chain(&first).copied().collect();
    // Each task hashes its own files right after writing them (one thread per file, as
    // before), so the largest file's hash no longer waits for the others.
    type Hashed = Vec<Result<(String, FileEntry), OutputError>>;
    type Done = Result<(Vec<PathBuf>, Hashed), OutputError>;
    let done: Vec<Done> = started
        .par_iter()
        .with_max_len(1)
        .map(|&i| {
            interrupted()?;
            let paths = list[i].write(ctx)?;
            let hashed = paths.iter().map(|p| hash_staged(ctx, p)).collect();
            Ok((paths, hashed))
        })
        .collect();
    let mut by_exporter: Vec<Option<Done>> = (0..list.len()).map(|_| None).collect();
    for (&i, r) in started.iter().zip(done) {
        by_exporter[i] = Some(r);
    }
    let mut hashes: Vec<Option<Hashed>> = (0..list.len()).map(|_| None).collect();
    // Write errors first, in the sequence order; then hash errors, in file order.
    for i in first.iter().chain(&last).copied() {
        let Some(r) = by_exporter[i].take() else { continue };
        let (paths, hashed) = r?;
        order.extend(
            paths
                .iter()
                .filter_map(|p| p.file_name())
                .map(|n| n.to_string_lossy().into_owned()),
        );
        hashes[i] = Some(hashed);
    }
    interrupted()?;
    let mut files = Vec::new();
    let mut entries = Vec::new();
    for r in hashes.into_iter().flatten().flatten() {
        let (name, entry) = r?;
        entries.push(entry);
        files.push(name);
    }
    fault_stall()?;
    interrupted()?;
    let manifest = Manifest {
        schema: MANIFEST_SCHEMA.into(),
        schema_version: MANIFEST_VERSION,
        generator: format!("portalfind {}", env!("CARGO_PKG_VERSION")),
        complete: true,
        files: entries,
        later: opts.later.iter().map(|s| s.to_string()).collect(),
        replacing: Vec::new(),
    };
    Ok(Staged { files, order, manifest })
}

/// Swaps the staged `files` (in this order) into the existing `dir`, replacing the `previous` set; moves
/// the previous set back on an error. Returns the previous files removed and not replaced.
fn swap_in(
    dir: &Path,
    staging: &Path,
    files: &[String],
    manifest: Manifest,
    previous: &[String],
) -> Result<Vec<String>, OutputError> {
    let aside = staging.join(".previous");
    std::fs::create_dir(&aside).map_err(|source| OutputError::CreateDir {
        dir: aside.clone(),
        source,
    })?;
    let mut moved_aside: Vec<&str> = Vec::new();
    let mut moved_in: Vec<&str> = Vec::new();
    let mut marked = false;
    let r = (|| {
        // 1. Mark the directory as being rewritten (readers refuse it from now on).
        if dir.join(MANIFEST_FILE).exists() {
            rename(&dir.join(MANIFEST_FILE), &aside.join(MANIFEST_FILE))?;
            moved_aside.push(MANIFEST_FILE);
        }
        let mut incomplete = manifest.clone();
        incomplete.complete = false;
        incomplete.replacing = previous.iter().filter(|n| *n != MANIFEST_FILE).cloned().collect();
        place(staging, dir, MANIFEST_FILE, &manifest_bytes(&incomplete)?)?;
        marked = true;
        // 2. Move the previous set aside.
        for n in previous.iter().filter(|n| *n != MANIFEST_FILE) {
            if std::fs::symlink_metadata(dir.join(n)).is_ok() {
                rename(&dir.join(n), &aside.join(n))?;
                moved_aside.push(n);
            }
        }
        // 3. Move the new files in.
        for (k, n) in files.iter().enumerate() {
            rename(&staging.join(n), &dir.join(n))?;
            moved_in.push(n);
            fault_abort_after(k + 1);
        }
        // 4. The complete manifest, last.
        place(staging, dir, MANIFEST_FILE, &manifest_bytes(&manifest)?)
    })();
    if let Err(e) = r {
        for n in &moved_in {
            let _ = std::fs::remove_file(dir.join(n));
        }
        if marked {
            let _ = std::fs::remove_file(dir.join(MANIFEST_FILE));
        }
        for n in &moved_aside {
            let _ = std::fs::rename(aside.join(n), dir.join(n));
        }
        return Err(e);
    }
    Ok(moved_aside
        .into_iter()
        .filter(|n| *n != MANIFEST_FILE && !files.iter().any(|f| f == n))
        .map(str::to_string)
        .collect())
}

/// Removes the previous run's set from `dir` (named by its manifest, or as in
/// [`write_run`] for output written before manifests), the manifest, and `dir` itself if
/// that leaves it empty; other files stay. Returns the names of the files removed (the
/// manifest not counted).
pub fn remove_run(dir: &Path, opts: &SetOptions<'_>) -> Result<Vec<String>, OutputError> {
    let _guard = lock();
    if !is_dir(dir)? {
        return Ok(Vec::new());
    }
    let list = super::exporters();
    let previous = previous_set(dir, &list, opts.later)?;
    let mut removed = Vec::new();
    // The manifest goes first, so a set half removed is never taken for a complete one.
    let mut order: Vec<&String> = previous.iter().filter(|n| *n == MANIFEST_FILE).collect();
    order.extend(previous.iter().filter(|n| *n != MANIFEST_FILE));
    for n in order {
        let p = dir.join(n);
        match std::fs::remove_file(&p) {
            Ok(()) if n != MANIFEST_FILE => removed.push(n.clone()),
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(source) => return Err(OutputError::Remove { path: p, source }),
        }
    }
    let _ = std::fs::remove_dir(dir);
    Ok(removed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streamed_entry_equals_the_entry_of_the_bytes() {
        let dir = std::env::temp_dir().join(format!("portalfind-entry-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // Longer than several read blocks, and not a multiple of one.
        let bytes: Vec<u8> = (0..200_003u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        for len in [0, 1, 65_536, bytes.len()] {
            let p = dir.join("f.bin");
            std::fs::write(&p, &bytes[..len]).unwrap();
            for kind in [HashKind::Xxh3, HashKind::Fnv1a] {
                let e = entry_of_file("f.bin", &p, kind).unwrap();
                assert_eq!(e, entry_of("f.bin", &bytes[..len], kind), "{len}");
                assert_eq!(e.kind(), kind);
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The entry hashed on the way out equals the entry of the bytes, whatever the split
    /// of the writes (a short-writing inner writer included).
    #[test]
    fn hashing_writer_entry_equals_the_entry_of_the_bytes() {
        use std::io::Write;
        struct Short(Vec<u8>);
        impl Write for Short {
            fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
                let k = b.len().min(7);
                self.0.extend_from_slice(&b[..k]);
                Ok(k)
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        let bytes: Vec<u8> = (0..100_003u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 11) as u8)
            .collect();
        for len in [0, 1, 4096, bytes.len()] {
            let mut w = HashingWriter::new(Short(Vec::new()));
            for chunk in bytes[..len].chunks(1000) {
                w.write_all(chunk).unwrap();
            }
            let (e, inner) = w.finish("f.bin");
            assert_eq!(inner.0, &bytes[..len]);
            assert_eq!(e, entry_of("f.bin", &bytes[..len], HashKind::Xxh3), "{len}");
        }
    }

    /// Reference values from the Python `xxhash` package (`xxh3_64_hexdigest`), which
    /// `xxhsum -H3` prints too.
    #[test]
    fn xxh3_entries_match_the_reference_values() {
        let long: Vec<u8> = (0..1280).map(|i| (i % 256) as u8).collect();
        for (bytes, hex) in [
            (&b""[..], "2d06800538d394c2"),
            (b"a", "e6c632b61e964e1f"),
            (b"foobar", "d78fda63144c5c84"),
            (&long, "4844b009e164352e"),
        ] {
            let e = entry_of("f", bytes, HashKind::Xxh3);
            assert_eq!(e.xxh3_64.as_deref(), Some(hex));
            assert_eq!(e.fnv1a64, None);
            // Split anywhere, the streamed hash is the same.
            let mut d = Digest::new(HashKind::Xxh3);
            for c in bytes.chunks(7) {
                d.update(c);
            }
            assert_eq!(d.entry("f", bytes.len() as u64), e);
        }
    }

    /// A version-1 manifest (FNV-1a hashes) is still read and its files verified; a file
    /// changed since is refused under either version, and an unknown version is refused.
    #[test]
    fn version_1_manifests_are_verified_with_their_own_hash() {
        let dir = std::env::temp_dir().join(format!("portalfind-v1-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("a.txt"), b"foobar").unwrap();
        let manifest = |version: u32, entry: FileEntry| Manifest {
            schema: MANIFEST_SCHEMA.into(),
            schema_version: version,
            generator: "test".into(),
            complete: true,
            files: vec![entry],
            later: Vec::new(),
            replacing: Vec::new(),
        };
        let v1 = manifest(1, entry_of("a.txt", b"foobar", HashKind::Fnv1a));
        let text = String::from_utf8(manifest_bytes(&v1).unwrap()).unwrap();
        assert!(text.contains("\"fnv1a64\": \"85944171f73967e8\""), "{text}");
        assert!(!text.contains("xxh3_64"), "{text}");
        std::fs::write(dir.join(MANIFEST_FILE), &text).unwrap();
        assert_eq!(check_run(&dir).unwrap().files, v1.files);
        verify_file(&dir, "a.txt", b"foobar").unwrap();
        assert!(verify_file(&dir, "a.txt", b"foobaz").is_err());
        let v2 = manifest(2, entry_of("a.txt", b"foobar", HashKind::Xxh3));
        std::fs::write(dir.join(MANIFEST_FILE), manifest_bytes(&v2).unwrap()).unwrap();
        assert_eq!(check_run(&dir).unwrap().files, v2.files);
        std::fs::write(dir.join("a.txt"), b"foobaz").unwrap();
        assert!(matches!(check_run(&dir), Err(OutputError::NotInManifest { .. })));
        let v3 = manifest(3, entry_of("a.txt", b"foobaz", HashKind::Xxh3));
        std::fs::write(dir.join(MANIFEST_FILE), manifest_bytes(&v3).unwrap()).unwrap();
        assert!(matches!(
            check_run(&dir),
            Err(OutputError::ManifestSchema { version: 3, .. })
        ));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn fnv1a64_matches_the_reference_values() {
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn output_directories_split_into_parent_and_name() {
        assert_eq!(split_dir(Path::new("out")).unwrap(), (PathBuf::from("."), "out".into()));
        assert_eq!(split_dir(Path::new("a/b/")).unwrap(), (PathBuf::from("a"), "b".into()));
        let (p, n) = split_dir(Path::new(".")).unwrap();
        assert_eq!(p.join(n), std::fs::canonicalize(".").unwrap());
    }
}
