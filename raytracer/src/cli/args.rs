//! Command-line arguments. Radiance spells its options with one dash and
//! several letters (`-ds 0.2`, `-av 1 1 1`, `-vp 0 0 1`), which clap
//! cannot express; [`translate`] rewrites them into long options first.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

use crate::render::RADIANCE_OPTIONS;

/// The name clap accepts for an enum value (its canonical spelling).
pub fn value_name<T: ValueEnum>(v: &T) -> String {
    v.to_possible_value()
        .map(|p| p.get_name().to_string())
        .unwrap_or_default()
}

/// rpict's switch states: `-bv+` / `-bv-`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Switch {
    #[value(name = "+")]
    On,
    #[value(name = "-")]
    Off,
}

/// `--quality`: the presets of [`crate::render::RenderOptions::preset`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Quality {
    Draft,
    Normal,
    High,
}

/// `--runtime`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum RuntimeArg {
    #[default]
    Threads,
    Sequential,
    #[value(alias = "simulated")]
    Sim,
    Mpi,
}

impl From<RuntimeArg> for crate::parallel::RuntimeKind {
    fn from(r: RuntimeArg) -> Self {
        use crate::parallel::RuntimeKind as K;
        match r {
            RuntimeArg::Threads => K::Threads,
            RuntimeArg::Sequential => K::Sequential,
            RuntimeArg::Sim => K::Sim,
            RuntimeArg::Mpi => K::Mpi,
        }
    }
}

/// `--policy`: the framework's placement policies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum PolicyArg {
    #[default]
    Local,
    #[value(aliases = ["via_master", "viamaster", "master"])]
    ViaMaster,
    #[value(aliases = ["to_origin", "toorigin", "origin"])]
    ToOrigin,
    #[value(aliases = ["round_robin", "roundrobin", "rr"])]
    RoundRobin,
    #[value(aliases = ["load_aware", "loadaware", "load"])]
    LoadAware,
}

impl From<PolicyArg> for hybrid_sched::Policy {
    fn from(p: PolicyArg) -> Self {
        use hybrid_sched::Policy as P;
        match p {
            PolicyArg::Local => P::Local,
            PolicyArg::ViaMaster => P::ViaMaster,
            PolicyArg::ToOrigin => P::ToOrigin,
            PolicyArg::RoundRobin => P::RoundRobin,
            PolicyArg::LoadAware => P::LoadAware,
        }
    }
}

/// `--distribution`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum DistributionArg {
    #[default]
    #[value(alias = "balanced")]
    Octree,
    #[value(aliases = ["cost-predicted", "work"])]
    Predicted,
    #[value(alias = "shared")]
    Replicated,
    #[value(aliases = ["worst-case", "one"])]
    Worst,
}

impl From<DistributionArg> for crate::parallel::Distribution {
    fn from(d: DistributionArg) -> Self {
        use crate::parallel::Distribution as D;
        match d {
            DistributionArg::Octree => D::Octree,
            DistributionArg::Predicted => D::Predicted,
            DistributionArg::Replicated => D::Replicated,
            DistributionArg::Worst => D::Worst,
        }
    }
}

/// `--serve-data`: when a processor answers requests for its data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum ServeDataArg {
    /// By its data server, as the request arrives (beyond the paper).
    #[default]
    #[value(alias = "arrival")]
    OnArrival,
    /// Between two of its steps (the paper's).
    #[value(alias = "steps")]
    BetweenSteps,
}

impl From<ServeDataArg> for hybrid_sched::DataService {
    fn from(s: ServeDataArg) -> Self {
        match s {
            ServeDataArg::OnArrival => hybrid_sched::DataService::OnArrival,
            ServeDataArg::BetweenSteps => hybrid_sched::DataService::BetweenSteps,
        }
    }
}

/// `--network`: the simulated machines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum NetworkArg {
    /// The paper's Parsytec CC.
    #[value(name = "parsytec-cc", aliases = ["parsytec", "parsytec_cc"])]
    ParsytecCc,
    /// A cluster on 10 Gbit/s Ethernet.
    #[default]
    #[value(name = "10gbe", aliases = ["10gbe-cluster", "ten-gbe"])]
    TenGbe,
}

