//! The `portalfind` command line. Thin: parsing, progress and printing; the work is in the library.

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use portalfind::bench;
use portalfind::delaunay::Tetrahedralization;
use portalfind::pipeline::{self, CellSettings, Progress, Stage, Subdivision};
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
    /// Build the cell complex: split tetrahedra by model polygons, build the portal graph,
    /// remove the exterior. Prints the counts in the thesis's terms with stage timings.
    Complex {
        /// Model file (.obj or .mesh).
        model: PathBuf,
        /// Skip the invariant check (convex cells, coverage, volumes, no crossing).
        #[arg(long)]
        no_validate: bool,
        /// If the model leaks, write the first leak's path here, one `x y z` point per line
        /// (qbsp's pointfile format: load it in TrenchBroom to see where the model is open).
        /// With no leak, a stale pointfile there is removed. A file there that is not a
        /// pointfile is never overwritten or removed.
        #[arg(long)]
        pointfile: Option<PathBuf>,
        /// How cells are made: delaunay (the thesis's method: tetrahedra split by the
        /// model's polygons) or bsp (the thesis's baseline: a BSP tree whose planes are the
        /// model's polygons, chosen to split the fewest others).
        #[arg(long, default_value = "delaunay")]
        subdivision: Subdivision,
        /// For bsp: candidate planes evaluated per node (0: all; more is slower, not
        /// always better: the choice is greedy).
        #[arg(long, default_value_t = portalfind::bsp::DEFAULT_MAX_CANDIDATES)]
        bsp_candidates: usize,
        /// Seal openings narrower than SIZE where the model leaks (Umbra's "smallest
        /// hole"): in model units (0.25) or as a percentage of the bounding-box diagonal
        /// (1%); `auto` (the default) seals only cracks (openings narrower than the
        /// sliver width, lying on a wall); `off` seals no opening. The exterior flood fill
        /// treats them as closed; each sealed hole is printed (where, how wide) and, for
        /// run, listed in result.json. Leaks through wider openings are still reported.
        /// (The "sealing cracks" stage and the cells "split by sealing" in the statistics
        /// are another pass, part of building the complex, that runs with every SIZE: it
        /// splits cells a polygon's crossing too small to cut at the time would leave
        /// bridging a wall.) See the README's "Sealing leaky levels".
        #[arg(long, value_name = "SIZE", default_value = "auto", allow_negative_numbers = true)]
        seal_holes: SealArg,
    },
    /// Generate test models (OBJ or .mesh by the output's extension).
    Gen {
        #[command(subcommand)]
        what: GenCmd,
    },
    /// Benchmarks that print tables (performance goals live here, not in tests).
    Bench {
        #[command(subcommand)]
        what: BenchCmd,
    },
    /// Find cells and portals: build the cell complex, collapse neighbouring cells (lowest
    /// portal weight first) until the stop rule holds, and write result.json,
    /// weight_curve.csv, weight_curve.png and cells.svg into --out.
    Run {
        /// Model file (.obj or .mesh).
        model: PathBuf,
        /// Portal weight. aperture (the default; ours): clearance, plus rooms joined through
        /// an opening small against their cross-section kept apart. clearance (ours): rooms
        /// are the basins of the distance-to-walls field and doorways its passes; the weight
        /// is the ratio of the smaller room's clearance to the pass's, so it needs no scale
        /// and stops by itself. The thesis's: aspect (4.1.4), refined (4.3.2), volume (4.3.3).
        #[arg(long, default_value = "aperture")]
        heuristic: portalfind::decimate::HeuristicKind,
        /// Projected cell area for the thesis's heuristics: bbox (bounding rectangle), hull
        /// (2D convex hull) or union (exact union of the convex pieces). Not used by
        /// clearance.
        #[arg(long, default_value = "hull")]
        estimator: portalfind::decimate::Estimator,
        /// threshold:W (stop when the lowest weight is >= W), cells:N, or none (until no
        /// pair is left: one cell per connected region, but with aperture's gate the pairs
        /// it keeps apart stay apart; records the whole weight curve). Default: the heuristic's
        /// own stop — threshold:1.8 for clearance (a pass narrower than 1/1.8 of the
        /// smaller room separates it; chosen on the tune half of `bench accuracy`),
        /// threshold:3 for the thesis's (it suggests 3 to 4 for aspect; refined and volume
        /// weights depend on the model's scale).
        #[arg(long)]
        stop: Option<portalfind::decimate::StopRule>,
        /// Output directory (created, with missing parents, if it does not exist). The files
        /// are one set, swapped in whole with manifest.json last: a failed or interrupted
        /// run leaves it as it was; a rerun replaces the previous run's set; other files
        /// stay, and files named like outputs that no manifest lists make the run refuse.
        #[arg(long)]
        out: PathBuf,
        /// How cells are made: delaunay (the thesis's method: tetrahedra split by the
        /// model's polygons) or bsp (the thesis's baseline: a BSP tree whose planes are the
        /// model's polygons, chosen to split the fewest others).
        #[arg(long, default_value = "delaunay")]
        subdivision: Subdivision,
        /// For bsp: candidate planes evaluated per node (0: all; more is slower, not
        /// always better: the choice is greedy).
        #[arg(long, default_value_t = portalfind::bsp::DEFAULT_MAX_CANDIDATES)]
        bsp_candidates: usize,
        /// Seal openings narrower than SIZE where the model leaks (Umbra's "smallest
        /// hole"): in model units (0.25) or as a percentage of the bounding-box diagonal
        /// (1%); `auto` (the default) seals only cracks (openings narrower than the
        /// sliver width, lying on a wall); `off` seals no opening. The exterior flood fill
        /// treats them as closed; each sealed hole is printed (where, how wide) and, for
        /// run, listed in result.json. Leaks through wider openings are still reported.
        /// (The "sealing cracks" stage and the cells "split by sealing" in the statistics
        /// are another pass, part of building the complex, that runs with every SIZE: it
        /// splits cells a polygon's crossing too small to cut at the time would leave
        /// bridging a wall.) See the README's "Sealing leaky levels".
        #[arg(long, value_name = "SIZE", default_value = "auto", allow_negative_numbers = true)]
        seal_holes: SealArg,
        /// Also draw intermediate states: for each count N (comma-separated, e.g.
        /// 2000,500,200), the cells when N were left, rebuilt by replaying the recorded
        /// collapses, as OUT/cells_N.svg. Each N must lie between the active cell count
        /// and where the stop rule ended the run.
        #[arg(long, value_delimiter = ',')]
        snapshots: Vec<usize>,
        /// Also export (comma-separated): prt (Quake PRT1 portal file, cells.prt), obj
        /// (cells.obj + cells.mtl, one object per cell and portal, for Blender), gltf
        /// (cells.glb, named for Godot 3.5's rooms and portals), dot (portals.dot, Graphviz),
        /// html (viewer.html, a 3D viewer that replays the merges; open it in a browser).
        /// Default: none. See the README's "Exports".
        #[arg(long, value_delimiter = ',', value_parser = export_format)]
        export: Vec<String>,
        /// Also evaluate the partition's visibility, as `portalfind evaluate` does, and write
        /// its files into --out (see `portalfind evaluate --help`).
        #[arg(long)]
        evaluate: bool,
        #[command(flatten)]
        eval: EvalArgs,
        /// Also finish the decimation past the stop, for the weight curve: weight_curve.png
        /// and .svg then draw the whole run (the part after the stop lighter), as
        /// experiments do. Without it they draw the run to its stop (the collapses past it
        /// cost up to a sixth of a large run). Implied by --export html (the viewer replays
        /// the whole run).
        #[arg(long)]
        full_curve: bool,
    },
    /// Visibility of a run's cells: PVS, rendering cost, conservativeness, walkthroughs.
    ///
    /// Re-reads DIR (written by `portalfind run --out DIR` or by an experiment): loads the
    /// model named in DIR/result.json, rebuilds its cells and replays the collapses of
    /// DIR/weight_curve.csv (nothing is re-decided; the cell ids must match result.json).
    /// Then, and printed:
    ///
    /// - PVS: for each cell the cells some line through a portal sequence may reach
    ///   (Quake vis's portal flow with separating planes; conservative: a merged cell sees
    ///   all of its own portals). Sizes in cells (mean, max, volume-weighted).
    ///
    /// - Cost: each model polygon belongs to the cells it faces; a cell's cost is the
    ///   triangles (and area) of the polygons of its PVS. E_T = Σ vol·T(PVS) / Σ vol, the
    ///   expected triangles drawn from a random viewpoint; the area fraction (PVS area over
    ///   the model's, independent of tessellation); the culling ratio 1 − E_T / triangles.
    ///
    /// - Conservativeness by sampling: random points in each cell, random rays, first
    ///   polygon hit; a hit outside the PVS is a false invisible (must be 0). The
    ///   overestimation is PVS triangles / sampled-visible triangles per cell.
    ///
    /// - With --walkthrough: a camera tours every cell through portal centres; per frame the
    ///   triangles drawn by view-frustum culling, portal culling (exact frustum and screen
    ///   rectangles) and portal textures (portals deeper than k drawn as 2-triangle quads).
    ///
    /// Writes DIR/visibility.json, DIR/visibility_cells.csv and, with --walkthrough,
    /// DIR/walkthrough.csv, .png and .md (or into --out).
    ///
    /// Example: portalfind run models/thesis/four_room_optimized.obj --out out/fr &&
    /// portalfind evaluate out/fr --walkthrough
    Evaluate {
        /// Output directory of `portalfind run` (or of one experiment).
        dir: PathBuf,
        /// The model, when it is no longer at the path result.json records (relative to the
        /// directory the run was started in; a relative path is tried from the current folder,
        /// then from DIR and every folder above it).
        #[arg(long)]
        model: Option<PathBuf>,
        /// Write the files here instead of into DIR (created if missing).
        #[arg(long)]
        out: Option<PathBuf>,
        #[command(flatten)]
        eval: EvalArgs,
    },
    /// Re-export a finished `run` directory in other tools' formats: rebuilds the cells
    /// from the run's model, replays its recorded collapses, checks them against
    /// result.json and writes the set again with the formats added (see "Exports").
    Export {
        /// Output directory of `portalfind run`.
        dir: PathBuf,
        /// Formats (comma-separated): prt, obj, gltf, dot, html.
        #[arg(long, value_delimiter = ',', value_parser = export_format, required = true)]
        to: Vec<String>,
        /// The run's model, if it is no longer at the path recorded in result.json (a
        /// relative path is tried from the current folder, then from DIR and every folder
        /// above it).
        #[arg(long)]
        model: Option<PathBuf>,
    },
    /// Run experiment definitions (the thesis reproduction): every `*.json` of a directory,
    /// or one file. Each experiment writes OUT/NAME/ (result.json, evaluation.json, weight
    /// curve CSV/PNG, cells.svg); a directory run also writes OUT/summary.csv and
    /// OUT/README.md. The schema is in experiments/README.md. Exits non-zero if any failed.
    Experiment {
        /// A directory of definitions, or one definition file.
        path: PathBuf,
        /// Results directory [default: `results` beside the definitions directory].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Run only these experiments (comma-separated names); summary.csv and README.md
        /// are then left alone.
        #[arg(long, value_delimiter = ',', conflicts_with_all = ["shard", "merge"])]
        only: Vec<String>,
        /// Run shard I of N (e.g. 2/4): a deterministic subset of the directory's
        /// definitions (experiments joined by compare_to stay together; groups balanced by
        /// model polygon count). Writes the experiments' directories, OUT/shard-I-of-N.json
        /// and OUT/timings.shard-I-of-N.json, never summary.csv or README.md; shards may
        /// run at the same time (GNU parallel, a Slurm array). Then run --merge.
        #[arg(long, conflicts_with = "merge")]
        shard: Option<portalfind::experiment::Shard>,
        /// Write OUT/summary.csv and OUT/README.md from the shards' outputs (all N
        /// shard-I-of-N.json records, for the same definitions); runs no experiment.
        #[arg(long)]
        merge: bool,
        /// Evaluate every experiment's visibility (PVS, E_T, culling ratio, sampling check;
        /// as `run --evaluate` without the walkthrough): visibility.json per experiment and
        /// OUT/summary_visibility.csv. Without it, only definitions with "evaluate": true.
        #[arg(long)]
        evaluate: bool,
    },
    /// For each x,y,z row of POINTS (CSV), print the id of the final cell of a run (read
    /// from DIR/result.json) that contains the point, or -1.
    ///
    /// Output: one line per point, in input order: the cell id (the `id` of a cell in
    /// result.json), or -1 when the point lies in no cell (inside a wall, outside the
    /// model, or in a sliver gap). A point on a boundary shared by several cells gets the
    /// lowest of their ids. Bad rows are errors naming the file and line, and then nothing
    /// is printed.
    Locate {
        /// Output directory of `portalfind run` (or of one experiment).
        dir: PathBuf,
        /// CSV file of x,y,z rows; blank lines and lines starting with # are skipped, and
        /// a first row of names (such as x,y,z) is taken as a header.
        points: PathBuf,
    },
}

