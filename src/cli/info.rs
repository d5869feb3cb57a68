//! `steernav info`: the GPU adapter, its limits, and what `--backend auto` would choose.

use std::process::ExitCode;

pub fn run() -> anyhow::Result<ExitCode> {
    println!("steernav {}", env!("CARGO_PKG_VERSION"));
    println!("cpu threads: {}", rayon::current_num_threads());
    match steernav::GpuContext::shared() {
        Ok(ctx) => {
            println!("{}", ctx.describe());
            match ctx.auto_refusal() {
                None => println!("--backend auto: this GPU (a hardware adapter)"),
                Some(reason) => println!(
                    "--backend auto: the CPU path, because {reason}; --backend gpu still uses it"
                ),
            }
            Ok(ExitCode::SUCCESS)
        }
        Err(e) => {
            println!("gpu: none ({e}); --backend auto will use the CPU");
            Ok(if steernav::low_level::gpu::gpu_required() {
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            })
        }
    }
}
