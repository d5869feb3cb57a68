//! `steernav eval homography`: img1 against img2..img6 of Oxford-layout sequences, with the
//! matching metrics (MMA, correct matches, homography accuracy) beside repeatability.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Args;
use steernav::eval::matching::{self, PairMatching};
use steernav::eval::sweep::homography_sequence;
use steernav::output::write_atomic;

use super::{report, EvalArgs};
use crate::args::stem;

#[derive(Args)]
pub struct HomographyCmd {
    /// Sequence directories (img1..img6 as PPM/PGM/PNG, H1to2p..H1to6p).
    #[arg(required = true, value_name = "DIR")]
    sequences: Vec<PathBuf>,
    /// Directory receiving <sequence>.csv and <sequence>.png.
    #[arg(long, default_value = "eval-out", value_name = "DIR")]
    out: PathBuf,
    #[command(flatten)]
    eval: EvalArgs,
}

pub fn run(cmd: HomographyCmd) -> anyhow::Result<ExitCode> {
    let setup = cmd.eval.setup()?;
    let mut all_matching = Vec::new();
    for dir in &cmd.sequences {
        let (rows, matching) =
            homography_sequence(dir, setup.steernav.as_ref(), setup.peers(), &setup.options)?;
        let name = stem(dir);
        println!("== {}", dir.display());
        report(
            &rows,
            Some(&cmd.out.join(format!("{name}.csv"))),
            Some(&cmd.out.join(format!("{name}.png"))),
            &name,
            "image N (img1 against imgN)",
            "image",
        )?;
        report_matching(&matching, &cmd.out, &name)?;
        all_matching.extend(matching);
    }
    if cmd.sequences.len() > 1 {
        println!("== all sequences");
        report_matching(&all_matching, &cmd.out, "all")?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Prints the matching summary and writes `<name>_matching.csv` and `<name>_mma.png`.
fn report_matching(rows: &[PairMatching], out: &Path, name: &str) -> anyhow::Result<()> {
    let summaries = matching::summarize(rows);
    print!("{}", matching::summary_table(&summaries));
    let csv = out.join(format!("{name}_matching.csv"));
    write_atomic(&csv, matching::to_csv(rows).as_bytes())?;
    eprintln!("wrote {}", csv.display());
    let png = out.join(format!("{name}_mma.png"));
    steernav::eval::figure::mma_figure(
        &png,
        &summaries,
        &format!("{name}: mean matching accuracy"),
    )?;
    eprintln!("wrote {}", png.display());
    Ok(())
}