/// Options of the visibility evaluation (`evaluate`, `run --evaluate`).
#[derive(clap::Args)]
struct EvalArgs {
    /// Also run a walkthrough (implies --evaluate for `run`).
    #[arg(long)]
    walkthrough: bool,
    /// Skip the sampling check.
    #[arg(long)]
    no_sampling: bool,
    /// Sampling: random points per cell (at least 1).
    #[arg(long, default_value_t = 16, value_parser = at_least_one)]
    points_per_cell: usize,
    /// Sampling: random rays per point (at least 1).
    #[arg(long, default_value_t = 64, value_parser = at_least_one)]
    rays_per_point: usize,
    /// Sampling: seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// PVS work bound, flow steps per source portal; beyond it a branch marks everything
    /// it could still see (conservative, coarser).
    #[arg(long, default_value_t = portalfind::visibility::PvsSettings::default().max_steps_per_source)]
    pvs_budget: u64,
    /// PVS: let portal chains re-enter cells (the old, slow rule; for comparison only).
    #[arg(long)]
    pvs_revisit_cells: bool,
    /// PVS: do not clip the source by the separating planes (the old rule; for comparison).
    #[arg(long)]
    pvs_no_clip_source: bool,
    /// PVS: keep one-way pairs (no symmetric intersection; the old rule, for comparison).
    #[arg(long)]
    pvs_no_symmetric: bool,
    /// Walkthrough: horizontal field of view in degrees (the image is 4:3), above 0 and below 180.
    #[arg(long, default_value_t = 90.0, value_parser = field_of_view)]
    fov: f64,
    /// Walkthrough: the model's up axis (x, y or z).
    #[arg(long, default_value = "z", value_parser = ["x", "y", "z"])]
    up: String,
    /// Walkthrough: width in pixels of the per-pixel portal masks (the `mask` windows).
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=8192))]
    mask_width: u32,
}

impl EvalArgs {
    fn settings(&self) -> portalfind::evaluate::Settings {
        use portalfind::visibility::{PvsSettings, sample::SampleSettings, walk::WalkSettings};
        portalfind::evaluate::Settings {
            pvs: PvsSettings {
                max_steps_per_source: self.pvs_budget,
                revisit_cells: self.pvs_revisit_cells,
                clip_source: !self.pvs_no_clip_source,
                symmetric: !self.pvs_no_symmetric,
                ..Default::default()
            },
            sampling: (!self.no_sampling).then_some(SampleSettings {
                seed: self.seed,
                points_per_cell: self.points_per_cell,
                rays_per_point: self.rays_per_point,
            }),
            walkthrough: self.walkthrough.then(|| WalkSettings {
                fov_deg: self.fov,
                up_axis: ["x", "y", "z"].iter().position(|a| *a == self.up).unwrap_or(2),
                mask_width: self.mask_width as usize,
                ..Default::default()
            }),
        }
    }
}

#[derive(Subcommand)]
enum GenCmd {
    /// Reconstructions of the thesis's test models (section 4.3) with ground-truth rooms
    /// and doorways: writes DIR/NAME.obj and DIR/NAME.truth.json. NAME is one of
    /// four_room_optimized, four_room_tessellated, four_room_distorted, caverns,
    /// caverns_rotated, noisy, or all.
    Thesis {
        /// Model name, or `all`.
        name: String,
        /// Output directory.
        #[arg(long, default_value = "models/thesis")]
        out: PathBuf,
    },
    /// A building of nx × ny rooms (4 × 4 × 3 m, walls 0.5 m) joined by door corridors,
    /// every surface tessellated into quads; about 640 triangles per room at --tess 8.
    /// Scales to a million triangles for benchmarks.
    Rooms {
        /// Rooms along x.
        #[arg(long, default_value_t = 3)]
        nx: usize,
        /// Rooms along y.
        #[arg(long, default_value_t = 2)]
        ny: usize,
        /// Quads per 4 m of wall (rounded down to a multiple of 8, at least 8).
        #[arg(long, default_value_t = 8)]
        tess: usize,
        /// Output file (.obj or .mesh).
        #[arg(long)]
        out: PathBuf,
    },
}

