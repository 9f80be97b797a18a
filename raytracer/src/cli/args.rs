//! Command-line arguments. Radiance spells its options with one dash and
//! several letters (`-ds 0.2`, `-av 1 1 1`, `-vp 0 0 1`), which clap
//! cannot express; [`translate`] rewrites them into long options first.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use crate::render::RADIANCE_OPTIONS;

#[derive(Debug, Parser)]
#[command(
    name = "hybrid-rt",
    version,
    about = "A Radiance-style ray tracer, sequential reference of a hybrid-scheduled parallel renderer",
    after_help = "Radiance options may be written Radiance's way: -ds 0.2 -dj 0.5 -dt 0.05 -dc 0.5 -lr 8 -lw 0.002 -av 0.1 0.1 0.1 -ab 1 -aa 0.1 -ar 256 -ad 512 -as 128 -ps 1, and view options -vf FILE -vtv -vp X Y Z -vd X Y Z -vu X Y Z -vh A -vv A.\nLogging: set RUST_LOG (e.g. RUST_LOG=info)."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a scene to a PNG or Radiance HDR picture.
    Render(Box<RenderArgs>),
    /// Measure primary and shadow ray throughput on a scene.
    Bench(Box<BenchArgs>),
    /// What accuracy costs: render a converged reference, sweep the quality knobs, report error against time (CSV, markdown, SVG with the Pareto front).
    Sweep(Box<SweepArgs>),
    /// Reproduce the paper's tables and figures on a simulated cluster (SVG, markdown, JSON).
    Experiment(Box<ExperimentArgs>),
}

/// Radiance rendering options (long forms of `-ds`, `-dj`, ...).
#[derive(Debug, Args, Default)]
pub struct RadianceArgs {
    /// Quality preset chosen from the sweep's Pareto front: draft, normal or high (Radiance options given as well override it).
    #[arg(long, value_name = "PRESET")]
    pub quality: Option<String>,
    /// -ds: source subdivision ratio [default: 0.2]
    #[arg(long = "ds", value_name = "RATIO", allow_hyphen_values = true)]
    pub ds: Option<String>,
    /// -dj: source jitter 0..1 [default: 0]
    #[arg(long = "dj", value_name = "FRAC", allow_hyphen_values = true)]
    pub dj: Option<String>,
    /// -dt: direct threshold of adaptive shadow testing [default: 0.05]
    #[arg(long = "dt", value_name = "FRAC", allow_hyphen_values = true)]
    pub dt: Option<String>,
    /// -dc: direct certainty 0..1 [default: 0.5]
    #[arg(long = "dc", value_name = "FRAC", allow_hyphen_values = true)]
    pub dc: Option<String>,
    /// -dr: source relays through mirrors and prisms (virtual light sources) [default: 1]
    #[arg(long = "dr", value_name = "N", allow_hyphen_values = true)]
    pub dr: Option<String>,
    /// -lr: reflection depth limit [default: 7]
    #[arg(long = "lr", value_name = "N", allow_hyphen_values = true)]
    pub lr: Option<String>,
    /// -lw: ray weight limit [default: 0.002]
    #[arg(long = "lw", value_name = "W", allow_hyphen_values = true)]
    pub lw: Option<String>,
    /// -av: constant ambient radiance [default: 0 0 0]
    #[arg(long = "av", num_args = 3, value_names = ["R", "G", "B"], allow_hyphen_values = true)]
    pub av: Option<Vec<String>>,
    /// -ab: ambient bounces (diffuse inter-reflection) [default: 0]
    #[arg(long = "ab", value_name = "N", allow_hyphen_values = true)]
    pub ab: Option<String>,
    /// -aa: ambient accuracy, 0 = no irradiance cache [default: 0.1]
    #[arg(long = "aa", value_name = "FRAC", allow_hyphen_values = true)]
    pub aa: Option<String>,
    /// -ar: ambient resolution [default: 256]
    #[arg(long = "ar", value_name = "N", allow_hyphen_values = true)]
    pub ar: Option<String>,
    /// -ad: ambient divisions (hemisphere rays) [default: 512]
    #[arg(long = "ad", value_name = "N", allow_hyphen_values = true)]
    pub ad: Option<String>,
    /// -as: ambient super-samples [default: 128]
    #[arg(long = "as", value_name = "N", allow_hyphen_values = true)]
    pub as_: Option<String>,
    /// -st: specular sampling threshold [default: 0.15]
    #[arg(long = "st", value_name = "FRAC", allow_hyphen_values = true)]
    pub st: Option<String>,
    /// -ss: specular sampling jitter [default: 1]
    #[arg(long = "ss", value_name = "FRAC", allow_hyphen_values = true)]
    pub ss: Option<String>,
    /// -ps: pixel sample spacing: trace every N-th pixel, refine where neighbours differ by more than -pt [default: 1]
    #[arg(long = "ps", value_name = "N", allow_hyphen_values = true)]
    pub ps: Option<String>,
    /// -pt: pixel sampling threshold (relative difference) [default: 0.05]
    #[arg(long = "pt", value_name = "FRAC", allow_hyphen_values = true)]
    pub pt: Option<String>,
    /// -pj: pixel jitter 0..1 [default: 0]
    #[arg(long = "pj", value_name = "FRAC", allow_hyphen_values = true)]
    pub pj: Option<String>,
    /// -pn: primary rays per pixel, averaged (not an rpict option) [default: 1]
    #[arg(long = "pn", value_name = "N", allow_hyphen_values = true)]
    pub pn: Option<String>,
    /// -bv+ / -bv-: back faces visible, or rays pass through them [default: +]
    #[arg(long = "bv", value_name = "+|-", value_parser = ["+", "-"])]
    pub bv: Option<String>,
    /// -me: global medium extinction per unit length [default: 0 0 0]
    #[arg(long = "me", num_args = 3, value_names = ["R", "G", "B"], allow_hyphen_values = true)]
    pub me: Option<Vec<String>>,
    /// -ma: global medium scattering albedo [default: 0 0 0]
    #[arg(long = "ma", num_args = 3, value_names = ["R", "G", "B"], allow_hyphen_values = true)]
    pub ma: Option<Vec<String>>,
    /// -mg: global medium scattering eccentricity [default: 0]
    #[arg(long = "mg", value_name = "G", allow_hyphen_values = true)]
    pub mg: Option<String>,
    /// -ms: medium in-scattering sample spacing [default: 0]
    #[arg(long = "ms", value_name = "DIST", allow_hyphen_values = true)]
    pub ms: Option<String>,
}

