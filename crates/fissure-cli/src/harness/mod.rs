//! The accuracy, stability and speed harness behind `fissure bench`.
//!
//! One command runs every section and writes, under the output folder, a CSV per table and a PNG per plot, and a
//! Markdown report; with `--results FILE` the report replaces the part of `FILE` between the harness markers
//! (`benches/RESULTS.md` in the repository), so the numbers there are always a whole run with its machine, date
//! and commit. Every section states the checks it makes; a failed check makes the command exit non-zero, which is
//! how the reduced CI run (`FISSURE_BENCH_QUICK=1` or `--quick`) keeps the harness from rotting. Figures that are
//! goals rather than correctness (a speed target) are reported as targets and do not fail the run.
//!
//! Sections: `precision` (work–precision: RMS error against an f64 RK4 reference shown converged, against wall
//! time, with measured convergence orders), `stability` (largest stable step by bisection against stiffness,
//! next to the solver's estimated, Gershgorin's and the 1-DOF bounds), `large-steps` (implicit Euler at dt = 1/60 s on stiff cloth), `terms`
//! (cost of each force term, per stage), `speed` (step time against size, thread scaling, memory per element,
//! fraction of the memory-bandwidth floor).

pub mod large_steps;
pub mod precision;
pub mod scenes;
pub mod speed;
pub mod stability;
pub mod terms;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What to run.
#[derive(Clone, Debug)]
pub struct Config {
    /// Reduced sizes and sweeps (CI).
    pub quick: bool,
    /// Folder for CSVs, PNGs and the report.
    pub out: PathBuf,
    /// Markdown file whose harness section is replaced with the report.
    pub results: Option<PathBuf>,
    /// Sections to run (all when empty).
    pub only: Vec<String>,
    /// Leave the GPU out even when an adapter exists.
    pub no_gpu: bool,
}

/// All section names, in run order.
pub const SECTIONS: [&str; 5] = ["precision", "stability", "large-steps", "terms", "speed"];

/// A check a section made.
#[derive(Clone, Debug)]
pub struct Check {
    /// What was checked.
    pub name: String,
    /// Whether it held.
    pub ok: bool,
    /// The numbers behind it.
    pub detail: String,
    /// A goal (reported) rather than a correctness check (fails the run).
    pub target: bool,
}

/// What the sections write.
pub struct Report {
    /// Markdown body.
    pub md: String,
    /// Checks in order.
    pub checks: Vec<Check>,
    /// Output folder.
    pub out: PathBuf,
    /// Reduced run.
    pub quick: bool,
    /// Check lines waiting for the current table to end.
    pub pending: String,
}

impl Report {
    /// Records a correctness check.
    pub fn check(&mut self, name: impl Into<String>, ok: bool, detail: impl Into<String>) {
        self.push(name.into(), ok, detail.into(), false);
    }

    /// Records a goal.
    pub fn target(&mut self, name: impl Into<String>, ok: bool, detail: impl Into<String>) {
        self.push(name.into(), ok, detail.into(), true);
    }

    fn push(&mut self, name: String, ok: bool, detail: String, target: bool) {
        let mark = match (ok, target) {
            (true, _) => "✓",
            (false, false) => "✗ FAILED",
            (false, true) => "✗ (target not met)",
        };
        eprintln!("  [{mark}] {name}: {detail}");
        let _ = writeln!(self.pending, "- {mark} {name}: {detail}");
        self.checks.push(Check { name, ok, detail, target });
    }

    /// Ends a table: writes the check lines recorded while it was being written.
    pub fn flush(&mut self) {
        if !self.pending.is_empty() {
            let _ = write!(self.md, "\n{}\n", self.pending);
            self.pending.clear();
        }
    }

    /// Writes a CSV file under the output folder; returns its file name.
    pub fn csv(&self, name: &str, header: &str, rows: &[String]) -> std::io::Result<String> {
        let mut s = String::from(header);
        s.push('\n');
        for r in rows {
            s.push_str(r);
            s.push('\n');
        }
        std::fs::write(self.out.join(name), s)?;
        Ok(name.to_string())
    }