#[derive(Subcommand)]
enum BenchCmd {
    /// Issue 12's run-time-versus-error table: on the thesis models, three generated suite
    /// models and e1m1, for each subdivision (Delaunay at the default stop and at cells:N,
    /// BSP, qbsp's leaves from e1m1.prt) and heuristic/estimator, the cells, portals, PVS,
    /// E_T, area fraction, culling ratio, PVS time, false invisibles and run time. Writes
    /// OUT/comparison.csv, comparison.md and comparison.png (time against E_T).
    Visibility {
        /// Only the models whose name contains one of these (comma-separated), e.g.
        /// four_room,e1m1.
        #[arg(long, value_delimiter = ',')]
        models: Vec<String>,
        /// Skip the sampling check.
        #[arg(long)]
        no_sampling: bool,
        /// Output directory.
        #[arg(long, default_value = "results/visibility")]
        out: PathBuf,
    },
    /// Issue 14's window representations along the walkthroughs: on the thesis models, the
    /// generated multi-storey building and e1m1 (default `run` partition), level and tilted
    /// cameras, per representation the mean and worst triangles rendered and windows
    /// passed, the triangles missed against the exact window (must be 0) and the culling
    /// time per frame (every frame culled --repeat times by each, interleaved). Writes
    /// OUT/walkthrough.csv, walkthrough.md and per walk frames_<model>_<camera>.csv/.png.
    Walkthrough {
        /// Only the models whose name contains one of these (comma-separated).
        #[arg(long, value_delimiter = ',')]
        models: Vec<String>,
        /// Timing repetitions per frame and representation.
        #[arg(long, default_value_t = 3)]
        repeat: usize,
        /// At most this many frames per walkthrough.
        #[arg(long, default_value_t = portalfind::visibility::walk::WalkSettings::default().max_frames)]
        max_frames: usize,
        /// Output directory.
        #[arg(long, default_value = "results/walkthrough")]
        out: PathBuf,
    },
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
        /// Runs per case (each in a fresh process); the table shows the fastest and the
        /// median. On a shared or virtual machine single runs vary by ±15%: use 3 or more
        /// before comparing against a reference.
        #[arg(long, default_value_t = 1)]
        repeat: usize,
    },
    /// Write the points of one benchmark case as raw little-endian f64 triples (x, y, z per
    /// point, no header), to run another tetrahedralizer on identical input (see
    /// bench/cgal/README.md for CGAL).
    Points {
        /// Input kind: uniform, grid, boxes or urot.
        kind: String,
        /// Number of points.
        n: usize,
        /// Output file.
        out: PathBuf,
    },
    /// The accuracy benchmark: every configuration on the ground-truth suite (generated
    /// buildings and caverns, and the thesis models, each with true rooms and doorways):
    /// rooms isolated, volumetric precision and recall (micro and macro), spike cells,
    /// doorways matched, final cells per room, run time. Writes cases.csv, summary.csv,
    /// accuracy.json and table.md into --out and prints the table. Tune settings on the
    /// tune half (even seeds) and report the other.
    Accuracy {
        /// Configurations, comma-separated, as heuristic[/estimator]@stop; the stop `rooms`
        /// is `cells:K` with K the true number of rooms (an oracle).
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "aspect/hull@rooms,refined/hull@rooms,volume/hull@rooms,aspect/hull@threshold:3,clearance@threshold:1.8,aperture@threshold:1.8"
        )]
        configs: Vec<portalfind::suite::bench::Config>,
        /// Which half of the suite: tune (even seeds), report (odd seeds), all (both), or
        /// holdout: the generated families at seeds 10 to 19, outside the suite, which no
        /// setting was tuned on (report these for models the tool was not shaped on).
        #[arg(long, default_value = "all")]
        half: String,
        /// Only these families (comma-separated; default all).
        #[arg(long, value_delimiter = ',')]
        families: Vec<String>,
        /// Output directory.
        #[arg(long, default_value = "results/accuracy")]
        out: PathBuf,
    },
    /// A stable, deterministic, time-bounded fuzzer (cargo-fuzz needs nightly): mutates the
    /// corpus of TARGET (obj, mesh: the readers; pipeline: small soups through the cell
    /// complex, its validation and the decimation), catches panics, buckets failures by
    /// message (known classes counted apart), shrinks the first find of each bucket and
    /// writes it to FINDS/TARGET/open/ (known classes to FINDS/TARGET/known/). Writes the figures
    /// to OUT/TARGET.json.
    Fuzz {
        /// obj, mesh or pipeline.
        #[arg(long)]
        target: portalfind::suite::fuzz::Target,
        /// Wall time to run.
        #[arg(long, default_value_t = 60.0)]
        seconds: f64,
        /// Seed (case i's input is a function of the seed and i).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Corpus directory (one subdirectory per target).
        #[arg(long, default_value = "tests/fuzz-corpus")]
        corpus: PathBuf,
        /// Where shrunk finds are written (one subdirectory per target).
        #[arg(long, default_value = "tests/data/fuzz")]
        finds: PathBuf,
        /// Where the report is written.
        #[arg(long, default_value = "results/fuzz")]
        out: PathBuf,
        /// Checks spent shrinking each bucket's first find.
        #[arg(long, default_value_t = 400)]
        shrink_budget: usize,
    },
    /// The stress table (issue 16): suite models (thesis, buildings, caverns) under
    /// rotations (7°/8°/9° and random), offsets (1e3-1e9), scales (1e-4, 1e6), vertex
    /// noise (1e-7-1e-2 of the diagonal), shuffles, centroid splits, duplicated and
    /// flipped-duplicate faces. Per variant: validation, leaks, regions, active cells,
    /// final portals (default decimation), rooms isolated and whether they are the unmoved
    /// model's. Writes stress.csv, stress.json and table.md into --out.
    Stress {
        /// 3 models × 9 variants instead of 10 × 21.
        #[arg(long)]
        quick: bool,
        /// Instead of the table's models, the generated families (tessellated, greedy,
        /// multi-storey buildings; caverns) at these seeds (e.g. `--seeds 2,3`: models the
        /// table never saw), without the thesis models. The suite's seeds are 0 to 9; 10 to
        /// 19 are the held-out seeds (`bench accuracy --half holdout`).
        #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u64).range(0..portalfind::suite::HOLDOUT_SEEDS.end))]
        seeds: Option<Vec<u64>>,
        /// Output directory.
        #[arg(long, default_value = "results/stress")]
        out: PathBuf,
    },
    /// Scale (issue 17): `gen rooms` buildings of about 10k to 1M triangles, each through
    /// `run` at defaults and `tetra --no-validate` in fresh processes; wall time, peak memory,
    /// run/tetra ratio, per-stage seconds, growth exponents. Writes scale.csv, scale.json,
    /// table.md and scale.svg (log-log) into --out.
    Scale {
        /// Skip sizes above this many triangles (974,080 is the largest).
        #[arg(long, default_value_t = 1_000_000)]
        max_triangles: usize,
        /// Skip sizes below this many triangles (9,856 is the smallest), e.g. 900000 for the
        /// 1M-triangle run alone.
        #[arg(long, default_value_t = 0)]
        min_triangles: usize,
        /// Rayon thread counts (comma-separated, e.g. 1,2): run each size once per count
        /// (and per --repeat) in fresh processes with RAYON_NUM_THREADS set, interleaved,
        /// and add a per-stage table of the counts side by side.
        #[arg(long, value_delimiter = ',')]
        threads: Vec<usize>,
        /// Runs per thread count, interleaved (with --threads; medians are reported).
        #[arg(long, default_value_t = 1)]
        repeat: usize,
        /// Output directory.
        #[arg(long, default_value = "results/scale")]
        out: PathBuf,
    },
    /// Bounded cost on degenerate input (issue 16): a round room whose floor and ceiling
    /// are each one convex n-gon, the same with star-shaped (non-convex) caps, a box
    /// with one face of n random vertex indices, a square room whose floor has n vertices
    /// along straight edges, and a room with a stack of n two-sided plates 1e-6 apart, at
    /// growing n, each through `complex
    /// --no-validate` in a fresh process: wall time, peak memory, load and splitting
    /// seconds, growth exponent per family. Writes degenerate.csv, degenerate.json and
    /// table.md into --out.
    Degenerate {
        /// Skip sizes above this n (100,000 is the largest).
        #[arg(long, default_value_t = 100_000)]
        max_n: usize,
        /// Output directory.
        #[arg(long, default_value = "results/degenerate")]
        out: PathBuf,
    },
    /// Run one case in this process and print it as JSON (what `bench delaunay` runs in a
    /// child process per case). With the environment variable PF_BENCH_STATS=1 it also
    /// prints the per-phase times and walk/cavity statistics to stderr.
    One {
        /// Input kind: uniform, grid, boxes or urot (rotated by 7°, 8°, 9° and offset by 1e6).
        kind: String,
        /// Number of points (grid: a k × k × k lattice with k³ close to it).
        n: usize,
    },
}

fn bench_accuracy(
    configs: &[portalfind::suite::bench::Config],
    half: &str,
    families: &[String],
    out: &std::path::Path,
) -> Result<()> {
    use portalfind::suite::{self, Half, bench};
    let want_half = match half {
        "tune" => Some(Half::Tune),
        "report" => Some(Half::Report),
        "holdout" => Some(Half::Holdout),
        "all" => None,
        other => bail!("unknown half {other:?}; use tune, report, holdout or all"),
    };
    let all = if want_half == Some(Half::Holdout) {
        suite::holdout()
    } else {
        suite::suite()
    };
    let cases: Vec<_> = all
        .into_iter()
        .filter(|c| want_half.is_none_or(|h| c.half == h))
        .filter(|c| families.is_empty() || families.iter().any(|f| *f == c.family.to_string()))
        .collect();
    if cases.is_empty() {
        bail!("no suite case matches --half {half} --families {}", families.join(","));
    }
    eprintln!("{} cases x {} configurations", cases.len(), configs.len());
    let bar = indicatif::ProgressBar::new(cases.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("accuracy {bar:40} {pos}/{len} cases [{elapsed}] {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let results = bench::run_cases(&cases, configs, &Default::default(), &mut |i, r| {
        bar.set_position(i as u64);
        bar.set_message(r.name.clone());
    })?;
    bar.finish_and_clear();
    bench::write_all(&results, out).with_context(|| format!("cannot write into {}", out.display()))?;
    println!("{}", bench::table(&results));
    println!("{}", suite::estimators::write_estimator_errors(&cases, out)?);
    println!(
        "wrote {}/{{cases.csv,summary.csv,accuracy.json,table.md,time_vs_error.png,time_vs_error.svg,estimators.csv,estimators.md}}",
        out.display()
    );
    Ok(())
}

fn bench_fuzz(
    target: portalfind::suite::fuzz::Target,
    seconds: f64,
    seed: u64,
    corpus_dir: &std::path::Path,
    finds: &std::path::Path,
    out: &std::path::Path,
    shrink_budget: usize,
) -> Result<()> {
    use portalfind::suite::fuzz;
    let corpus = fuzz::load_corpus(corpus_dir, target)
        .with_context(|| format!("cannot read the corpus {}/{target}", corpus_dir.display()))?;
    eprintln!("fuzz {target}: {} corpus files, {seconds} s, seed {seed}", corpus.len());
    let limits = fuzz::Limits::default();
    let r = fuzz::run(target, &corpus, seed, seconds, &limits, shrink_budget, &mut |n, f| {
        eprint!("\r{n} cases, {f} failures");
    });
    eprintln!();
    let mut written = Vec::new();
    for b in &r.buckets {
        // Finds that fail today: `open/` (new) or `known/`; a fixed one is moved up to
        // FINDS/TARGET/, where tests/fuzz_regressions.rs checks it on every run.
        let dir = finds
            .join(target.name())
            .join(if b.known.is_some() { "known" } else { "open" });
        let path = dir.join(fuzz::find_name(target, &b.bucket, &b.shrunk));
        if !path.exists() {
            std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
            portalfind::model::write::write_atomic(&path, &b.shrunk)
                .with_context(|| format!("cannot write {}", path.display()))?;
            written.push(path);
        }
    }
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let json = out.join(format!("{target}.json"));
    portalfind::model::write::write_atomic(&json, serde_json::to_string_pretty(&r)?.as_bytes())
        .with_context(|| format!("cannot write {}", json.display()))?;
    println!(
        "{target}: {:.0} s, {} cases ({:.0}/s): {} passed, {} refused (typed error), {} skipped, {} new failures, {} known",
        r.seconds, r.cases, r.cases_per_second, r.passed, r.refused, r.skipped, r.new_failures, r.known_failures
    );
    for b in &r.buckets {
        println!(
            "  {:>6}  {}{}",
            b.count,
            b.known.map(|k| format!("[known: {k}] ")).unwrap_or_default(),
            b.bucket
        );
    }
    for p in &written {
        println!("wrote {}", p.display());
    }
    println!("wrote {}", json.display());
    Ok(())
}