impl RadianceArgs {
    /// (name, values) pairs of the options given, in table order.
    pub fn given(&self) -> Vec<(&'static str, Vec<&str>)> {
        fn one(o: &Option<String>) -> Option<Vec<&str>> {
            o.as_deref().map(|s| vec![s])
        }
        fn three(o: &Option<Vec<String>>) -> Option<Vec<&str>> {
            o.as_ref().map(|a| a.iter().map(String::as_str).collect())
        }
        let mut v = Vec::new();
        for (name, vals) in [
            ("ds", one(&self.ds)),
            ("dj", one(&self.dj)),
            ("dt", one(&self.dt)),
            ("dc", one(&self.dc)),
            ("dr", one(&self.dr)),
            ("lr", one(&self.lr)),
            ("lw", one(&self.lw)),
            (
                "av",
                self.av
                    .as_ref()
                    .map(|a| a.iter().map(String::as_str).collect()),
            ),
            ("ab", one(&self.ab)),
            ("aa", one(&self.aa)),
            ("ar", one(&self.ar)),
            ("ad", one(&self.ad)),
            ("as", one(&self.as_)),
            ("st", one(&self.st)),
            ("ss", one(&self.ss)),
            ("ps", one(&self.ps)),
            ("pt", one(&self.pt)),
            ("pj", one(&self.pj)),
            ("pn", one(&self.pn)),
            (
                match self.bv.as_deref() {
                    Some("-") => "bv-",
                    _ => "bv+",
                },
                self.bv.as_ref().map(|_| Vec::new()),
            ),
            ("me", three(&self.me)),
            ("ma", three(&self.ma)),
            ("mg", one(&self.mg)),
            ("ms", one(&self.ms)),
        ] {
            if let Some(vals) = vals {
                v.push((name, vals));
            }
        }
        v
    }
}

