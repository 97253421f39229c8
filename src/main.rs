//! The `portalfind` command line. Thin: parsing, progress and printing; the work is in the library.

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use portalfind::bench;
use portalfind::delaunay::Tetrahedralization;
use std::path::PathBuf;
use std::time::Instant;

/// Find cells and portals (rooms and the doors, windows and tunnel mouths between them) in
/// 3D polygon models, by Delaunay tetrahedralization and decimation (Gjørup 1999, ch. 4).
///
/// Input models are Wavefront OBJ (`.obj`) or the simple text format (`.mesh`, see the
/// README). The front side of a polygon, from which its vertices appear counter-clockwise,
/// faces free space.
#[derive(Parser)]
#[command(name = "portalfind", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Load a model and print its statistics and the cleaning report (welded vertices,
    /// dropped polygons, T-junctions, open edges).
    Info {
        /// Model file (.obj or .mesh).
        model: PathBuf,
    },
    /// Delaunay-tetrahedralize a model's vertices: counts, validation and time.
    Tetra {
        /// Model file (.obj or .mesh).
        model: PathBuf,
        /// Skip the (exact, O(n)) validation pass.
        #[arg(long)]
        no_validate: bool,
    },
    /// Benchmarks that print tables (performance goals live here, not in tests).
    Bench {
        #[command(subcommand)]
        what: BenchCmd,
    },
}

#[derive(Subcommand)]
enum BenchCmd {
    /// 3D Delaunay on uniform, grid, boxes and rotated+offset inputs; each case runs in its
    /// own process so peak memory is per case. Prints a Markdown table.
    Delaunay {
        /// Point counts to run.
        #[arg(long, value_delimiter = ',', default_value = "10000,100000,1000000")]
        sizes: Vec<usize>,
        /// Input kinds to run (uniform, grid, boxes, urot).
        #[arg(long, value_delimiter = ',', default_value = "uniform,grid,boxes,urot")]
        kinds: Vec<String>,
        /// Also write the rows as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Run one case in this process and print it as JSON (used by `bench delaunay`).
    #[command(hide = true)]
    One { kind: String, n: usize },
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.cmd {
        Cmd::Info { model } => info(&model),
        Cmd::Tetra { model, no_validate } => tetra(&model, !no_validate),
        Cmd::Bench { what } => match what {
            BenchCmd::One { kind, n } => {
                let row = bench::run_one(&kind, n, true).with_context(|| format!("unknown input kind {kind:?}"))?;
                println!("{}", serde_json::to_string(&row)?);
                Ok(())
            }
            BenchCmd::Delaunay { sizes, kinds, json } => bench_delaunay(&sizes, &kinds, json),
        },
    }
}

fn load(path: &std::path::Path) -> Result<portalfind::model::Model> {
    let t0 = Instant::now();
    let m = portalfind::model::load_model(path).with_context(|| format!("cannot load model {}", path.display()))?;
    eprintln!("loaded {} in {:.3} s", path.display(), t0.elapsed().as_secs_f64());
    Ok(m)
}

fn info(path: &std::path::Path) -> Result<()> {
    let m = load(path)?;
    let (lo, hi) = m.bbox();
    println!("model        {}", m.name);
    println!("vertices     {}", m.vertices.len());
    println!("polygons     {}", m.polygons.len());
    println!("triangles    {}", m.triangle_count());
    println!(
        "bbox         [{:.4}, {:.4}, {:.4}] .. [{:.4}, {:.4}, {:.4}]",
        lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]
    );
    println!(
        "weld dist    {:.3e} (relative {:.0e} of the bbox diagonal {:.4})",
        m.tolerances.weld_abs(),
        m.tolerances.weld,
        m.tolerances.scale
    );
    println!("\ncleaning report\n{}", m.report);
    Ok(())
}

fn tetra(path: &std::path::Path, validate: bool) -> Result<()> {
    let m = load(path)?;
    let t0 = Instant::now();
    let t =
        Tetrahedralization::build(&m.vertices).with_context(|| format!("cannot tetrahedralize {}", path.display()))?;
    let build = t0.elapsed().as_secs_f64();
    println!("vertices     {}", t.num_vertices());
    println!("tetrahedra   {}", t.num_tets());
    println!("hull faces   {}", t.num_hull_faces());
    println!("build time   {build:.3} s");
    if validate {
        let t1 = Instant::now();
        let r = t.validate();
        let vt = t1.elapsed().as_secs_f64();
        match r {
            Ok(r) => println!(
                "validate     ok in {vt:.3} s (V {} E {} F {} T {}; {} cospherical interior faces, {} coplanar hull edges)",
                r.vertices, r.edges, r.faces, r.tets, r.cospherical_faces, r.coplanar_hull_edges
            ),
            Err(e) => bail!("validation failed: {e}"),
        }
    }
    Ok(())
}

fn bench_delaunay(sizes: &[usize], kinds: &[String], json: Option<PathBuf>) -> Result<()> {
    let exe = std::env::current_exe().context("cannot find own executable")?;
    let mut rows = Vec::new();
    for &n in sizes {
        for kind in kinds {
            if !bench::KINDS.contains(&kind.as_str()) {
                bail!("unknown input kind {kind:?}; use one of {:?}", bench::KINDS);
            }
            eprint!("{kind} {n} ... ");
            let out = std::process::Command::new(&exe)
                .args(["bench", "one", kind, &n.to_string()])
                .output()
                .context("cannot run benchmark child")?;
            if !out.status.success() {
                bail!("benchmark {kind} {n} failed: {}", String::from_utf8_lossy(&out.stderr));
            }
            let row: bench::Row = serde_json::from_slice(&out.stdout).context("bad benchmark output")?;
            eprintln!("{:.3} s", row.seconds);
            rows.push(row);
        }
    }
    print!("{}", bench::table(&rows));
    if let Some(p) = json {
        std::fs::write(&p, serde_json::to_string_pretty(&rows)?)
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    Ok(())
}