impl From<NetworkArg> for hybrid_sched::Network {
    fn from(n: NetworkArg) -> Self {
        match n {
            NetworkArg::ParsytecCc => hybrid_sched::Network::parsytec_cc(),
            NetworkArg::TenGbe => hybrid_sched::Network::ten_gbe(),
        }
    }
}

/// `--up`: the up axis of an OBJ scene framed automatically.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum UpAxis {
    #[value(name = "x", alias = "+x")]
    X,
    #[default]
    #[value(name = "y", alias = "+y")]
    Y,
    #[value(name = "z", alias = "+z")]
    Z,
    #[value(name = "-x")]
    NegX,
    #[value(name = "-y")]
    NegY,
    #[value(name = "-z")]
    NegZ,
}

impl UpAxis {
    /// The axis as a unit vector.
    pub fn vector(self) -> crate::geometry::Vec3 {
        use crate::geometry::Vec3;
        match self {
            UpAxis::X => Vec3::X,
            UpAxis::Y => Vec3::Y,
            UpAxis::Z => Vec3::Z,
            UpAxis::NegX => -Vec3::X,
            UpAxis::NegY => -Vec3::Y,
            UpAxis::NegZ => -Vec3::Z,
        }
    }
}

/// `hybrid-rt experiment NAME`: the paper's experiments
/// ([`crate::experiment::NAMES`]), all of them, or the calibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ExperimentName {
    Table1,
    Speedup,
    Efficiency,
    Clipping,
    Idle,
    Communication,
    Data,
    Cache,
    Breakdown,
    Memory,
    Flow,
    /// Diffuse inter-reflection (`-ab`) on the simulated cluster, 1 to
    /// `--max-procs` processors (not in `all`).
    Interreflection,
    /// Hemisphere rays migrating through a distributed scene (`-ab` with
    /// `-aa 0`) on the simulated cluster, 1 to `--max-procs`
    /// processors, unlimited and 10% caches (not in `all`).
    Hemispheres,
    All,
    Calibrate,
}

#[derive(Debug, Parser)]
#[command(
    name = "hybrid-rt",
    version,
    about = "A Radiance-style ray tracer, sequential reference of a hybrid-scheduled parallel renderer",
    after_help = "rpict's habits: -x W -y H (--width, --height), -o FILE or no -o for a Radiance picture on standard output, -e FILE (diagnostics appended to FILE), -i (irradiance), -vf FILE (a view file or a Radiance picture's VIEW= line).\nRadiance options may be written Radiance's way: -ds 0.2 -dj 0.5 -dt 0.05 -dc 0.5 -lr 8 -lw 0.002 -av 0.1 0.1 0.1 -ab 1 -aa 0.1 -ar 256 -ad 512 -as 128 -ps 1, and view options -vf FILE -vtv -vp X Y Z -vd X Y Z -vu X Y Z -vh A -vv A.\nLogging: set RUST_LOG (e.g. RUST_LOG=info)."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a scene to a PNG, Radiance HDR, OpenEXR or PFM picture.
    Render(Box<RenderArgs>),
    /// Measure primary and shadow ray throughput on a scene.
    Bench(Box<BenchArgs>),
    /// What accuracy costs: render a converged reference, sweep the quality knobs, report error against time (CSV, markdown, SVG with the Pareto front).
    Sweep(Box<SweepArgs>),
    /// Reproduce the paper's tables and figures on a simulated cluster (SVG, markdown, JSON).
    Experiment(Box<ExperimentArgs>),
    /// Write a built-in scene as Radiance text: a seeded city of any size, the studio, the Cornell box.
    Generate(Box<super::generate::GenerateArgs>),
    /// Compile scene files into one binary scene grouped by octree cell (like oconv); render reads it.
    Compile(Box<super::compile::CompileArgs>),
}

