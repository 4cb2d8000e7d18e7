//! `fissure sweep SCENE --set KEY=V1,V2 ...`: the product of the values, run in parallel on all cores (one run
//! per thread: `fissure::scene::run_all`), one CSV row of outcomes per run and a PNG plot.

use crate::plot::{PALETTE, Plot, Series};
use fissure::scene::{Job, Outcome, Override, Scene, run_all_reporting};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

pub const SWEEP_USAGE: &str = "\
usage: fissure sweep SCENE --set KEY=V1,V2,... [--set KEY=...] [--duration S] [--threads N] [--out DIR]

  Runs the scene once for every combination of the values (the product over the --set keys), in
  parallel, headless on the CPU, and writes DIR/sweep.csv (one row per run: the values, fracture
  events by kind, pieces, gas volume, wall time, and the error of a run that failed) and
  DIR/sweep.png (fracture events against the key with the most values, one line per combination of
  the others).

  --set KEY=V1,V2   a scene key and its values (TOML; commas inside [...] belong to a value), e.g.
                    --set body[0].pressure=1000,2000,4000 --set body[0].load_limit=2,3
  --duration S      simulated time of each run [s] (default: the scene's duration)
  --threads N       runs at a time (default: one per core)
  --out DIR         output folder (default target/fissure-sweep/<scene name>)

A run that fails (a bad value, a state that blew up) is a row with its error; the sweep goes on.
The exit status is 1 when every run failed, 2 on a usage error.";

pub struct SweepConfig {
    scene: PathBuf,
    keys: Vec<(String, Vec<toml::Value>)>,
    duration: Option<f64>,
    threads: Option<usize>,
    out: Option<PathBuf>,
}

pub fn parse(args: &[String]) -> Result<SweepConfig, String> {
    let mut cfg = SweepConfig { scene: PathBuf::new(), keys: Vec::new(), duration: None, threads: None, out: None };
    let mut scene = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().cloned().ok_or_else(|| format!("{name} needs a value"));
        match a.as_str() {
            "--set" => cfg.keys.push(Override::parse_list(&value("--set")?)?),
            "--duration" => {
                let v = value("--duration")?;
                let d: f64 = v.parse().map_err(|_| format!("--duration: not a number: {v:?}"))?;
                if !(d.is_finite() && d >= 0.0) {
                    return Err(format!("--duration must be >= 0, got {v}"));
                }
                cfg.duration = Some(d);
            }
            "--threads" => {
                let v = value("--threads")?;
                cfg.threads = Some(v.parse().ok().filter(|&n: &usize| n > 0).ok_or(format!("--threads: {v:?}"))?);
            }
            "--out" => cfg.out = Some(value("--out")?.into()),
            s if s.starts_with('-') => return Err(format!("unknown option `{s}`")),
            s if scene.is_none() => scene = Some(PathBuf::from(s)),
            s => return Err(format!("one scene at a time (got {s:?} too)")),
        }
    }
    cfg.scene = scene.ok_or("which scene? e.g. fissure sweep scenes/fracture.toml --set body[0].pressure=1000,2000")?;
    if cfg.keys.is_empty() {
        return Err("nothing to sweep: give at least one --set KEY=V1,V2,...".into());
    }
    Ok(cfg)
}

/// Every combination of the values, the last key varying fastest.
fn product(keys: &[(String, Vec<toml::Value>)]) -> Vec<Vec<Override>> {
    keys.iter().fold(vec![Vec::new()], |acc, (key, values)| {
        acc.iter()
            .flat_map(|prefix| {
                values.iter().map(move |v| {
                    let mut o = prefix.clone();
                    o.push(Override::new(key.clone(), v.clone()));
                    o
                })
            })
            .collect()
    })
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
}