#[derive(Debug, Args)]
pub struct RenderArgs {
    /// Scene files (.rad or .obj), read in order into one scene.
    #[arg(required = true, value_name = "SCENE")]
    pub scenes: Vec<PathBuf>,
    /// Radiance view file (also -vf).
    #[arg(long = "view-file", value_name = "FILE")]
    pub view_file: Option<PathBuf>,
    /// Radiance view options, e.g. "-vtv -vp 0 0 1 -vd 0 1 0 -vh 60 -vv 45" (applied after --view-file; may repeat).
    #[arg(long = "view", value_name = "OPTIONS", allow_hyphen_values = true)]
    pub view: Vec<String>,
    /// View options given Radiance's way on the command line (collected by the translator).
    #[arg(long = "view-words", hide = true, allow_hyphen_values = true)]
    pub view_words: Vec<String>,
    /// Maximum image width; reduced to keep pixels square (rpict -x).
    #[arg(long, default_value_t = 512, value_name = "W")]
    pub width: u32,
    /// Maximum image height; reduced to keep pixels square (rpict -y).
    #[arg(long, default_value_t = 512, value_name = "H")]
    pub height: u32,
    /// Output picture: .png (tone mapped) or .hdr (Radiance RGBE).
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: PathBuf,
    /// Write render statistics as JSON to this file.
    #[arg(long, value_name = "FILE")]
    pub stats: Option<PathBuf>,
    /// Exposure: a multiplier (2.5) or stops with a sign (+1, -2) like pfilt -e. Default: automatic (mean brightness to 0.5).
    #[arg(long, value_name = "E", allow_hyphen_values = true)]
    pub exposure: Option<String>,
    /// Display gamma for PNG instead of the sRGB curve.
    #[arg(long, value_name = "G")]
    pub gamma: Option<f64>,
    /// Seed of the random streams.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    #[command(flatten)]
    pub radiance: RadianceArgs,
    #[command(flatten)]
    pub parallel: ParallelArgs,
}

