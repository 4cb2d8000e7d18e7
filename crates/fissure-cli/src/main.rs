//! `fissure`: the command-line program.
//!
//! ```text
//! fissure run SCENE [--frames N] [--fps F] [--out DIR] [--backend cpu|gpu] [--size WxH] [--mesh obj|ply]
//! fissure view SCENE [--size WxH] [--paused] [--frames N --screenshot FILE]
//! fissure sweep SCENE --set KEY=V1,V2,... [--set ...] [--duration S] [--threads N] [--out DIR]
//! fissure bench [--quick] [--out DIR] [--results FILE] [--only SECTION[,SECTION…]] [--no-gpu]
//! ```
//!
//! `run` simulates a scene file headless and writes PNG frames, an animated GIF and optionally OBJ/PLY meshes,
//! with a progress bar and a summary table; without any GPU adapter it still simulates and says why it drew
//! nothing. `view` opens the interactive viewer (`fissure::viewer`). Both take `--set KEY=VALUE` to override any
//! scene key. `sweep` runs the product of several keys' values in parallel and writes a CSV of outcomes and a
//! plot.
//!
//! `bench` runs the accuracy, stability and speed harness (see the `harness` module): CSVs, PNG plots and a
//! Markdown report in `--out` (default `target/fissure-bench`), and with `--results` the report spliced into that
//! file between the harness markers. `FISSURE_BENCH_QUICK=1` (or `--quick`) runs the reduced sizes CI uses. The
//! exit status is 1 when a correctness check fails, 2 on a usage or I/O error.

mod harness;
mod plot;
mod run;
mod sweep;

use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "\
usage: fissure run SCENE [--frames N] [--fps F] [--out DIR] [--backend cpu|gpu] [--size WxH] [--mesh obj|ply]
       fissure view SCENE [--size WxH] [--paused] [--frames N --screenshot FILE]
       fissure sweep SCENE --set KEY=V1,V2,... [--set ...] [--duration S] [--threads N] [--out DIR]
       fissure bench [--quick] [--out DIR] [--results FILE] [--only SECTION[,SECTION...]] [--no-gpu]

  run      simulate a scene file headless: PNG frames, a GIF, a summary (fissure run --help)
  view     open a window on a scene (fissure view --help)
  sweep    run a scene for every combination of values of some keys, in parallel: a CSV of
           outcomes and a plot (fissure sweep --help)
  bench    the accuracy, stability and speed harness: work-precision, stability bisection,
           large implicit steps, cost per term, speed (sections: precision, stability,
           large-steps, terms, speed)

  --quick          reduced sizes (also FISSURE_BENCH_QUICK=1), as CI runs it
  --out DIR        where CSVs, PNGs and REPORT.md go (default target/fissure-bench)
  --results FILE   replace the harness section of FILE (benches/RESULTS.md) with the report
  --only LIST      run only these sections
  --no-gpu         leave the GPU rows out even when an adapter exists

The full run: cargo run --release -p fissure-cli -- bench --out benches/harness --results benches/RESULTS.md";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("bench") => bench(&args[1..]),
        Some("run") => {
            if args[1..].iter().any(|a| a == "-h" || a == "--help") {
                println!("{}", run::RUN_USAGE);
                return ExitCode::SUCCESS;
            }
            match run::parse(&args[1..]) {
                Err(e) => {
                    eprintln!("fissure run: {e}\n\n{}", run::RUN_USAGE);
                    ExitCode::from(2)
                }
                Ok(cfg) => match run::run(&cfg) {
                    Ok(_) => ExitCode::SUCCESS,
                    Err(e) => {
                        eprintln!("fissure run: {e}");
                        ExitCode::from(1)
                    }
                },
            }
        }
        Some("sweep") => {
            if args[1..].iter().any(|a| a == "-h" || a == "--help") {
                println!("{}", sweep::SWEEP_USAGE);
                return ExitCode::SUCCESS;
            }
            match sweep::parse(&args[1..]) {
                Err(e) => {
                    eprintln!("fissure sweep: {e}\n\n{}", sweep::SWEEP_USAGE);
                    ExitCode::from(2)
                }
                Ok(cfg) => match sweep::run(&cfg) {
                    Ok(true) => ExitCode::SUCCESS,
                    Ok(false) => ExitCode::from(1),
                    Err(e) => {
                        eprintln!("fissure sweep: {e}");
                        ExitCode::from(2)
                    }
                },
            }
        }
        Some("view") => {
            if args[1..].iter().any(|a| a == "-h" || a == "--help") {
                println!("{}", run::VIEW_USAGE);
                return ExitCode::SUCCESS;
            }
            match run::view(&args[1..]) {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) => {
                    eprintln!("fissure view: {e}");
                    ExitCode::from(1)
                }
            }
        }
        Some("-h" | "--help" | "help") => {
            println!("{USAGE}");
            ExitCode::SUCCESS
        }
        Some(other) => {
            eprintln!("fissure: unknown command `{other}`\n\n{USAGE}");
            ExitCode::from(2)
        }
        None => {
            eprintln!("{USAGE}");
            ExitCode::from(2)
        }
    }
}

fn bench(args: &[String]) -> ExitCode {
    let quick_env = std::env::var("FISSURE_BENCH_QUICK").is_ok_and(|v| !v.is_empty() && v != "0");
    let mut cfg = harness::Config {
        quick: quick_env,
        out: PathBuf::from("target/fissure-bench"),
        results: None,
        only: Vec::new(),
        no_gpu: false,
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| -> Result<String, String> {
            it.next().cloned().ok_or_else(|| format!("{name} needs a value"))
        };
        let res = match a.as_str() {
            "--quick" => {
                cfg.quick = true;
                Ok(())
            }
            "--no-gpu" => {
                cfg.no_gpu = true;
                Ok(())
            }
            "--out" => value("--out").map(|v| cfg.out = PathBuf::from(v)),
            "--results" => value("--results").map(|v| cfg.results = Some(PathBuf::from(v))),
            "--only" => value("--only").map(|v| cfg.only = v.split(',').map(|s| s.trim().to_string()).collect()),
            other => Err(format!("unknown option `{other}`")),
        };
        if let Err(e) = res {
            eprintln!("fissure bench: {e}\n\n{USAGE}");
            return ExitCode::from(2);
        }
    }
    match harness::run(&cfg) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => {
            eprintln!("fissure bench: some checks failed (see above and {}/REPORT.md)", cfg.out.display());
            ExitCode::from(1)
        }
        Err(e) => {
            eprintln!("fissure bench: {e}");
            ExitCode::from(2)
        }
    }
}