/// Radiance rendering options (long forms of `-ds`, `-dj`, ...).
#[derive(Debug, Args, Default)]
pub struct RadianceArgs {
    /// Quality preset chosen from the sweep's Pareto front: draft, normal or high (Radiance options given as well override it).
    #[arg(long, value_name = "PRESET", value_enum, ignore_case = true)]
    pub quality: Option<Quality>,
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
    /// -aw: weight of -av in a moving average of the computed ambient values, 0 = -av as given [default: 0]
    #[arg(long = "aw", value_name = "N", allow_hyphen_values = true)]
    pub aw: Option<String>,
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
    #[arg(long = "bv", value_name = "+|-", value_enum)]
    pub bv: Option<Switch>,
    /// -i+ / -i-: irradiance (Radiance's white Lambertian at the first surfaces seen) instead of radiance [default: -]
    #[arg(long = "i", value_name = "+|-", value_enum)]
    pub i: Option<Switch>,
    /// -dp: virtual source pretest density: accepted, no effect
    #[arg(long = "dp", value_name = "N", allow_hyphen_values = true, hide = true)]
    pub dp: Option<String>,
    /// -af: ambient file (render): the irradiance cache's records are read from it at the start if it exists, and the render's new ones appended (Radiance 5's format)
    #[arg(long = "af", value_name = "FILE", allow_hyphen_values = true)]
    pub af: Option<String>,
    /// -u+ / -u-: uncorrelated sampling: accepted, no effect
    #[arg(long = "u", value_name = "+|-", value_enum, hide = true)]
    pub u: Option<Switch>,
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
            ("dp", one(&self.dp)),
            ("af", one(&self.af)),
            ("lr", one(&self.lr)),
            ("lw", one(&self.lw)),
            (
                "av",
                self.av
                    .as_ref()
                    .map(|a| a.iter().map(String::as_str).collect()),
            ),
            ("aw", one(&self.aw)),
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
                match self.bv {
                    Some(Switch::Off) => "bv-",
                    _ => "bv+",
                },
                self.bv.map(|_| Vec::new()),
            ),
            (
                match self.i {
                    Some(Switch::On) => "i+",
                    _ => "i-",
                },
                self.i.map(|_| Vec::new()),
            ),
            (
                match self.u {
                    Some(Switch::On) => "u+",
                    _ => "u-",
                },
                self.u.map(|_| Vec::new()),
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
    /// Radiance view file (also -vf), or a Radiance picture whose header's VIEW= line is read. Without any view option: SCENE.vf beside the first scene file, else (OBJ) a view framing the scene, else Radiance's default view.
    #[arg(long = "view-file", value_name = "FILE")]
    pub view_file: Option<PathBuf>,
    /// Up axis of an OBJ scene framed automatically (no view given).
    #[arg(long, value_enum, default_value_t = UpAxis::Y, allow_hyphen_values = true)]
    pub up: UpAxis,
    /// Radiance view options, e.g. "-vtv -vp 0 0 1 -vd 0 1 0 -vh 60 -vv 45" (applied after --view-file; may repeat).
    #[arg(long = "view", value_name = "OPTIONS", allow_hyphen_values = true)]
    pub view: Vec<String>,
    /// View options given Radiance's way on the command line (collected by the translator).
    #[arg(long = "view-words", hide = true, allow_hyphen_values = true)]
    pub view_words: Vec<String>,
    /// Maximum image width; reduced to keep pixels square (also rpict's -x W).
    #[arg(long, default_value_t = 512, value_name = "W")]
    pub width: u32,
    /// Maximum image height; reduced to keep pixels square (also rpict's -y H).
    #[arg(long, default_value_t = 512, value_name = "H")]
    pub height: u32,
    /// Output picture: .png (tone mapped), or linear radiance as .hdr (Radiance RGBE), .exr (OpenEXR) or .pfm. Without -o, or with -o -, a Radiance picture goes to standard output, as rpict writes it.
    #[arg(
        short = 'o',
        long = "output",
        value_name = "FILE",
        allow_hyphen_values = true
    )]
    pub output: Option<PathBuf>,
    /// Diagnostics (warnings, errors, log output) appended to this file instead of standard error (also rpict's -e FILE).
    #[arg(long = "error-file", value_name = "FILE", allow_hyphen_values = true)]
    pub error_file: Option<PathBuf>,
    /// Write render statistics as JSON to this file.
    #[arg(long, value_name = "FILE")]
    pub stats: Option<PathBuf>,
    /// Exposure: a multiplier (2.5) or stops with a sign (+1, -2) like pfilt -e; selects --tone exposure, which without it maps the mean brightness to 0.5.
    #[arg(long, value_name = "E", allow_hyphen_values = true)]
    pub exposure: Option<String>,
    /// Display gamma for PNG instead of the sRGB curve.
    #[arg(long, value_name = "G")]
    pub gamma: Option<f64>,
    /// Tone operator for PNG output [default: reinhard; exposure when --exposure is given].
    #[arg(long, value_enum, value_name = "OPERATOR")]
    pub tone: Option<crate::image::ToneOperator>,
    /// --tone reinhard: the percentile of luminance that maps to white [default: 100, the brightest pixel].
    #[arg(long = "tone-white", value_name = "PERCENT")]
    pub tone_white: Option<f64>,
    /// rpict -t: a progress report on stderr every N seconds (0: none).
    #[arg(short = 't', long = "report", value_name = "N")]
    pub report: Option<u64>,
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
        value_enum,
        ignore_case = true,
        help_heading = "Parallel rendering"
    )]
    pub runtime: RuntimeArg,
    /// Placement of shadow tasks: local, via-master, to-origin, round-robin or load-aware.
    #[arg(
        long,
        default_value = "local",
        value_name = "POLICY",
        value_enum,
        ignore_case = true,
        help_heading = "Parallel rendering"
    )]
    pub policy: PolicyArg,
    /// Object cache per processor: unlimited, bytes (64M, 512K) or a percentage of the scene data (10%).
    #[arg(
        long,
        default_value = "unlimited",
        value_name = "SIZE",
        help_heading = "Parallel rendering"
    )]
    pub cache: String,
    /// Most cell data one demand-driven task may have fetched for it: auto (with a budgeted --cache, 1/32 of the budget and at least 64K; unlimited with an unlimited cache), unlimited (the paper's scheduler), bytes (1M, 64K) or a percentage of the scene data; a task with more to fetch traces data-parallel instead (its rays migrate to the cells' owners). The picture is the same; on a 1.5M-triangle city under four MPI ranks with --cache 10%, auto (1M) kept every rank's peak memory at or under its bound, which unlimited overshot by up to 52 MiB.
    #[arg(
        long,
        default_value = "auto",
        value_name = "SIZE",
        help_heading = "Parallel rendering"
    )]
    pub fetch_limit: String,
    /// Beyond the paper: with an unlimited cache (and no fetch limit), a processor asks for the rest of the scene data held elsewhere at once, and from then on holds the whole scene and traces its tiles as the sequential renderer does, when it has fetched this percentage of that data (at 50 it fetches at most twice what its tasks asked for) or sooner, once the octree walks past its own cells have cost what holding everything costs (a hierarchy over every object and a copy of the cell data); `off`: the paper's cache, which fetches only what tasks select. The picture is the same (the book's Parallel chapter; the times are in its Benchmarks chapter).
    #[arg(
        long,
        default_value = "50",
        value_name = "PERCENT|off",
        value_parser = parse_percent_or_off,
        help_heading = "Parallel rendering"
    )]
    pub complete_cache: PercentOrOff,
    /// When a processor answers requests for the scene data it holds: `on-arrival` (beyond the paper: its data server answers while the processor traces; the simulator charges the time to the owner's CPU, the threads runtime reads the owner's cells in the requesting processor's step, MPI answers on the owner's MPI thread) or `between-steps` (the paper's: a request waits for the owner's current task to end). The picture is the same.
    #[arg(
        long,
        default_value = "on-arrival",
        value_name = "WHEN",
        value_enum,
        help_heading = "Parallel rendering"
    )]
    pub serve_data: ServeDataArg,
    /// Data distribution: octree (equal memory), predicted (equal predicted work) or worst (one processor holds everything).
    #[arg(
        long,
        default_value = "octree",
        value_name = "D",
        value_enum,
        ignore_case = true,
        help_heading = "Parallel rendering"
    )]
    pub distribution: DistributionArg,
    /// Side of the square screen tiles handed out as primary tasks, in pixels [default: 16; with diffuse inter-reflection in the hybrid workload (-ab with -aa 0), the largest power of two up to 16 whose tile starts at most 16384 hemisphere samples (-ad plus -as per pixel): 4 at rpict's -ad 512 -as 128].
    #[arg(long, value_name = "PIXELS", help_heading = "Parallel rendering")]
    pub tile: Option<usize>,
    /// Shadow bundles with fewer (estimated) rays than this run data-parallel instead of being clipped.
    #[arg(
        long = "shadow-dp-below",
        default_value_t = 2,
        value_name = "RAYS",
        help_heading = "Parallel rendering"
    )]
    pub shadow_dp_below: usize,
    /// Clip once per (cell, light) with the cell-to-light hull and reuse the selection for every shadow bundle from that cell (fewer clipping steps; a hull ends at the light, where a bundle's own pyramid reaches past it, so a selection can hold fewer cells); `--clip-cache false`: clip every bundle, as the paper does.
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
    /// Run a shadow bundle whose rays stay among its processor's resident cells in the step that shaded its point (no task of its own; pictures do not change), and a point's other bundles, with data-parallel ones stopped there by a cell held elsewhere, as one task; `--inline-shadows false`: every bundle a task of its own, as the paper schedules them.
    #[arg(
        long = "inline-shadows",
        value_name = "BOOL",
        default_value_t = true,
        num_args = 0..=1,
        default_missing_value = "true",
        action = clap::ArgAction::Set,
        help_heading = "Parallel rendering"
    )]
    pub inline_shadows: bool,
    /// Answer a ray or shadow query through the processor's own hierarchy over its resident objects (and, with an unlimited cache, the cells it has cached: the hierarchy is rebuilt as the cache grows by a quarter) when they decide the answer, instead of walking the octree leaf by leaf (pictures do not change; `--runtime sim` always walks, as its cost model prices the walk); `--local-kernel false`: every query walks.
    #[arg(
        long = "local-kernel",
        value_name = "BOOL",
        default_value_t = true,
        num_args = 0..=1,
        default_missing_value = "true",
        action = clap::ArgAction::Set,
        help_heading = "Parallel rendering"
    )]
    pub local_kernel: bool,
    /// Hand out the frame's last tiles (two per processor) in quarters, so the processors run dry together (pictures do not change); `--tail-tiles false`: every tile of `--tile` pixels, as the paper's.
    #[arg(
        long = "tail-tiles",
        value_name = "BOOL",
        default_value_t = true,
        num_args = 0..=1,
        default_missing_value = "true",
        action = clap::ArgAction::Set,
        help_heading = "Parallel rendering"
    )]
    pub tail_tiles: bool,
    /// Finished pixels a processor holds before sending them to the master in one message (32 bytes each), so its memory does not grow with the picture; 0 holds them all to the end.
    #[arg(
        long = "pixel-batch",
        default_value_t = crate::parallel::PIXEL_BATCH,
        value_name = "PIXELS",
        help_heading = "Parallel rendering"
    )]
    pub pixel_batch: usize,
    /// Simulated machine for --runtime sim: parsytec-cc (the paper's) or 10gbe.
    #[arg(
        long,
        default_value = "10gbe",
        value_name = "PRESET",
        value_enum,
        ignore_case = true,
        help_heading = "Parallel rendering"
    )]
    pub network: NetworkArg,
    /// Flow control: task and result messages one processor may have unconsumed at another.
    #[arg(
        long,
        default_value_t = 64,
        value_name = "N",
        help_heading = "Parallel rendering"
    )]
    pub credits: usize,
    /// Flow control in bytes: work in flight per processor (task and result messages received and not consumed, plus those waiting to be sent). Five eighths bound the input buffer (half shared, an eighth that only results may use), three eighths the send backlog; past three quarters in flight, a processor with results waiting to leave runs nothing until they do. The simulated experiments use 1 MiB.
    #[arg(
        long,
        default_value_t = crate::parallel::RENDER_FLIGHT_BYTES,
        value_name = "BYTES",
        value_parser = byte_count,
        help_heading = "Parallel rendering"
    )]
    pub flight_bytes: usize,
    /// Ask the master for a new tile only when out of work (the paper's way) instead of one tile ahead.
    #[arg(long, help_heading = "Parallel rendering")]
    pub no_prefetch: bool,
    /// Worker threads for the threads runtime [default: one per core].
    #[arg(long, value_name = "N", help_heading = "Parallel rendering")]
    pub threads: Option<usize>,
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
    /// After rendering, print this process's peak resident memory as the operating system measured it (Linux: VmHWM; under MPI one line per rank).
    #[arg(long = "peak-memory", help_heading = "Parallel rendering")]
    pub peak_memory: bool,
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
    /// (e.g. 1,2,4), replicated and octree-distributed (with render's default cache, which completes
    /// itself, and with the paper's), beside the sequential renderer and, for each count N above 1,
    /// N sequential renders at once (what the machine allows); runs are interleaved and each time is
    /// the median of --repeat runs.
    #[arg(long, value_name = "N,N,...", value_delimiter = ',')]
    pub scaling: Vec<usize>,
    /// Runs per configuration for --scaling (the median is reported).
    #[arg(long, default_value_t = 3, value_name = "K")]
    pub repeat: usize,
    /// Instead: the scene as triangles through this project's hierarchy and
    /// through Embree (a build with the `embree` feature), primary and shadow
    /// rays side by side, --repeat rounds (median).
    #[arg(long)]
    pub embree: bool,
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
    /// An experiment, all of them, or calibrate (fit the cost model on this machine, write it to OUT/cost-model.json, and say how far the committed experiments/cost-model.json is off).
    #[arg(value_enum)]
    pub name: ExperimentName,
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
    #[arg(long, value_enum, ignore_case = true, default_value = "parsytec-cc")]
    pub network: NetworkArg,
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
    "-t",
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
    "--network",
    "--credits",
    "--flight-bytes",
    "--max-procs",
    "--detail-procs",
    "--cache-procs",
    "--cache-size",
    "--reference",
    "--up",
    "--error-file",
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
/// becomes `--ds 0.2`, `-vf F` becomes `--view-file F` (`-x`, `-y`, `-e`:
/// `--width`, `--height`, `--error-file`), `-i` becomes `--i=+`, and view options
/// (`-vtv -vp 0 0 1 ...`) are collected into one hidden `--view-words`
/// argument each. Everything else passes through unchanged. Values are
/// taken verbatim (a negative number is a value, not an option). As in
/// rpict, a Radiance-style option given twice takes its last value
/// (`rad` writes `-ps 3 -pt .08 -ps 1`).
pub fn translate(args: Vec<String>) -> Vec<String> {
    let mut out = Vec::with_capacity(args.len());
    // Where each Radiance-style option was last written: (first word,
    // words); an earlier occurrence is dropped when it comes again.
    let mut seen: std::collections::HashMap<String, (usize, usize)> = Default::default();
    let mut dropped = vec![false; 0];
    let mut note = |out: &Vec<String>, dropped: &mut Vec<bool>, key: String, start: usize| {
        dropped.resize(out.len(), false);
        if let Some((s0, n)) = seen.insert(key, (start, out.len() - start)) {
            dropped[s0..s0 + n].iter_mut().for_each(|d| *d = true);
        }
    };
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
            let start = out.len();
            out.push(format!("--{base}={state}"));
            note(&out, &mut dropped, base.to_string(), start);
            continue;
        }
        if let Some(opt) = name.and_then(|n| RADIANCE_OPTIONS.iter().find(|o| o.name == n)) {
            let start = out.len();
            if opt.arity == 0 {
                // A bare switch toggles rpict's default (off for -i, on
                // for the others).
                let state = if opt.name == "i" { "+" } else { "-" };
                out.push(format!("--{}={state}", opt.name));
                note(&out, &mut dropped, opt.name.to_string(), start);
                continue;
            }
            out.push(format!("--{}", opt.name));
            for _ in 0..opt.arity {
                if let Some(v) = it.next() {
                    out.push(v);
                }
            }
            note(&out, &mut dropped, opt.name.to_string(), start);
        } else if let Some(long) = match a.as_str() {
            "-vf" => Some("--view-file"),
            "-x" => Some("--width"),
            "-y" => Some("--height"),
            "-e" => Some("--error-file"),
            _ => None,
        } {
            let start = out.len();
            out.push(long.into());
            if let Some(v) = it.next() {
                out.push(v);
            }
            note(&out, &mut dropped, long.to_string(), start);
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
    dropped.resize(out.len(), false);
    out.into_iter()
        .zip(dropped)
        .filter_map(|(w, d)| (!d).then_some(w))
        .collect()
}