/// The hybrid-scheduled parallel renderer (used when `--procs` is given).
#[derive(Debug, Args, Default)]
pub struct ParallelArgs {
    /// Render in parallel on N processors (hybrid scheduling); without it, the sequential renderer runs.
    #[arg(long, value_name = "N", help_heading = "Parallel rendering")]
    pub procs: Option<usize>,
    /// Runtime driving the processors: threads, sequential (the framework's one-processor reference), sim (a simulated cluster, see --network) or mpi (one processor per rank of `mpirun -np N`; needs a build with --features mpi).
    #[arg(
        long,
        default_value = "threads",
        value_name = "RUNTIME",
        help_heading = "Parallel rendering"
    )]
    pub runtime: String,
    /// Placement of shadow tasks: local, via-master, to-origin, round-robin or load-aware.
    #[arg(
        long,
        default_value = "local",
        value_name = "POLICY",
        help_heading = "Parallel rendering"
    )]
    pub policy: String,
    /// Object cache per processor: unlimited, bytes (64M, 512K) or a percentage of the scene data (10%).
    #[arg(
        long,
        default_value = "unlimited",
        value_name = "SIZE",
        help_heading = "Parallel rendering"
    )]
    pub cache: String,
    /// Data distribution: octree (equal memory), predicted (equal predicted work) or worst (one processor holds everything).
    #[arg(
        long,
        default_value = "octree",
        value_name = "D",
        help_heading = "Parallel rendering"
    )]
    pub distribution: String,
    /// Side of the square screen tiles handed out as primary tasks, in pixels.
    #[arg(
        long,
        default_value_t = 16,
        value_name = "PIXELS",
        help_heading = "Parallel rendering"
    )]
    pub tile: usize,
    /// Shadow bundles with fewer (estimated) rays than this run data-parallel instead of being clipped.
    #[arg(
        long = "shadow-dp-below",
        default_value_t = 2,
        value_name = "RAYS",
        help_heading = "Parallel rendering"
    )]
    pub shadow_dp_below: usize,
    /// Clip once per (cell, light) with the cell-to-light hull and reuse the selection for every shadow bundle from that cell (fewer clipping steps, slightly larger selections); `--clip-cache false`: clip every bundle, as the paper does.
    #[arg(
        long = "clip-cache",
        value_name = "BOOL",
        default_value_t = true,
        num_args = 0..=1,
        default_missing_value = "true",
        action = clap::ArgAction::Set,
        help_heading = "Parallel rendering"
    )]
    pub clip_cache: bool,
    /// Simulated machine for --runtime sim: parsytec-cc (the paper's) or 10gbe.
    #[arg(
        long,
        default_value = "10gbe",
        value_name = "PRESET",
        help_heading = "Parallel rendering"
    )]
    pub network: String,
    /// Flow control: task and result messages one processor may have unconsumed at another.
    #[arg(
        long,
        default_value_t = 64,
        value_name = "N",
        help_heading = "Parallel rendering"
    )]
    pub credits: usize,
    /// Ask the master for a new tile only when out of work (the paper's way) instead of one tile ahead.
    #[arg(long, help_heading = "Parallel rendering")]
    pub no_prefetch: bool,
    /// Worker threads for the threads runtime [default: one per core].
    #[arg(long, value_name = "N", help_heading = "Parallel rendering")]
    pub threads: Option<usize>,
    /// With -ab: how processors treat the irradiance cache's data dependency: one-at-a-time (wait for the hemisphere in flight) or extra (start hemispheres freely, count the redundant ones).
    #[arg(
        long,
        default_value = "one-at-a-time",
        value_name = "MODE",
        help_heading = "Parallel rendering"
    )]
    pub hemispheres: String,
    /// Give up with an error after this many seconds of parallel rendering (under MPI: and end every rank).
    #[arg(
        long = "time-limit",
        value_name = "SECONDS",
        help_heading = "Parallel rendering"
    )]
    pub time_limit: Option<f64>,
    /// Write the parallel run's statistics (per processor: times, traffic, tasks, cache, memory, work) as JSON.
    #[arg(
        long = "parallel-stats",
        value_name = "FILE",
        help_heading = "Parallel rendering"
    )]
    pub parallel_stats: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Built-in scene (cornell, studio, conference) or a scene file.
    #[arg(long, default_value = "cornell")]
    pub scene: String,
    /// View file for a scene file (default: the .vf next to it).
    #[arg(long = "view-file", value_name = "FILE")]
    pub view_file: Option<PathBuf>,
    #[arg(long, default_value_t = 256)]
    pub width: u32,
    #[arg(long, default_value_t = 256)]
    pub height: u32,
    /// Also run a full render and report its throughput.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub render: bool,
    /// Also time the octree kernel on the same rays, batch by batch beside
    /// the hierarchy, and check that every answer agrees.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub octree: bool,
    /// Thread scaling instead: render with the threads runtime on each of these processor counts
    /// (e.g. 1,2,4), replicated and octree-distributed, beside the sequential renderer; runs are
    /// interleaved and each time is the median of --repeat runs.
    #[arg(long, value_name = "N,N,...", value_delimiter = ',')]
    pub scaling: Vec<usize>,
    /// Runs per configuration for --scaling (the median is reported).
    #[arg(long, default_value_t = 3, value_name = "K")]
    pub repeat: usize,
    #[command(flatten)]
    pub radiance: RadianceArgs,
}

#[derive(Debug, Args)]
pub struct SweepArgs {
    /// Built-in scene (cornell, studio, conference) or a scene file (its view: the .vf next to it or --view-file).
    #[arg(value_name = "SCENE")]
    pub scene: String,
    /// Directory for sweep.csv, sweep.md, sweep.svg and reference.hdr (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// View file for a scene file.
    #[arg(long = "view-file", value_name = "FILE")]
    pub view_file: Option<PathBuf>,
    /// Maximum image width (reduced to keep pixels square).
    #[arg(long, default_value_t = 64, value_name = "W")]
    pub width: u32,
    /// Maximum image height.
    #[arg(long, default_value_t = 64, value_name = "H")]
    pub height: u32,
    /// Seed of the random streams (the reference uses its own).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// A cheaper reference (-pn 4 -ab 2 -aa 0.1 -ad 256 -as 64), for quick looks and tests.
    #[arg(long)]
    pub quick_reference: bool,
    /// Radiance options applied to the reference after --quick-reference, e.g. "-dt 0.01" for a
    /// scene with hundreds of sources where testing every shadow ray takes hours.
    #[arg(long, value_name = "OPTIONS", allow_hyphen_values = true)]
    pub reference: Option<String>,
}