/// Errors are printed as their context chain (file, line, element, fix), without a
/// backtrace even when `RUST_BACKTRACE` is set, and exit with status 1.
/// Caps glibc's malloc arenas at two. The complex's stages allocate on rayon's
/// worker threads; with glibc's default (8 arenas per core) that memory stays in
/// the workers' arenas and the decimation's main-thread allocations cannot reuse
/// it. Measured on 13×12 rooms (95k triangles), two runs each in one go: peak
/// 452 → 418 MB, wall time unchanged (6.22/6.28 s default, 6.56/6.27 s capped).
/// An explicit `MALLOC_ARENA_MAX` in the environment wins.
fn cap_malloc_arenas() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    if std::env::var_os("MALLOC_ARENA_MAX").is_none() {
        // SAFETY: mallopt only sets an allocator parameter; called before any thread starts.
        unsafe {
            libc::mallopt(libc::M_ARENA_MAX, 2);
        }
    }
}

fn main() -> std::process::ExitCode {
    cap_malloc_arenas();
    // The pictures' font is compiled in; register it before anything draws.
    portalfind::output::plot::register_fonts();
    install_interrupt_handler();
    match run(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        // The interrupt handler exits with 130 too; this may finish first.
        Err(e)
            if e.chain().any(|c| {
                matches!(
                    c.downcast_ref::<portalfind::output::OutputError>(),
                    Some(portalfind::output::OutputError::Interrupted)
                )
            }) =>
        {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(130)
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// On Ctrl-C (SIGINT) or SIGTERM: stop output writing (a run's set that is not yet swapped
/// in is removed, with the directories its writing created), then exit with status 130.
/// Nothing else is on disk before outputs are written.
fn install_interrupt_handler() {
    let r = ctrlc::set_handler(|| {
        let _no_more_writes = portalfind::output::interrupt();
        eprintln!("interrupted: no output of this run was left half written");
        std::process::exit(130);
    });
    if let Err(e) = r {
        eprintln!("warning: cannot handle Ctrl-C ({e}); an interrupted run may leave a hidden staging directory");
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.cmd {
        Cmd::Info { model } => info(&model),
        Cmd::Tetra { model, no_validate } => tetra(&model, !no_validate),
        Cmd::Complex {
            model,
            no_validate,
            pointfile,
            subdivision,
            bsp_candidates,
            seal_holes,
        } => complex(
            &model,
            !no_validate,
            pointfile.as_deref(),
            cell_settings(subdivision, bsp_candidates, seal_holes.0),
        ),
        Cmd::Gen {
            what: GenCmd::Rooms { nx, ny, tess, out },
        } => gen_rooms(nx, ny, tess, &out),
        Cmd::Gen {
            what: GenCmd::Thesis { name, out },
        } => gen_thesis(&name, &out),
        Cmd::Bench { what } => match what {
            BenchCmd::Points { kind, n, out } => {
                let pts = bench::generate(&kind, n, bench::SEED)
                    .with_context(|| format!("unknown input kind {kind:?} (uniform, grid, boxes, urot)"))?;
                let bytes: Vec<u8> = pts.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
                std::fs::write(&out, bytes).with_context(|| format!("cannot write {}", out.display()))?;
                println!("wrote {} points to {}", pts.len(), out.display());
                Ok(())
            }
            BenchCmd::One { kind, n } => {
                let row = bench::run_one(&kind, n, true).with_context(|| format!("unknown input kind {kind:?}"))?;
                println!("{}", serde_json::to_string(&row)?);
                Ok(())
            }
            BenchCmd::Delaunay {
                sizes,
                kinds,
                json,
                repeat,
            } => bench_delaunay(&sizes, &kinds, json, repeat),
            BenchCmd::Accuracy {
                configs,
                half,
                families,
                out,
            } => bench_accuracy(&configs, &half, &families, &out),
            BenchCmd::Fuzz {
                target,
                seconds,
                seed,
                corpus,
                finds,
                out,
                shrink_budget,
            } => bench_fuzz(target, seconds, seed, &corpus, &finds, &out, shrink_budget),
            BenchCmd::Visibility {
                models,
                no_sampling,
                out,
            } => bench_visibility(&models, no_sampling, &out),
            BenchCmd::Walkthrough {
                models,
                repeat,
                max_frames,
                out,
            } => bench_walkthrough(&models, repeat, max_frames, &out),
            BenchCmd::Scale {
                max_triangles,
                min_triangles,
                threads,
                repeat,
                out,
            } => {
                let exe = std::env::current_exe()?;
                let work = std::env::temp_dir().join(format!("portalfind-scale-{}", std::process::id()));
                let opts = portalfind::suite::scale::ScaleOptions { threads, repeat };
                let rep =
                    portalfind::suite::scale::run_with(&exe, (min_triangles, max_triangles), &opts, &work, &mut |l| {
                        eprintln!("{l}")
                    })
                    .context("scale benchmark failed")?;
                let _ = std::fs::remove_dir_all(&work);
                portalfind::suite::scale::write_all(&rep, &out)
                    .with_context(|| format!("cannot write into {}", out.display()))?;
                println!("{}", portalfind::suite::scale::table(&rep));
                println!("wrote {}/{{scale.csv,scale.json,table.md,scale.svg}}", out.display());
                Ok(())
            }
            BenchCmd::Degenerate { max_n, out } => {
                use portalfind::suite::degenerate;
                let exe = std::env::current_exe()?;
                let work = std::env::temp_dir().join(format!("portalfind-degenerate-{}", std::process::id()));
                let rows = degenerate::run(&exe, max_n, &work, &mut |l| eprintln!("{l}"));
                let _ = std::fs::remove_dir_all(&work);
                let rows = rows.context("degenerate benchmark failed")?;
                degenerate::write_all(&rows, &out).with_context(|| format!("cannot write into {}", out.display()))?;
                println!("{}", degenerate::table(&rows));
                println!("wrote {}/{{degenerate.csv,degenerate.json,table.md}}", out.display());
                Ok(())
            }
            BenchCmd::Stress { quick, seeds, out } => {
                use portalfind::suite::stress;
                let models = match &seeds {
                    Some(s) => stress::generated_models(s),
                    None => stress::models(quick),
                };
                let rows = stress::run_models(&models, quick, &mut |what| eprintln!("{what}"));
                portalfind::suite::stress::write_all(&rows, &out)
                    .with_context(|| format!("cannot write into {}", out.display()))?;
                println!("{}", portalfind::suite::stress::table(&rows));
                println!("wrote {}/{{stress.csv,stress.json,table.md}}", out.display());
                Ok(())
            }
        },
        Cmd::Run {
            model,
            heuristic,
            estimator,
            stop,
            out,
            subdivision,
            bsp_candidates,
            seal_holes,
            snapshots,
            export,
            evaluate,
            eval,
            full_curve,
        } => with_output_dir(&out, || {
            run_decimation(
                &model,
                heuristic,
                estimator,
                stop.unwrap_or_else(|| heuristic.default_stop()),
                &out,
                cell_settings(subdivision, bsp_candidates, seal_holes.0),
                &snapshots,
                &export,
                (evaluate || eval.walkthrough).then(|| eval.settings()),
                full_curve || export.iter().any(|e| e == "html"),
            )
        }),
        Cmd::Evaluate { dir, model, out, eval } => {
            let model = run_model(&dir, model).with_context(|| format!("cannot evaluate {}", dir.display()))?;
            let o = portalfind::evaluate::evaluate_dir(&dir, Some(&model), &eval.settings())
                .with_context(|| format!("cannot evaluate {}", dir.display()))?;
            let out = out.unwrap_or(dir);
            std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
            print_evaluation(&o, &out)
        }
        Cmd::Locate { dir, points } => locate(&dir, &points),
        Cmd::Export { dir, to, model } => {
            let model = run_model(&dir, model)?;
            let w = pipeline::reexport(&dir, Some(&model), &to)?;
            for f in &w.files {
                println!("wrote {}", f.display());
            }
            Ok(())
        }
        Cmd::Experiment {
            path,
            out,
            only,
            shard,
            merge,
            evaluate,
        } => experiment(&path, out, &only, shard, merge, evaluate),
    }
}

/// The model of the run in `dir` for `evaluate` and `export`: `--model`, or the path its
/// result.json records ([`pipeline::run_model_path`]), with a note when that was found from
/// the run directory rather than from the current folder.
fn run_model(dir: &std::path::Path, model: Option<PathBuf>) -> Result<PathBuf> {
    if let Some(m) = model {
        return Ok(m);
    }
    let (path, from_dir) = pipeline::recorded_model_path(dir)?;
    if from_dir {
        eprintln!(
            "note: the run's model is not at its recorded path from the current folder; using {} \
             (found from {}; --model PATH overrides)",
            path.display(),
            dir.display()
        );
    }
    Ok(path)
}

/// `run --export`'s values: the opt-in formats of the exporter registry.
fn export_format(s: &str) -> Result<String, String> {
    let known = portalfind::output::opt_in_formats();
    if known.contains(&s) {
        Ok(s.to_string())
    } else {
        Err(format!("unknown export format {s:?}; use {}", known.join(", ")))
    }
}

/// A progress bar that stays hidden until its stage has run for a second.
struct LazyBar {
    bar: indicatif::ProgressBar,
    start: Instant,
    stage: &'static str,
    shown: bool,
}

impl LazyBar {
    fn new() -> Self {
        let bar = indicatif::ProgressBar::with_draw_target(None, indicatif::ProgressDrawTarget::hidden());
        bar.set_style(
            indicatif::ProgressStyle::with_template("{msg:>28} {bar:40} {pos}/{len} [{elapsed}]")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        LazyBar {
            bar,
            start: Instant::now(),
            stage: "",
            shown: false,
        }
    }

    fn update(&mut self, stage: &'static str, done: usize, total: usize) {
        if stage != self.stage {
            self.stage = stage;
            self.start = Instant::now();
            self.bar.set_message(stage);
        }
        if !self.shown && self.start.elapsed().as_secs_f64() > 1.0 {
            self.shown = true;
            self.bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
        }
        self.bar.set_length(total as u64);
        self.bar.set_position(done as u64);
    }
}

impl LazyBar {
    /// Clears the bar (the stage is over).
    fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

impl Drop for LazyBar {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}

/// `--seal-holes`: a [`pipeline::SealSize`] (`auto` included), or `off`.
#[derive(Clone, Copy, Debug)]
struct SealArg(Option<pipeline::SealSize>);

impl std::str::FromStr for SealArg {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, Self::Err> {
        if s.trim() == "off" {
            return Ok(SealArg(None));
        }
        s.parse()
            .map(|x| SealArg(Some(x)))
            .map_err(|e: pipeline::BadSealSize| format!("{e}, or off (no sealing at all)"))
    }
}

/// How `complex` and `run` make cells: the pipeline's settings with the CLI's choices.
fn cell_settings(
    subdivision: Subdivision,
    bsp_candidates: usize,
    seal_holes: Option<pipeline::SealSize>,
) -> CellSettings {
    CellSettings {
        subdivision,
        seal_holes,
        bsp: portalfind::bsp::BspSettings {
            max_candidates: bsp_candidates,
            variant: 0,
        },
        ..CellSettings::default()
    }
}

fn load(path: &std::path::Path) -> Result<portalfind::model::Model> {
    Ok(load_timed(path)?.0)
}

/// [`pipeline::load`], reported on stderr.
fn load_timed(path: &std::path::Path) -> Result<(portalfind::model::Model, f64)> {
    let (m, secs) = pipeline::load(path)?;
    eprintln!("loaded {} in {secs:.3} s", path.display());
    if let Some(t) = &m.report.translation {
        eprintln!("note: {t}");
    }
    Ok((m, secs))
}

fn info(path: &std::path::Path) -> Result<()> {
    let m = load(path)?;
    let (lo, hi) = m.bbox();
    let (lo, hi) = (m.to_user(lo), m.to_user(hi));
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
    let st = t.stats();
    println!(
        "build time   {build:.3} s (rank {:.3}, order {:.3}, insert {:.3}, compact {:.3}, canonical numbering {:.3}; {:.2} walk steps and {:.2} cavity tetrahedra per point, largest cavity {} vertices)",
        st.seconds[0],
        st.seconds[1],
        st.seconds[2],
        st.seconds[3],
        st.seconds[4],
        st.walk_steps as f64 / st.input_points as f64,
        st.cavity_tets as f64 / st.input_points as f64,
        st.largest_cavity_vertices
    );
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

fn complex(
    path: &std::path::Path,
    validate: bool,
    pointfile: Option<&std::path::Path>,
    how: CellSettings,
) -> Result<()> {
    let m = load(path)?;
    let mut bar = LazyBar::new();
    // The complex `run` would use: the first level of the fallback ladder that passes the
    // checks (or level 0's, which the validation below then reports).
    let pipeline::Attempts { cells, valid } = pipeline::build_cells_attempts(&m, path, &how, &mut |p: Progress| {
        bar.update(p.stage.name(), p.done, p.total)
    })?;
    drop(bar);
    if !valid {
        for r in &cells.rejected {
            let variant = match r.variant {
                0 => String::new(),
                v => format!(" (BSP tree variant {v})"),
            };
            eprintln!(
                "warning: the cell complex is invalid at tolerance level {}{variant}: {}",
                r.level, r.error
            );
        }
    }
    let pipeline::Cells {
        cx,
        stats,
        stages: pre,
        sealed,
        ..
    } = cells;
    let stats = stats.to_json();
    let s = &cx.stats;
    println!("{:<44}{:>10}", "stage", "seconds");
    for (name, secs) in &pre {
        println!("{name:<44}{secs:>10.3}");
    }
    for (name, secs) in &s.timings {
        println!("{name:<44}{secs:>10.3}");
    }
    println!();
    for why in &s.rejected_levels {
        eprintln!("warning: the cell complex was invalid at tolerance {why}");
    }
    let rows: [(&str, String); 18] = [
        ("model polygons", s.polygons.to_string()),
        ("tetrahedra", s.tetrahedra.to_string()),
        (
            "polygons skipped as already conforming",
            s.polygons_conforming.to_string(),
        ),
        ("polygons clipped against cells", s.polygons_clipped.to_string()),
        (
            "cells split",
            format!("{} ({} by sealing)", s.cells_split, s.cells_sealed),
        ),
        ("splits refused (sliver)", s.splits_refused.to_string()),
        ("fragments left unplaced", s.unplaced_fragments.to_string()),
        ("cells after splitting", s.cells_after_split.to_string()),
        (
            "exterior cells removed",
            format!(
                "{} in {} region{}",
                s.exterior_cells_removed,
                s.exterior_regions,
                if s.exterior_regions == 1 { "" } else { "s" }
            ),
        ),
        (
            "active cells",
            format!(
                "{} in {} region{}",
                s.active_cells,
                s.interior_regions,
                if s.interior_regions == 1 { "" } else { "s" }
            ),
        ),
        ("portal pairs", s.portal_pairs.to_string()),
        ("portal polygons", s.portal_polygons.to_string()),
        (
            "slivers discarded",
            format!("{} (total area {:.3e})", s.slivers_discarded, s.sliver_area),
        ),
        (
            "thin cells facing polygons removed",
            format!("{} (volume {:.3e})", s.thin_removed_cells, s.thin_removed_volume),
        ),
        ("leaks", s.leaks.to_string()),
        ("openings sealed", s.openings_sealed.to_string()),
        (
            "tolerance level (0: the model's own)",
            format!("{} (plane {:.0e})", s.tolerance_level, cx.tol.plane),
        ),
        ("hull volume", format!("{:.6e}", cx.hull_volume)),
    ];
    for (k, v) in rows {
        println!("{k:<44}{v:>10}");
    }
    if how.subdivision == Subdivision::Bsp
        && let Some(obj) = stats.as_object()
    {
        println!();
        for (k, v) in obj {
            if v.is_number() {
                println!("{:<44}{v:>10}", format!("bsp {}", k.replace('_', " ")));
            }
        }
    }
    for (i, l) in cx.leaks.iter().enumerate() {
        let (first, hull) = (m.to_user(l.first_portal_point), m.to_user(l.hull_point));
        println!(
            "leak {i}: region of {} cells; path of {} cells from cell {}; first portal at ({:.3}, {:.3}, {:.3}); leaves the hull at ({:.3}, {:.3}, {:.3})",
            l.region_cells,
            l.path.len(),
            l.from_cell,
            first[0],
            first[1],
            first[2],
            hull[0],
            hull[1],
            hull[2]
        );
    }
    if !cx.stats.faces_reversed
        && let Some(hint) = gap_hint(&cx, &m)
    {
        println!("{hint}");
    }
    print_sealed(&sealed, &m);
    if let Some(pf) = pointfile {
        let points = cx
            .leaks
            .first()
            .map(|l| cx.leak_pointfile(l).into_iter().map(|p| m.to_user(p)).collect());
        write_or_clear_pointfile(pf, points)?;
    }
    if cx.stats.faces_reversed {
        eprintln!("{}", reversed_warning(&cx));
    } else if cx.stats.active_cells == 0 {
        report_leaks_and_orientation(&cx, &m, None);
    }
    if cx.stats.active_cells > 0
        && let Some(w) = cx.thin_loss_warning()
    {
        eprintln!("{w}");
    }
    if validate {
        let t1 = Instant::now();
        eprintln!(
            "validating {} cells and their patches exactly (skip with --no-validate)...",
            cx.stats.active_cells
        );
        let spin = indicatif::ProgressBar::new_spinner();
        spin.set_message("validating the complex");
        spin.enable_steady_tick(std::time::Duration::from_millis(250));
        let r = cx.validate(&m);
        spin.finish_and_clear();
        match r {
            Ok(v) => println!(
                "validate ok in {:.3} s ({} cells, {} patches, volume error {:.1e})",
                t1.elapsed().as_secs_f64(),
                v.cells,
                v.patches,
                v.volume_rel_error
            ),
            Err(e) => bail!("complex validation failed: {e}"),
        }
    }
    Ok(())
}

fn gen_thesis(name: &str, out: &std::path::Path) -> Result<()> {
    use portalfind::generate::thesis as thesis_models;
    let models = if name == "all" {
        thesis_models::all()
    } else {
        vec![thesis_models::by_name(name).with_context(|| {
            format!(
                "unknown thesis model {name:?}; use one of {:?} or all",
                thesis_models::NAMES
            )
        })?]
    };
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    for m in &models {
        thesis_models::write(m, out).with_context(|| format!("cannot write {} into {}", m.name, out.display()))?;
        let tris: usize = m.soup.polygons.iter().map(|p| p.len() - 2).sum();
        println!(
            "wrote {}/{}.obj and .truth.json: {} vertices, {} triangles, {} rooms, {} doorways",
            out.display(),
            m.name,
            m.soup.vertices.len(),
            tris,
            m.truth.rooms.len(),
            m.truth.doorways.len()
        );
    }
    Ok(())
}

/// A count that must be at least 1 (a sampling check with 0 samples tests nothing).
fn at_least_one(s: &str) -> std::result::Result<usize, String> {
    match s.parse::<usize>() {
        Ok(0) => Err("must be at least 1 (0 would check nothing)".into()),
        Ok(n) => Ok(n),
        Err(e) => Err(format!("expected a whole number of at least 1: {e}")),
    }
}

/// A horizontal field of view in degrees: finite, above 0 and below 180 (a pinhole camera).
fn field_of_view(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(f) if f > 0.0 && f < 180.0 => Ok(f),
        Ok(f) => Err(format!(
            "{f} is not a field of view: give degrees above 0 and below 180, e.g. 90"
        )),
        Err(e) => Err(format!("expected degrees, e.g. 90: {e}")),
    }
}

fn gen_rooms(nx: usize, ny: usize, tess: usize, out: &std::path::Path) -> Result<()> {
    use portalfind::model::write;
    if nx == 0 || ny == 0 || nx.saturating_mul(ny) > 1_000_000 {
        bail!("--nx and --ny must be at least 1 and give at most a million rooms (got {nx} × {ny})");
    }
    let (s, centres) = portalfind::generate::scenes::room_grid(nx, ny, tess);
    let text = match out.extension().and_then(|e| e.to_str()) {
        Some("obj") => write::obj_text(
            &format!("portalfind gen rooms --nx {nx} --ny {ny} --tess {tess}\nroom centres: {centres:?}"),
            &s.vertices,
            &s.polygons,
        ),
        Some("mesh") => write::mesh_text(&s.vertices, &s.polygons),
        _ => bail!("output {} must end in .obj or .mesh", out.display()),
    };
    // Create a missing parent folder, as `gen thesis` and `run` do.
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create the folder {} for {}", dir.display(), out.display()))?;
    }
    write::write_atomic(out, text.as_bytes()).with_context(|| format!("cannot write {}", out.display()))?;
    let tris: usize = s.polygons.iter().map(|p| p.len() - 2).sum();
    println!(
        "wrote {}: {} rooms, {} polygons ({} triangles)",
        out.display(),
        nx * ny,
        s.polygons.len(),
        tris
    );
    Ok(())
}

fn bench_delaunay(sizes: &[usize], kinds: &[String], json: Option<PathBuf>, repeat: usize) -> Result<()> {
    let exe = std::env::current_exe().context("cannot find own executable")?;
    let mut rows = Vec::new();
    for &n in sizes {
        for kind in kinds {
            if !bench::KINDS.contains(&kind.as_str()) {
                bail!("unknown input kind {kind:?}; use one of {:?}", bench::KINDS);
            }
            eprint!("{kind} {n} ...");
            let mut best: Option<bench::Row> = None;
            let mut runs = Vec::new();
            for _ in 0..repeat.max(1) {
                let out = std::process::Command::new(&exe)
                    .args(["bench", "one", kind, &n.to_string()])
                    .output()
                    .context("cannot run benchmark child")?;
                if !out.status.success() {
                    bail!("benchmark {kind} {n} failed: {}", String::from_utf8_lossy(&out.stderr));
                }
                let row: bench::Row = serde_json::from_slice(&out.stdout).context("bad benchmark output")?;
                eprint!(" {:.3} s", row.seconds);
                runs.push(row.seconds);
                if best.as_ref().is_none_or(|b| row.seconds < b.seconds) {
                    best = Some(row);
                }
            }
            eprintln!();
            let mut row = best.expect("at least one run");
            row.runs = runs;
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

/// Runs `f`, which writes a run's outputs into `out` as one set
/// (`portalfind::output::write_run`: staged beside `out`, swapped in, `manifest.json` last;
/// on an error `out` is as it was and the directories the writing created are removed).
/// First refuses, before any work, an `out` the run could not write into (a file, or a
/// directory holding files named like outputs that no manifest of ours lists). Creates
/// nothing itself.
fn with_output_dir(out: &std::path::Path, f: impl FnOnce() -> Result<()>) -> Result<()> {
    portalfind::output::check_output_dir(out, &portalfind::output::SetOptions::default())?;
    f()
}

/// Whether `text` is a pointfile as `complex --pointfile` writes it: at least one line,
/// every line three finite numbers separated by spaces.
fn looks_like_pointfile(text: &str) -> bool {
    let mut lines = 0;
    for l in text.lines() {
        let xs: Vec<&str> = l.split(' ').collect();
        if xs.len() != 3 || !xs.iter().all(|x| x.parse::<f64>().is_ok_and(f64::is_finite)) {
            return false;
        }
        lines += 1;
    }
    lines > 0
}

/// Writes the leak path `points` to the pointfile `pf`, or with no leak removes a stale
/// pointfile there (as qbsp does). Either way a file at `pf` that is not a pointfile of
/// ours (such as the model itself) is never overwritten or removed: writing refuses, and
/// with no leak it is left alone with a note.
fn write_or_clear_pointfile(pf: &std::path::Path, points: Option<Vec<[f64; 3]>>) -> Result<()> {
    const MAX_POINTFILE_BYTES: u64 = 64 << 20;
    let ours = match std::fs::symlink_metadata(pf) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(e).with_context(|| format!("cannot inspect {}", pf.display())),
        Ok(md) => Some(
            md.is_file()
                && md.len() <= MAX_POINTFILE_BYTES
                && std::fs::read_to_string(pf).is_ok_and(|t| looks_like_pointfile(&t)),
        ),
    };
    match (points, ours) {
        (Some(_), Some(false)) => bail!(
            "{} exists and is not a pointfile (lines of `x y z`); refusing to overwrite it: \
             give --pointfile a new file name",
            pf.display()
        ),
        (Some(points), _) => {
            let text: String = points.iter().map(|p| format!("{} {} {}\n", p[0], p[1], p[2])).collect();
            portalfind::model::write::write_atomic(pf, text.as_bytes())
                .with_context(|| format!("cannot write {}", pf.display()))?;
            println!("wrote the leak path to {}", pf.display());
        }
        (None, Some(true)) => {
            std::fs::remove_file(pf).with_context(|| format!("cannot remove stale {}", pf.display()))?;
            println!("no leak: removed the stale pointfile {}", pf.display());
        }
        (None, Some(false)) => {
            println!("no leak: left {} alone (it is not a pointfile)", pf.display());
        }
        (None, None) => {}
    }
    Ok(())
}

/// The decimation's progress line. A bar paced by collapses, except for the `union`
/// estimator: its collapses get slower as the cells grow (on e1m1, 96% of them were done at
/// 15% of the time), so a bar would promise an end it cannot estimate; it shows a spinner
/// with the counts instead.
fn decimation_progress_template(estimator: portalfind::decimate::Estimator) -> &'static str {
    match estimator {
        portalfind::decimate::Estimator::Union => {
            "decimating {spinner} {pos} of at most {len} collapses, {msg} [{elapsed}]"
        }
        _ => "decimating {bar:40} {pos}/{len} collapses, {msg} [{elapsed}]",
    }
}

// One parameter per `run` option; a struct would only repeat the clap fields.
#[allow(clippy::too_many_arguments)]
fn run_decimation(
    path: &std::path::Path,
    heuristic: portalfind::decimate::HeuristicKind,
    estimator: portalfind::decimate::Estimator,
    stop: portalfind::decimate::StopRule,
    out: &std::path::Path,
    how: CellSettings,
    snapshot_counts: &[usize],
    export: &[String],
    evaluate: Option<portalfind::evaluate::Settings>,
    full_curve: bool,
) -> Result<()> {
    use portalfind::decimate::{QueueMode, Settings};
    let t0 = Instant::now();
    portalfind::output::check_snapshot_counts(snapshot_counts, &stop)?;
    let (m, load_secs) = load_timed(path)?;
    let load_peak = pipeline::peak_rss_mib();
    let settings = pipeline::Settings {
        cells: how,
        decimation: Settings {
            heuristic,
            estimator,
            stop,
            queue: QueueMode::Auto,
        },
    };
    let mut bar = LazyBar::new();
    let dec_bar = indicatif::ProgressBar::with_draw_target(None, indicatif::ProgressDrawTarget::hidden());
    dec_bar.set_style(
        indicatif::ProgressStyle::with_template(decimation_progress_template(estimator))
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let (mut t2, mut shown) = (None::<Instant>, false);
    // With `full_curve`, also the collapses of the run to the end, so the weight curve shows
    // the run past its stop.
    let run_pipeline = if full_curve {
        pipeline::run_model_with_curve
    } else {
        pipeline::run_model
    };
    let run = run_pipeline(
        &m,
        path,
        &settings,
        vec![("load model".into(), load_secs)],
        &mut |p: Progress| match p.stage {
            Stage::Decimate { cells } => {
                let t2 = *t2.get_or_insert_with(|| {
                    bar.finish();
                    Instant::now()
                });
                let steps = p.done;
                if !steps.is_multiple_of(256) {
                    return;
                }
                if !shown && t2.elapsed().as_secs_f64() > 1.0 {
                    shown = true;
                    dec_bar.set_length(p.total as u64);
                    dec_bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
                    if !decimation_progress_template(estimator).contains("{bar") {
                        dec_bar.enable_steady_tick(std::time::Duration::from_millis(120));
                    }
                }
                if shown {
                    dec_bar.set_position(steps as u64);
                    dec_bar.set_message(format!("{cells} cells"));
                }
            }
            _ => bar.update(p.stage.name(), p.done, p.total),
        },
    )?;
    dec_bar.finish_and_clear();
    drop(bar);
    let pipeline::Run {
        cx,
        dec,
        mut stages,
        doc,
        sealed,
        full_steps,
        mut memory,
        ..
    } = run;
    let t3 = Instant::now();
    // Snapshots are rebuilt before anything is written, so a count the run never passed
    // through fails without leaving files behind.
    let snapshots = snapshot_counts
        .iter()
        .map(|&n| portalfind::output::snapshot(&m, path, &cx, &dec, n))
        .collect::<Result<Vec<_>, _>>()?;
    let written = portalfind::output::write_run(
        out,
        &m,
        &doc,
        &dec,
        &snapshots,
        &portalfind::output::SetOptions {
            cx: Some(&cx),
            export,
            notes: portalfind::output::Notes {
                full_steps: full_steps.as_deref(),
                ..Default::default()
            },
            ..Default::default()
        },
    )?;
    let files = &written.files;
    stages.push(("write outputs".into(), t3.elapsed().as_secs_f64()));
    if let Some(m) = pipeline::peak_rss_mib() {
        memory.push(("write outputs".into(), m));
    }
    if let Some(m) = load_peak {
        memory.insert(0, ("load model".into(), m));
    }
    println!("{:<44}{:>10}", "stage", "seconds");
    for (name, secs) in &stages {
        println!("{name:<44}{secs:>10.3}");
    }
    println!("{:<44}{:>10.3}", "total", t0.elapsed().as_secs_f64());
    println!();
    if !memory.is_empty() {
        println!("{:<44}{:>10}", "peak memory after", "MiB");
        for (name, mib) in &memory {
            println!("{name:<44}{mib:>10.1}");
        }
        println!();
    }
    let s = &dec.stats;
    let rows: [(&str, String); 9] = [
        (
            "heuristic / estimator",
            if heuristic.heuristic().engine() == portalfind::decimate::HeuristicEngine::Clearance {
                format!("{heuristic} / -")
            } else {
                format!("{heuristic} / {estimator}")
            },
        ),
        ("active cells", s.initial_cells.to_string()),
        ("cell pairs", s.initial_pairs.to_string()),
        ("connected regions", s.regions.to_string()),
        ("collapses", s.steps.to_string()),
        ("final cells", doc.cells.len().to_string()),
        ("final portal pairs", doc.portals.len().to_string()),
        (
            "weights computed / re-weighs skipped",
            format!("{} / {}", s.weights_computed, s.reweighs_skipped),
        ),
        (
            "stop rule / reason",
            match dec.cells_target_warning() {
                Some(_) => format!("{stop} / already {} cells, nothing collapsed", s.initial_cells),
                None => format!("{stop} / {}", dec.stop),
            },
        ),
    ];
    for (k, v) in rows {
        println!("{k:<44}{v:>10}");
    }
    if !snapshots.is_empty() {
        println!();
        println!(
            "{:>10}{:>11}{:>13}{:>13}{:>14}{:>14}",
            "snapshot", "collapses", "last weight", "next weight", "portal pairs", "portal area"
        );
        let w = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.4}"));
        for (sn, _) in &snapshots {
            println!(
                "{:>10}{:>11}{:>13}{:>13}{:>14}{:>14.4e}",
                sn.cells,
                sn.collapses,
                w(sn.last_weight),
                w(sn.next_weight),
                sn.portal_pairs,
                sn.portal_area
            );
        }
    }
    for f in files {
        println!("wrote {}", f.display());
    }
    println!("wrote {}", out.join(portalfind::output::MANIFEST_FILE).display());
    if !written.removed.is_empty() {
        println!("removed the previous run's {}", written.removed.join(", "));
    }
    if !written.foreign.is_empty() {
        println!("left alone, not written by portalfind: {}", written.foreign.join(", "));
    }
    for d in &written.swept {
        println!("removed an interrupted run's staging directory {}", d.display());
    }
    print_sealed(&sealed, &m);
    if let Some(w) = dec.cells_target_warning() {
        eprintln!("warning: {w}");
    }
    report_leaks_and_orientation(&cx, &m, Some(&out.join(portalfind::output::LEAK_FILE)));
    if let Some(settings) = evaluate {
        println!();
        let rs = serde_json::to_value(&doc.settings).unwrap_or_default();
        let o = portalfind::evaluate::evaluate_partition(
            &m,
            &doc.model.path,
            rs,
            &cx,
            &dec.partition,
            &settings,
            Vec::new(),
        );
        print_evaluation(&o, out)?;
    }
    // The process ends after this: the complex (a polyhedron per cell), the decimation and
    // the model go back to the system with it, not piece by piece (seconds at a million
    // triangles, after the printed total).
    std::mem::forget((cx, dec, doc, m));
    Ok(())
}

/// Prints an evaluation's figures and writes its files into `dir`.
fn print_evaluation(o: &portalfind::evaluate::Output, dir: &std::path::Path) -> Result<()> {
    let e = &o.evaluation;
    let r = &e.report;
    println!("{:<44}{:>10}", "stage", "seconds");
    for s in &e.stages {
        println!("{:<44}{:>10.3}", s.stage, s.seconds);
    }
    println!();
    let mut rows = vec![
        (
            "cells / portals / portal pieces".to_string(),
            format!("{} / {} / {}", r.cells, r.portals, r.portal_pieces),
        ),
        (
            "PVS cells: mean / max".into(),
            format!("{:.1} / {}", r.pvs_mean_cells, r.pvs_max_cells),
        ),
        (
            "PVS cells, volume-weighted".into(),
            format!("{:.1}", r.expected_pvs_cells),
        ),
        (
            "PVS flow chains / sources truncated".into(),
            format!("{} / {}", r.pvs.chains, r.pvs.sources_truncated),
        ),
        (
            "triangles (in no cell)".into(),
            format!("{} ({})", r.total_triangles, r.triangles_in_no_cell),
        ),
        (
            "E_T (expected triangles drawn)".into(),
            format!("{:.1}", r.expected_triangles),
        ),
        ("PVS area fraction".into(), format!("{:.4}", r.area_fraction)),
        ("culling ratio".into(), format!("{:.4}", r.culling_ratio)),
    ];
    if let Some(s) = &r.sampling {
        rows.push(("sampling: rays (points)".into(), format!("{} ({})", s.rays, s.points)));
        rows.push((
            "sampling: false invisibles (rate)".into(),
            format!(
                "{} ({:.2e})",
                s.false_invisible,
                s.false_invisible as f64 / s.rays.max(1) as f64
            ),
        ));
        rows.push((
            "sampling: overestimation mean / median / max".into(),
            format!(
                "{:.2} / {:.2} / {:.2}",
                s.overestimation_mean, s.overestimation_median, s.overestimation_max
            ),
        ));
        rows.push((
            "sampling: E_T of the sampled visible sets".into(),
            format!("{:.1}", s.expected_sampled_triangles),
        ));
    }
    for (k, v) in rows {
        println!("{k:<44}{v:>24}");
    }
    if let Some(w) = &e.walkthrough {
        println!();
        print!("{}", portalfind::evaluate::walkthrough_table(w));
    }
    let title = std::path::Path::new(&e.model)
        .file_stem()
        .map_or_else(|| e.model.clone(), |s| s.to_string_lossy().into_owned());
    for f in portalfind::evaluate::write(dir, o, &title)? {
        println!("wrote {}", f.display());
    }
    if r.sampling.as_ref().is_some_and(|s| s.false_invisible > 0) {
        bail!("the PVS missed polygons the sampling saw (false invisibles); please report the model");
    }
    Ok(())
}

/// One line per hole sealed by `--seal-holes`.
fn print_sealed(sealed: &[portalfind::complex::SealedOpening], m: &portalfind::model::Model) {
    // Cracks are often far below 1e-4 model units: print those in scientific notation
    // rather than as "0.0000".
    let small = |v: f64| {
        if v != 0.0 && v.abs() < 1e-3 {
            format!("{v:.3e}")
        } else {
            format!("{v:.4}")
        }
    };
    for (i, o) in sealed.iter().enumerate() {
        let point = m.to_user(o.point);
        println!(
            "sealed opening {i}: width {} at ({:.3}, {:.3}, {:.3}); {} portal{}, area {}, cell {} kept, {} removed",
            small(o.width),
            point[0],
            point[1],
            point[2],
            o.portals,
            if o.portals == 1 { "" } else { "s" },
            small(o.area),
            o.inside,
            if o.outside == portalfind::complex::HULL {
                "the outside of the hull".to_string()
            } else {
                format!("cell {}", o.outside)
            }
        );
    }
}

/// With a leak: the input's open edges and the widest gap between them
/// ([`portalfind::model::gaps::widest_gap`]), the size of the cracks a leak can pass, and
/// the `--seal-holes` size that closed every crack leak of the stress table (four widest
/// gaps). `None` without a leak (the measure is only computed when it is needed).
fn gap_hint(cx: &portalfind::complex::CellComplex, m: &portalfind::model::Model) -> Option<String> {
    if cx.leaks.is_empty() {
        return None;
    }
    let open = m.report.open_edges;
    if open == 0 && m.report.t_junctions == 0 && m.report.non_manifold_edges == 0 {
        // A closed input: the crack is the complex's own (a polygon placed on a support
        // plane it shares with nearly coplanar neighbours leaves a sliver between it and a
        // neighbour on another support), which the crack-sealing pass of `--seal-holes
        // auto` closes by splitting the cells at it.
        return Some(
            "note: the input is closed (no open edge, no T-junction, no non-manifold edge), so \
             the leak passes through a crack of the cell complex itself, between nearly \
             coplanar polygons placed on shared support planes; `--seal-holes auto` (the \
             default) closes such cracks; if it leaks with auto, please report the model"
                .into(),
        );
    }
    if open == 0 {
        return Some(
            "note: the input has no open edge, so the leak passes between polygons that touch \
             without sharing edges (T-junctions or overlaps); see the README's \"Sealing leaky levels\""
                .into(),
        );
    }
    let gap = portalfind::model::gaps::widest_gap(m);
    let (lo, hi) = m.bbox();
    let diag = portalfind::base::vec::dist(&lo, &hi);
    Some(format!(
        "note: the input has {open} open edges; the widest gap between them is {gap:.4e} model units \
         ({:.2e} of the diagonal). Cracks that narrow are closed by `--seal-holes {:.4e}` (4 x the gap; \
         a wider hole needs a larger size or a fix in the model); see the README's \"Sealing leaky levels\"",
        gap / diag,
        4.0 * gap
    ))
}

/// Warnings a user must not miss: leaks, and a model whose every region was removed
/// (typically polygons facing away from free space, the opposite of our convention).
fn report_leaks_and_orientation(
    cx: &portalfind::complex::CellComplex,
    m: &portalfind::model::Model,
    leak_file: Option<&std::path::Path>,
) {
    if cx.stats.tolerance_level > 0 {
        for why in &cx.stats.rejected_levels {
            eprintln!("warning: the cell complex was invalid at tolerance {why}");
        }
        eprintln!(
            "warning: so the cell complex was built at fallback tolerance level {} (weld {:.0e}, plane {:.0e}, \
             coplanar {:.0e} of the diagonal instead of {:.0e}, {:.0e}, {:.0e}): vertices and planes that \
             close count as coincident; this is recorded in result.json (`complex.tolerance_level`)",
            cx.stats.tolerance_level,
            cx.tol.weld,
            cx.tol.plane,
            cx.tol.coplanar,
            m.tolerances.weld,
            m.tolerances.plane,
            m.tolerances.coplanar
        );
    }
    for (i, l) in cx.leaks.iter().enumerate() {
        let hull = m.to_user(l.hull_point);
        // `run` writes the first leak's path beside its results; `complex` on request.
        let path = match leak_file {
            Some(f) if i == 0 => format!("its path is in {} (load it in TrenchBroom)", f.display()),
            _ => "write its path with `portalfind complex MODEL --pointfile FILE` (load it in TrenchBroom)".into(),
        };
        eprintln!(
            "warning: leak {i}: the region of {} cells reaches the outside near ({:.3}, {:.3}, {:.3}); {path}",
            l.region_cells, hull[0], hull[1], hull[2]
        );
    }
    if cx.stats.faces_reversed {
        // The gap hint would send the user looking for holes that are not there.
        eprintln!("{}", reversed_warning(cx));
    } else {
        if let Some(hint) = gap_hint(cx, m) {
            eprintln!("{hint}");
        }
        if cx.stats.active_cells == 0 {
            eprintln!(
                "warning: no region faces any polygon, so every cell was removed as exterior; \
                 polygons must be counter-clockwise seen from free space (the room side) — \
                 if this model's faces point outwards, reverse their winding"
            );
        }
    }
    if let Some(w) = cx.thin_loss_warning() {
        eprintln!("{w}");
    }
}

/// The warning for [`portalfind::complex::ComplexStats::faces_reversed`]: the enclosed
/// regions face only back sides (removed), what is left faces fronts and leaks (or nothing
/// is left), and reversing every polygon would give enclosed regions without a leak.
fn reversed_warning(cx: &portalfind::complex::CellComplex) -> String {
    let what = if cx.stats.active_cells == 0 {
        "every cell was removed as exterior".to_string()
    } else {
        format!(
            "every region kept leaks ({} leak{}: the space around the model, facing the outer walls' fronts)",
            cx.stats.leaks,
            if cx.stats.leaks == 1 { "" } else { "s" }
        )
    };
    format!(
        "warning: the model's faces appear reversed: {what}, while with every polygon's winding \
         reversed the enclosed space would be kept with no leak. Polygons must be counter-clockwise \
         seen from free space (the room side); flip the winding (the face normals) in the modelling \
         tool or exporter (portalfind has no option to flip it), e.g. Blender's Mesh > Normals > Flip"
    )
}

fn locate(dir: &std::path::Path, points: &std::path::Path) -> Result<()> {
    let doc = portalfind::output::read_result(dir)?;
    let pts = portalfind::output::read_points(points)?;
    let loc = portalfind::output::Locator::new(&doc);
    let mut out = String::new();
    // The points are in the input's frame, the document in the model's.
    let to_model = doc.model.origin.map(|o| -o);
    for p in &pts {
        match loc.locate(&portalfind::model::translate_point(*p, to_model)) {
            Some(id) => out.push_str(&format!("{id}\n")),
            None => out.push_str("-1\n"),
        }
    }
    print!("{out}");
    Ok(())
}

fn bench_visibility(only: &[String], no_sampling: bool, out: &std::path::Path) -> Result<()> {
    use portalfind::suite::visibility as vb;
    let t0 = Instant::now();
    let ms = vb::models(std::path::Path::new("."), only).context("cannot load the models")?;
    if ms.is_empty() {
        bail!("--models: no model matches {only:?}");
    }
    let opts = vb::Options {
        sampling: if no_sampling {
            None
        } else {
            vb::Options::default().sampling
        },
        ..Default::default()
    };
    let mut rows = Vec::new();
    for m in &ms {
        eprintln!("{}: {} triangles", m.name, m.model.triangle_count());
        rows.extend(vb::run_model(m, &opts, &mut |r| {
            eprintln!(
                "  {} {} {} {}: {} cells, E_T {}, PVS {:.3} s, run {} s",
                r.subdivision,
                r.heuristic,
                r.estimator,
                r.stop,
                r.cells,
                r.expected_triangles.map_or("-".into(), |x| format!("{x:.1}")),
                r.pvs_seconds,
                r.run_seconds.map_or("-".into(), |x| format!("{x:.3}"))
            )
        })?);
    }
    let command = std::iter::once("portalfind".to_string())
        .chain(std::env::args().skip(1))
        .collect::<Vec<_>>()
        .join(" ");
    let preamble = format!(
        "Whole command: {:.1} s wall on this machine (shared, 2 cores); seconds below are wall-clock \
         in that one process and drift with the load.\n",
        t0.elapsed().as_secs_f64()
    );
    for f in vb::write(out, &rows, &command, &preamble)? {
        println!("wrote {}", f.display());
    }
    print!("{}", vb::table(&rows));
    Ok(())
}

fn bench_walkthrough(only: &[String], repeat: usize, max_frames: usize, out: &std::path::Path) -> Result<()> {
    use portalfind::suite::walkthrough as wb;
    use portalfind::visibility::walk::WalkSettings;
    let t0 = Instant::now();
    let ms = wb::models(std::path::Path::new("."), only).context("cannot load the models")?;
    if ms.is_empty() {
        bail!("--models: no model matches {only:?}");
    }
    let ws = WalkSettings {
        max_frames,
        ..WalkSettings::default()
    };
    let mut rows = Vec::new();
    for m in &ms {
        let t1 = Instant::now();
        eprintln!("{}: {} triangles", m.name, m.model.triangle_count());
        for w in wb::run_model(m, &ws, repeat)? {
            for f in wb::write_walk(out, &w)? {
                println!("wrote {}", f.display());
            }
            for r in &w.rows {
                eprintln!(
                    "  roll {} {}: {:.1} triangles (worst {}), {:.2} windows, {} frames missing, {:.1} CPU us/frame, {:.1} wall us/frame",
                    r.roll_deg,
                    r.window,
                    r.mean_triangles,
                    r.max_triangles,
                    r.mean_portals,
                    r.frames_missing,
                    r.cpu_us_per_frame_best.unwrap_or(f64::NAN),
                    r.us_per_frame_best
                );
            }
            rows.extend(w.rows);
        }
        eprintln!("  {:.1} s", t1.elapsed().as_secs_f64());
    }
    let command = std::iter::once("portalfind".to_string())
        .chain(std::env::args().skip(1))
        .collect::<Vec<_>>()
        .join(" ");
    let preamble = format!(
        "Whole command: {:.1} s wall on this machine (shared, 2 cores). Culling times are the culling \
         thread's CPU time (CLOCK_THREAD_CPUTIME_ID) and wall-clock time in that one process: every frame \
         culled by each representation back to back, rotating which goes first; `best` is the fastest \
         repetition's mean per frame, `median` the median repetition's. Compare representations within \
         one section, not across runs.\n",
        t0.elapsed().as_secs_f64()
    );
    for f in wb::write(out, &rows, &command, &preamble)? {
        println!("wrote {}", f.display());
    }
    print!("{}", wb::table(&rows));
    Ok(())
}

fn experiment(
    path: &std::path::Path,
    out: Option<PathBuf>,
    only: &[String],
    shard: Option<portalfind::experiment::Shard>,
    merge: bool,
    evaluate: bool,
) -> Result<()> {
    use portalfind::experiment::{self, RunOptions};
    let t0 = Instant::now();
    let is_dir = path.is_dir();
    if (shard.is_some() || merge) && !is_dir {
        bail!(
            "--shard and --merge need a directory of definitions, not {}",
            path.display()
        );
    }
    let files = if is_dir {
        experiment::definition_files(path)?
    } else {
        vec![path.to_path_buf()]
    };
    if files.is_empty() {
        bail!("no experiment definitions (*.json) in {}", path.display());
    }
    // Model paths are relative to the repository: the parent of the definitions directory.
    let defs_dir = if is_dir {
        path.to_path_buf()
    } else {
        path.parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(std::path::Path::new("."))
            .to_path_buf()
    };
    let abs = std::fs::canonicalize(&defs_dir).with_context(|| format!("cannot resolve {}", defs_dir.display()))?;
    let root = abs.parent().map_or_else(|| abs.clone(), |p| p.to_path_buf());
    let out = out.unwrap_or_else(|| root.join("results"));
    let mut defs = experiment::read_definitions(&files);
    if !only.is_empty() {
        // Unreadable definitions stay: their errors are reported.
        defs.retain(|d| d.as_ref().is_err() || d.as_ref().is_ok_and(|d| only.contains(&d.name)));
        let found: Vec<&String> = defs.iter().filter_map(|d| d.as_ref().ok()).map(|d| &d.name).collect();
        if let Some(missing) = only.iter().find(|n| !found.contains(n)) {
            bail!("--only: no experiment named {missing:?} in {}", path.display());
        }
    }
    // A shard records the equivalent unsharded command (the merged README shows it).
    let mut args = std::env::args().skip(1);
    let mut words = vec!["portalfind".to_string()];
    while let Some(a) = args.next() {
        if a == "--shard" {
            args.next();
        } else if !a.starts_with("--shard=") {
            words.push(a);
        }
    }
    let command = words.join(" ");
    let opts = RunOptions {
        root,
        out: out.clone(),
        write_summary: is_dir && only.is_empty() && shard.is_none(),
        command,
        shard,
        evaluate: evaluate.then(experiment::default_evaluate_settings),
    };
    let report = if merge {
        experiment::merge(defs, &opts).context("cannot merge the shards")?
    } else {
        experiment::run_all(defs, &opts, &mut |line| eprintln!("{line}"))
    };
    for f in &report.files {
        println!("wrote {}", f.display());
    }
    println!(
        "{} experiments {}, {} failed; results in {}; wall time {:.2} s",
        report.outcomes.len(),
        if merge { "merged" } else { "ran" },
        report.failures.len(),
        out.display(),
        t0.elapsed().as_secs_f64()
    );
    if !report.failures.is_empty() {
        let list: Vec<String> = report.failures.iter().map(|f| f.to_string()).collect();
        bail!("{} experiment(s) failed:\n  {}", list.len(), list.join("\n  "));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::decimation_progress_template;
    use portalfind::decimate::Estimator;

    /// The `union` estimator's collapses slow down as cells grow, so its progress shows no
    /// bar paced by collapses; the others keep theirs. Every template parses.
    #[test]
    fn union_progress_has_no_bar_paced_by_collapses() {
        for e in Estimator::ALL {
            let t = decimation_progress_template(e);
            assert!(indicatif::ProgressStyle::with_template(t).is_ok(), "{t}");
            assert_eq!(t.contains("{bar"), e != Estimator::Union, "{e}: {t}");
        }
    }
}
