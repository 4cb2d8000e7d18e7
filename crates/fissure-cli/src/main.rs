//! `fissure`: the command-line program.
//!
//! ```text
//! fissure bench [--quick] [--out DIR] [--results FILE] [--only SECTION[,SECTION…]] [--no-gpu]
//! ```
//!
//! `bench` runs the accuracy, stability and speed harness (see the `harness` module): CSVs, PNG plots and a
//! Markdown report in `--out` (default `target/fissure-bench`), and with `--results` the report spliced into that
//! file between the harness markers. `FISSURE_BENCH_QUICK=1` (or `--quick`) runs the reduced sizes CI uses. The
//! exit status is 1 when a correctness check fails, 2 on a usage or I/O error.

mod harness;
mod plot;

use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "\
usage: fissure bench [--quick] [--out DIR] [--results FILE] [--only SECTION[,SECTION...]] [--no-gpu]

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