/// `hybrid-rt experiment NAME`: the paper's experiments on a simulated cluster.
#[derive(Debug, Args)]
pub struct ExperimentArgs {
    /// table1, speedup, efficiency, clipping, idle, communication, data, cache, breakdown, memory, flow, all; or calibrate (fit the cost model on this machine).
    pub name: String,
    /// Built-in scene (cornell, studio, conference) or a scene file.
    #[arg(long, default_value = "studio")]
    pub scene: String,
    /// View file for a scene file (default: the .vf next to it).
    #[arg(long = "view-file", value_name = "FILE")]
    pub view_file: Option<PathBuf>,
    /// Output directory (created if missing).
    #[arg(long, default_value = "experiments")]
    pub out: PathBuf,
    /// Simulated machine: parsytec-cc (the paper's) or 10gbe.
    #[arg(long, default_value = "parsytec-cc")]
    pub network: String,
    /// Image width of the speed-up and per-processor experiments.
    #[arg(long, default_value_t = 256)]
    pub width: u32,
    #[arg(long, default_value_t = 256)]
    pub height: u32,
    /// Largest processor count of the speed-up curve (a power of two).
    #[arg(long = "max-procs", default_value_t = 64)]
    pub max_procs: usize,
    /// Processors of the per-processor figures (6 to 11, 13, Table 2).
    #[arg(long = "detail-procs", default_value_t = 16)]
    pub detail_procs: usize,
    /// Processors of the cache-size experiment (Figure 12).
    #[arg(long = "cache-procs", default_value_t = 8)]
    pub cache_procs: usize,
    /// Image side of the cache-size experiment (the paper's 128).
    #[arg(long = "cache-size", default_value_t = 128)]
    pub cache_size: u32,
    /// Seed of the simulation (latency jitter).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    #[command(flatten)]
    pub radiance: RadianceArgs,
}

/// Our options that take one value.
const VALUE_FLAGS: &[&str] = &[
    "--out",
    "--quality",
    "--view",
    "--view-file",
    "-o",
    "--output",
    "--stats",
    "--exposure",
    "--gamma",
    "--seed",
    "--width",
    "--height",
    "--scene",
    "--procs",
    "--runtime",
    "--policy",
    "--cache",
    "--distribution",
    "--tile",
    "--shadow-dp-below",
    "--threads",
    "--time-limit",
    "--parallel-stats",
    "--hemispheres",
    "--network",
    "--credits",
    "--max-procs",
    "--detail-procs",
    "--cache-procs",
    "--cache-size",
    "--reference",
];

/// Number of values each Radiance view option takes.
fn view_arity(word: &str) -> Option<usize> {
    match word {
        w if w.starts_with("-vt") && w.len() == 4 => Some(0),
        "-vp" | "-vd" | "-vu" => Some(3),
        "-vh" | "-vv" | "-vo" | "-va" | "-vs" | "-vl" => Some(1),
        _ => None,
    }
}