    /// Writes a plot under the output folder and links it in the report.
    pub fn plot(&mut self, name: &str, plot: &crate::plot::Plot) -> std::io::Result<()> {
        self.flush();
        plot.write_png(&self.out.join(name))?;
        let _ = writeln!(self.md, "\n![{}]({name})\n", plot.title);
        Ok(())
    }
}

/// Seconds `f` takes: once, or the best of as many runs as fit in ~0.1 s when one run is shorter than 20 ms.
pub fn time_best(mut f: impl FnMut()) -> f64 {
    let t = Instant::now();
    f();
    let first = t.elapsed().as_secs_f64();
    if first > 0.02 {
        return first;
    }
    let mut best = first;
    let start = Instant::now();
    while start.elapsed().as_secs_f64() < 0.1 {
        let t = Instant::now();
        f();
        best = best.min(t.elapsed().as_secs_f64());
    }
    best
}

/// A line about the machine: CPU model, cores, memory, OS.
pub fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let mem = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| s.lines().next().and_then(|l| l.split_whitespace().nth(1)).and_then(|kb| kb.parse::<f64>().ok()))
        .map(|kb| format!(", {:.0} GiB memory", kb / 1048576.0))
        .unwrap_or_default();
    format!("{cpu}, {cores} hardware threads{mem}, {} {}", std::env::consts::OS, std::env::consts::ARCH)
}

/// Today's date (UTC) from the system clock, `YYYY-MM-DD`.
pub fn today() -> String {
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0);
    let days = (secs / 86400) as i64;
    // Civil from days (Howard Hinnant's algorithm).
    let z = days + 719468;
    let era = z.div_euclid(146097);
    let doe = z - era * 146097;
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}

/// The commit being measured (`git rev-parse`, with `+dirty` for local changes), or `FISSURE_COMMIT`.
pub fn commit() -> String {
    if let Ok(c) = std::env::var("FISSURE_COMMIT") {
        return c;
    }
    let run = |args: &[&str]| std::process::Command::new("git").args(args).output().ok().filter(|o| o.status.success());
    match run(&["rev-parse", "--short", "HEAD"]) {
        Some(o) => {
            let mut c = String::from_utf8_lossy(&o.stdout).trim().to_string();
            if run(&["diff", "--quiet", "HEAD"]).is_none() {
                c.push_str("+dirty");
            }
            c
        }
        None => "unknown (not a git checkout)".into(),
    }
}

/// Markers delimiting the harness's part of a results file.
pub const BEGIN: &str = "<!-- fissure bench: begin (generated; edit the harness, not this) -->";
/// End marker.
pub const END: &str = "<!-- fissure bench: end -->";