/// The table: one header line, one row per run.
pub fn csv(keys: &[String], runs: &[(Vec<Override>, Outcome)]) -> String {
    let mut s = String::from("run");
    for k in keys {
        let _ = write!(s, ",{}", csv_field(k));
    }
    s.push_str(",status,spring_events,core_events,detach_events,events,pieces,bodies,particles,triangles,");
    s.push_str("initial_gas_volume_m3,gas_volume_m3,gas_volume_fraction,simulated_s,steps,wall_s,error\n");
    for (k, (o, r)) in runs.iter().enumerate() {
        let _ = write!(s, "{k}");
        for v in o {
            let _ = write!(s, ",{}", csv_field(&v.value.to_string()));
        }
        let fraction = if r.initial_gas_volume > 0.0 { r.gas_volume / r.initial_gas_volume } else { f64::NAN };
        let _ = writeln!(
            s,
            ",{},{},{},{},{},{},{},{},{},{:e},{:e},{:.6},{},{},{:.3},{}",
            if r.error.is_some() { "error" } else { "ok" },
            r.spring_events,
            r.core_events,
            r.detach_events,
            r.events(),
            r.pieces,
            r.bodies,
            r.particles,
            r.triangles,
            r.initial_gas_volume,
            r.gas_volume,
            fraction,
            r.simulated,
            r.steps,
            r.wall,
            csv_field(r.error.as_deref().unwrap_or(""))
        );
    }
    s
}

fn as_number(v: &toml::Value) -> Option<f64> {
    v.as_float().or_else(|| v.as_integer().map(|i| i as f64))
}

pub fn run(cfg: &SweepConfig) -> Result<bool, Box<dyn std::error::Error>> {
    // The file itself must load: a broken file is a usage error, not a table of failures.
    let scene = Scene::load(&cfg.scene)?;
    let combos = product(&cfg.keys);
    let keys: Vec<String> = cfg.keys.iter().map(|(k, _)| k.clone()).collect();
    let jobs: Vec<Job> =
        combos.iter().map(|o| Job { scene: cfg.scene.clone(), overrides: o.clone(), duration: cfg.duration }).collect();
    let threads = cfg.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let out = cfg.out.clone().unwrap_or_else(|| {
        let stem = cfg.scene.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
        PathBuf::from("target/fissure-sweep").join(stem)
    });
    std::fs::create_dir_all(&out)?;
    println!(
        "{}: {} runs of {:.3} s over {} on {threads} threads",
        cfg.scene.display(),
        jobs.len(),
        cfg.duration.unwrap_or(scene.solver.duration),
        keys.join(" x ")
    );
    let wall = Instant::now();
    // One line per finished run on stderr (the table follows on stdout).
    let finished = std::sync::atomic::AtomicUsize::new(0);
    let report = |k: usize, o: &Outcome| {
        let n = finished.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        let values: Vec<String> = combos[k].iter().map(|v| v.to_string()).collect();
        let result = match &o.error {
            Some(e) => format!("error: {e}"),
            None => format!("{} events, {:.2} s", o.events(), o.wall),
        };
        eprintln!("[{n}/{}] run {k} ({}): {result}", combos.len(), values.join(", "));
    };
    let outcomes = run_all_reporting::<f32>(&jobs, Some(threads), &report);
    let wall = wall.elapsed().as_secs_f64();
    let runs: Vec<(Vec<Override>, Outcome)> = combos.into_iter().zip(outcomes).collect();

    let table = out.join("sweep.csv");
    std::fs::write(&table, csv(&keys, &runs))?;
    let plot_path = out.join("sweep.png");
    let name = cfg.scene.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned());
    plot(&keys, &runs, &name).write_png(&plot_path)?;

    println!("\n| run | {} | events (spring, core, detach) | pieces | gas volume | wall |", keys.join(" | "));
    println!("|---|{}---|---|---|---|", "---|".repeat(keys.len()));
    for (k, (o, r)) in runs.iter().enumerate() {
        let values: Vec<String> = o.iter().map(|v| v.value.to_string()).collect();
        let result = match &r.error {
            Some(e) => format!("error: {e} | | |"),
            None => format!(
                "{} ({}, {}, {}) | {} | {:.3} l | {:.2} s",
                r.events(),
                r.spring_events,
                r.core_events,
                r.detach_events,
                r.pieces,
                r.gas_volume * 1e3,
                r.wall
            ),
        };
        println!("| {k} | {} | {result} |", values.join(" | "));
    }
    let sequential: f64 = runs.iter().map(|(_, r)| r.wall).sum();
    println!(
        "\n{} runs in {wall:.2} s wall ({sequential:.2} s summed over runs: {:.2}x from running in parallel)",
        runs.len(),
        sequential / wall.max(1e-9)
    );
    println!("table: {}\nplot:  {}", table.display(), plot_path.display());
    let failed = runs.iter().filter(|(_, r)| r.error.is_some()).count();
    if failed > 0 {
        println!("{failed} of {} runs failed (their rows say why)", runs.len());
    }
    Ok(failed < runs.len())
}