/// Rewrites Radiance-style options into clap's long options: `-ds 0.2`
/// becomes `--ds 0.2`, `-vf F` becomes `--view-file F`, and view options
/// (`-vtv -vp 0 0 1 ...`) are collected into one hidden `--view-words`
/// argument each. Everything else passes through unchanged. Values are
/// taken verbatim (a negative number is a value, not an option).
pub fn translate(args: Vec<String>) -> Vec<String> {
    let mut out = Vec::with_capacity(args.len());
    let mut it = args.into_iter().peekable();
    if let Some(prog) = it.next() {
        out.push(prog);
    }
    while let Some(a) = it.next() {
        if a == "--" {
            out.push(a);
            out.extend(it);
            break;
        }
        if VALUE_FLAGS.contains(&a.as_str()) {
            // The next word is this option's value, whatever it looks like
            // (`--view "-vtv ..."`, `-o -out.png`).
            out.push(a);
            if let Some(v) = it.next() {
                out.push(v);
            }
            continue;
        }
        let name = a.strip_prefix('-').filter(|n| !n.starts_with('-'));
        // A switch with its state (`-bv-`): `--bv=-`.
        if let Some((base, state)) = name.and_then(|n| {
            // The last character, not byte: arguments need not be ASCII.
            let cut = n.char_indices().last().map_or(0, |(k, _)| k);
            let (base, last) = n.split_at(cut);
            let switch = RADIANCE_OPTIONS
                .iter()
                .any(|o| o.name == base && o.arity == 0);
            (switch && (last == "+" || last == "-")).then_some((base, last))
        }) {
            out.push(format!("--{base}={state}"));
            continue;
        }
        if let Some(opt) = name.and_then(|n| RADIANCE_OPTIONS.iter().find(|o| o.name == n)) {
            if opt.arity == 0 {
                // A bare switch toggles rpict's default (on).
                out.push(format!("--{}=-", opt.name));
                continue;
            }
            out.push(format!("--{}", opt.name));
            for _ in 0..opt.arity {
                if let Some(v) = it.next() {
                    out.push(v);
                }
            }
        } else if a == "-vf" {
            out.push("--view-file".into());
            if let Some(v) = it.next() {
                out.push(v);
            }
        } else if let Some(n) = view_arity(&a) {
            let mut words = vec![a];
            for _ in 0..n {
                if let Some(v) = it.next() {
                    words.push(v);
                }
            }
            out.push(format!("--view-words={}", words.join(" ")));
        } else {
            out.push(a);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(v: &[&str]) -> Vec<String> {
        v.iter().map(|x| x.to_string()).collect()
    }

    #[test]
    fn translates_switches_and_medium_options() {
        let t = translate(s(&[
            "hybrid-rt",
            "render",
            "a.rad",
            "-bv-",
            "-ms",
            "0.27",
            "-me",
            "1",
            "2",
            "3",
            "-bv+",
        ]));
        assert_eq!(
            t,
            s(&[
                "hybrid-rt",
                "render",
                "a.rad",
                "--bv=-",
                "--ms",
                "0.27",
                "--me",
                "1",
                "2",
                "3",
                "--bv=+",
            ])
        );
    }

    #[test]
    fn translates_radiance_options() {
        let t = translate(s(&[
            "hybrid-rt",
            "render",
            "a.rad",
            "-ds",
            "0.1",
            "-av",
            "1",
            "2",
            "3",
            "-vtv",
            "-vp",
            "-1",
            "0",
            "2",
            "-vf",
            "v.vf",
            "-o",
            "x.png",
            "-lr",
            "-3",
        ]));
        assert_eq!(
            t,
            s(&[
                "hybrid-rt",
                "render",
                "a.rad",
                "--ds",
                "0.1",
                "--av",
                "1",
                "2",
                "3",
                "--view-words=-vtv",
                "--view-words=-vp -1 0 2",
                "--view-file",
                "v.vf",
                "-o",
                "x.png",
                "--lr",
                "-3"
            ])
        );
        let t2 = translate(s(&[
            "hybrid-rt",
            "render",
            "a.rad",
            "--view",
            "-vtv -vp 0 0 1",
            "-o",
            "-x.png",
        ]));
        assert_eq!(
            t2,
            s(&[
                "hybrid-rt",
                "render",
                "a.rad",
                "--view",
                "-vtv -vp 0 0 1",
                "-o",
                "-x.png"
            ])
        );
        let t3 = translate(s(&["hybrid-rt", "render", "a.rad", "--view", "-vtv"]));
        assert_eq!(t3[3..], s(&["--view", "-vtv"])[..]);
        let cli = Cli::try_parse_from(t).unwrap();
        let Command::Render(r) = cli.command else {
            panic!()
        };
        assert_eq!(r.radiance.ds.as_deref(), Some("0.1"));
        assert_eq!(r.radiance.lr.as_deref(), Some("-3"));
        assert_eq!(r.view_words, s(&["-vtv", "-vp -1 0 2"]));
    }
}