/// Runs the harness. Returns whether every correctness check held.
pub fn run(cfg: &Config) -> Result<bool, String> {
    std::fs::create_dir_all(&cfg.out).map_err(|e| format!("cannot create {}: {e}", cfg.out.display()))?;
    let sections: Vec<&str> =
        SECTIONS.iter().copied().filter(|s| cfg.only.is_empty() || cfg.only.iter().any(|o| o == s)).collect();
    for o in &cfg.only {
        if !SECTIONS.contains(&o.as_str()) {
            return Err(format!("unknown section `{o}`; the sections are {}", SECTIONS.join(", ")));
        }
    }
    let gpu = if cfg.no_gpu { None } else { GpuHandle::open() };
    let mut r = Report {
        md: String::new(),
        checks: Vec::new(),
        out: cfg.out.clone(),
        quick: cfg.quick,
        pending: String::new(),
    };
    let started = Instant::now();
    let _ = writeln!(
        r.md,
        "## The harness: run time against error, stability, cost per term, speed\n\n\
         - Command: `{}`\n- Machine: {}\n- GPU: {}\n- Date: {}, commit `{}`{}\n",
        if cfg.quick {
            "FISSURE_BENCH_QUICK=1 cargo run --release -p fissure-cli -- bench"
        } else {
            "cargo run --release -p fissure-cli -- bench --results benches/RESULTS.md --out benches/harness"
        },
        machine(),
        gpu.as_ref().map_or_else(|| GpuHandle::why_none(cfg.no_gpu), |g| g.name.clone()),
        today(),
        commit(),
        if cfg.quick { "\n- **Reduced run** (CI sizes): small scenes, short sweeps." } else { "" },
    );
    for s in sections {
        eprintln!("== {s}");
        let t = Instant::now();
        match s {
            "precision" => precision::run(&mut r, gpu.as_ref()),
            "stability" => stability::run(&mut r),
            "large-steps" => large_steps::run(&mut r),
            "terms" => terms::run(&mut r),
            "speed" => speed::run(&mut r),
            _ => unreachable!("filtered above"),
        }
        .map_err(|e| format!("section {s}: {e}"))?;
        r.flush();
        eprintln!("   ({s}: {:.1} s)", t.elapsed().as_secs_f64());
    }
    let failed: Vec<&Check> = r.checks.iter().filter(|c| !c.ok && !c.target).collect();
    for c in &failed {
        eprintln!("FAILED: {}: {}", c.name, c.detail);
    }
    let _ = writeln!(
        r.md,
        "\nWhole run: {:.0} s; {} checks, {} failed; {} targets, {} not met.",
        started.elapsed().as_secs_f64(),
        r.checks.iter().filter(|c| !c.target).count(),
        failed.len(),
        r.checks.iter().filter(|c| c.target).count(),
        r.checks.iter().filter(|c| c.target && !c.ok).count(),
    );
    let report = cfg.out.join("REPORT.md");
    std::fs::write(&report, &r.md).map_err(|e| format!("cannot write {}: {e}", report.display()))?;
    eprintln!("report: {}", report.display());
    if let Some(path) = &cfg.results {
        splice_results(path, &cfg.out, &r.md)?;
        eprintln!("updated {}", path.display());
    }
    Ok(failed.is_empty())
}

/// Replaces the harness section of `path` (or appends one), with links made relative to `path`'s folder.
fn splice_results(path: &Path, out: &Path, md: &str) -> Result<(), String> {
    let old = std::fs::read_to_string(path).unwrap_or_default();
    let dir = path.parent().unwrap_or(Path::new("."));
    let rel = out.strip_prefix(dir).map(Path::to_path_buf).unwrap_or_else(|_| out.to_path_buf());
    let rel = rel.to_string_lossy().replace('\\', "/");
    let body = md.replace("](", &format!("]({rel}/"));
    let section = format!("{BEGIN}\n{body}{END}\n");
    let new = match (old.find(BEGIN), old.find(END)) {
        (Some(a), Some(b)) if b > a => {
            format!("{}{section}{}", &old[..a], old[b + END.len()..].trim_start_matches('\n'))
        }
        _ => format!("{}\n{section}", old.trim_end()),
    };
    std::fs::write(path, new).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// A GPU for the sections that compare backends.
pub struct GpuHandle {
    /// The device and queue.
    pub ctx: fissure::gpu::GpuContext,
    /// Adapter description.
    pub name: String,
}

impl GpuHandle {
    fn open() -> Option<GpuHandle> {
        match fissure::gpu::GpuContext::new() {
            Ok(ctx) => {
                let name = ctx.describe();
                Some(GpuHandle { ctx, name })
            }
            Err(e) => {
                eprintln!("no GPU rows: {e}");
                None
            }
        }
    }

    fn why_none(disabled: bool) -> String {
        if disabled { "left out (--no-gpu)".into() } else { "none found (GPU rows left out)".into() }
    }
}

/// Formats a float with 3 significant digits (scientific notation outside [1e-3, 1e5)).
pub fn sig3(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    if v == 0.0 {
        return "0".into();
    }
    if v.abs() < 1e-3 || v.abs() >= 1e5 {
        return format!("{v:.2e}");
    }
    let decimals = (2 - v.abs().log10().floor() as i64).max(0) as usize;
    format!("{v:.decimals$}")
}