/// Fracture events against the key with the most values (the first of equals), one line per combination of the
/// others; against each value's index when that key's values are not numbers. Failed runs leave gaps.
fn plot(keys: &[String], runs: &[(Vec<Override>, Outcome)], scene: &str) -> Plot {
    let distinct = |k: usize| {
        let mut v: Vec<String> = runs.iter().map(|(o, _)| o[k].value.to_string()).collect();
        v.sort();
        v.dedup();
        v.len()
    };
    let xk = (0..keys.len()).fold(0, |best, k| if distinct(k) > distinct(best) { k } else { best });
    let numeric = runs.iter().all(|(o, _)| as_number(&o[xk].value).is_some());
    let x_label = if numeric { keys[xk].clone() } else { format!("{} (value index)", keys[xk]) };
    let mut plot = Plot::new(format!("fracture events: {scene}"), x_label, "fracture events");
    (plot.log_x, plot.log_y) = (false, false);
    let mut groups: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    let mut seen: Vec<String> = Vec::new();
    for (o, r) in runs {
        let rest: Vec<String> = (0..o.len())
            .filter(|&k| k != xk)
            .map(|k| format!("{}={}", o[k].key.rsplit('.').next().unwrap_or(""), o[k].value))
            .collect();
        let name = if rest.is_empty() { "events".to_string() } else { rest.join(" ") };
        let value = o[xk].value.to_string();
        let x = as_number(&o[xk].value).unwrap_or_else(|| {
            seen.iter().position(|f| *f == value).unwrap_or_else(|| {
                seen.push(value.clone());
                seen.len() - 1
            }) as f64
        });
        let y = if r.error.is_some() { f64::NAN } else { r.events() as f64 };
        match groups.iter_mut().find(|(n, _)| *n == name) {
            Some((_, pts)) => pts.push((x, y)),
            None => groups.push((name, vec![(x, y)])),
        }
    }
    for (k, (name, mut pts)) in groups.into_iter().enumerate() {
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        plot.series.push(Series::new(name, pts, PALETTE[k % PALETTE.len()]));
    }
    plot
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn product_covers_every_combination() {
        let keys = vec![
            ("a".to_string(), vec![toml::Value::Integer(1), toml::Value::Integer(2)]),
            ("b".to_string(), vec![toml::Value::Integer(3), toml::Value::Integer(4), toml::Value::Integer(5)]),
        ];
        let p = product(&keys);
        assert_eq!(p.len(), 6);
        assert_eq!(p[0][0].value, toml::Value::Integer(1));
        assert_eq!(p[5][1].value, toml::Value::Integer(5));
        let runs: Vec<_> = p.into_iter().map(|o| (o, Outcome::failed("x, \"y\""))).collect();
        let t = csv(&["a".into(), "b".into()], &runs);
        assert_eq!(t.lines().count(), 7);
        assert!(t.lines().nth(1).unwrap().ends_with("\"x, \"\"y\"\"\""));
    }
}