/// A byte count with an optional `K`, `M` or `G` suffix (powers of 1024),
/// as `--cache` takes one.
fn byte_count(s: &str) -> Result<usize, String> {
    match s.parse::<crate::parallel::CacheSize>() {
        Ok(crate::parallel::CacheSize::Bytes(b)) => {
            usize::try_from(b).map_err(|_| format!("{s:?} is too large"))
        }
        _ => Err(format!(
            "{s:?}: expected a byte count like 1048576, 512K or 64M"
        )),
    }
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
    fn a_repeated_radiance_option_takes_its_last_value() {
        assert_eq!(
            translate(s(&[
                "hybrid-rt",
                "render",
                "a.rad",
                "-ps",
                "3",
                "-pt",
                ".08",
                "-ps",
                "1",
                "-av",
                "1",
                "1",
                "1",
                "-bv-",
                "-x",
                "8",
                "-av",
                "2",
                "2",
                "2",
                "-bv+",
                "-x",
                "16"
            ])),
            s(&[
                "hybrid-rt",
                "render",
                "a.rad",
                "--pt",
                ".08",
                "--ps",
                "1",
                "--av",
                "2",
                "2",
                "2",
                "--bv=+",
                "--width",
                "16"
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

    fn render_args(v: &[&str]) -> RenderArgs {
        let cli = Cli::try_parse_from(translate(s(v))).unwrap();
        let Command::Render(r) = cli.command else {
            panic!()
        };
        *r
    }

    #[test]
    fn rpict_size_error_file_and_irradiance() {
        let t = translate(s(&[
            "hybrid-rt",
            "render",
            "a.rad",
            "-x",
            "64",
            "-y",
            "32",
            "-e",
            "-log",
            "-i",
            "-o",
            "-",
        ]));
        assert_eq!(
            t,
            s(&[
                "hybrid-rt",
                "render",
                "a.rad",
                "--width",
                "64",
                "--height",
                "32",
                "--error-file",
                "-log",
                "--i=+",
                "-o",
                "-"
            ])
        );
        let r = render_args(&t.iter().map(String::as_str).collect::<Vec<_>>());
        assert_eq!((r.width, r.height), (64, 32));
        assert_eq!(r.error_file, Some(PathBuf::from("-log")));
        assert_eq!(r.output, Some(PathBuf::from("-")));
        assert_eq!(r.radiance.i, Some(Switch::On));
        assert!(r.radiance.given().contains(&("i+", vec![])));
        // -i- and -i+ as written; no -o at all.
        let r = render_args(&[
            "hybrid-rt",
            "render",
            "a.rad",
            "-i-",
            "-bv-",
            "-u",
            "-dp",
            "32",
            "-af",
            "x.amb",
        ]);
        assert_eq!(r.radiance.i, Some(Switch::Off));
        assert_eq!(r.output, None);
        let given = r.radiance.given();
        assert!(given.contains(&("i-", vec![])) && given.contains(&("bv-", vec![])));
        assert!(given.contains(&("dp", vec!["32"])) && given.contains(&("af", vec!["x.amb"])));
        let mut o = crate::render::RenderOptions::default();
        for (name, values) in given {
            o.set(name, &values).unwrap();
        }
        assert!(!o.irradiance && !o.bv);
        let mut o = crate::render::RenderOptions::default();
        for (name, values) in render_args(&["hybrid-rt", "render", "a.rad", "-i"])
            .radiance
            .given()
        {
            o.set(name, &values).unwrap();
        }
        assert!(o.irradiance);
    }

    #[test]
    fn enums_map_onto_the_internal_types() {
        let r = render_args(&[
            "hybrid-rt",
            "render",
            "a.rad",
            "--runtime",
            "simulated",
            "--policy",
            "Load_Aware",
            "--distribution",
            "replicated",
            "--network",
            "parsytec",
            "--quality",
            "HIGH",
            "--up",
            "-z",
        ]);
        let p = &r.parallel;
        assert_eq!(
            crate::parallel::RuntimeKind::from(p.runtime),
            crate::parallel::RuntimeKind::Sim
        );
        assert_eq!(
            hybrid_sched::Policy::from(p.policy),
            hybrid_sched::Policy::LoadAware
        );
        assert_eq!(
            crate::parallel::Distribution::from(p.distribution),
            crate::parallel::Distribution::Replicated
        );
        assert_eq!(
            hybrid_sched::Network::from(p.network).name,
            hybrid_sched::Network::parsytec_cc().name
        );
        assert_eq!(r.radiance.quality, Some(Quality::High));
        assert_eq!(r.up.vector(), -crate::geometry::Vec3::Z);
        // Every canonical spelling parses as the internal type does, and
        // means the same.
        for p in PolicyArg::value_variants() {
            let internal: hybrid_sched::Policy = value_name(p).parse().unwrap();
            assert_eq!(internal, hybrid_sched::Policy::from(*p));
        }
        for d in DistributionArg::value_variants() {
            let internal: crate::parallel::Distribution = value_name(d).parse().unwrap();
            assert_eq!(internal, crate::parallel::Distribution::from(*d));
        }
        for n in NetworkArg::value_variants() {
            let name = value_name(n);
            assert_eq!(
                hybrid_sched::Network::preset(&name).map(|x| x.name),
                Some(hybrid_sched::Network::from(*n).name)
            );
        }
        let names: Vec<String> = NetworkArg::value_variants()
            .iter()
            .map(value_name)
            .collect();
        assert_eq!(names, hybrid_sched::Network::PRESETS);
        for q in Quality::value_variants() {
            crate::render::RenderOptions::preset(&value_name(q)).unwrap();
        }
        let quality: Vec<String> = Quality::value_variants().iter().map(value_name).collect();
        assert_eq!(quality, crate::render::QUALITY_PRESETS);
        let experiments: Vec<String> = ExperimentName::value_variants()
            .iter()
            .map(value_name)
            .filter(|n| n != "all" && n != "calibrate")
            .collect();
        let known: Vec<&str> = crate::experiment::NAMES
            .iter()
            .chain(&crate::experiment::EXTRA)
            .copied()
            .collect();
        assert_eq!(experiments, known);
        // Defaults as before.
        let d = render_args(&["hybrid-rt", "render", "a.rad"]);
        assert_eq!(d.parallel.runtime, RuntimeArg::Threads);
        assert_eq!(d.parallel.policy, PolicyArg::Local);
        assert_eq!(d.parallel.distribution, DistributionArg::Octree);
        assert_eq!(d.parallel.network, NetworkArg::TenGbe);
        assert_eq!(d.up, UpAxis::Y);
    }

    #[test]
    fn bad_enum_values_list_every_accepted_value() {
        let e = Cli::try_parse_from(translate(s(&[
            "hybrid-rt",
            "render",
            "a.rad",
            "--policy",
            "fastest",
        ])))
        .unwrap_err()
        .to_string();
        for p in PolicyArg::value_variants() {
            assert!(e.contains(&value_name(p)), "{e}");
        }
        assert!(e.contains("load-aware"));
        let e = Cli::try_parse_from(translate(s(&["hybrid-rt", "experiment", "fig99"])))
            .unwrap_err()
            .to_string();
        assert!(e.contains("table1") && e.contains("calibrate"), "{e}");
    }
}

/// `--complete-cache`: a percentage 0..=100, or `off` (`None`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PercentOrOff(pub Option<u8>);

/// As the command line's default (`50`).
impl Default for PercentOrOff {
    fn default() -> Self {
        PercentOrOff(Some(50))
    }
}

fn parse_percent_or_off(s: &str) -> Result<PercentOrOff, String> {
    if s == "off" {
        return Ok(PercentOrOff(None));
    }
    match s.trim_end_matches('%').parse::<u8>() {
        Ok(p) if p <= 100 => Ok(PercentOrOff(Some(p))),
        _ => Err(format!(
            "expected a percentage from 0 to 100, or off (got '{s}')"
        )),
    }
}
