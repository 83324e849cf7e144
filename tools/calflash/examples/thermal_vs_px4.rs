//! The continuous temperature model against PX4's per-axis cubic bias, on simulated ramps with
//! known truth (`calflash::sim::px4`): RMS error of the corrected input on held-out
//! temperatures, averaged over seeds.
//!
//! `cargo run --release -p calflash --example thermal_vs_px4 -- [SEEDS] [MODEL] [no-asymmetry]`:
//! with a MODEL (say `"output ~ 1 + input"`), calflash fits that instead of its preset; with
//! `no-asymmetry` it leaves the asymmetric scale out instead of testing for it (PX4's model
//! class exactly, with the model `output ~ 1 + input`).

use calflash::sim::px4;

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(50);
    let model = std::env::args().nth(2).filter(|m| m != "no-asymmetry");
    let no_asymmetry = std::env::args().any(|a| a == "no-asymmetry");
    let told = px4::Told {
        model: model.as_deref(),
        no_asymmetry,
    };
    let dir = std::env::temp_dir().join(format!("thermal_vs_px4-{}", std::process::id()));
    if let Err(e) = std::fs::create_dir_all(&dir) {
        eprintln!("{}: {e}", dir.display());
        std::process::exit(1);
    }
    println!(
        "RMS error of the corrected input on held-out temperatures, mm/s^2, {seeds} seeds, calflash fitting {}{}",
        model.as_deref().unwrap_or("its preset"),
        if no_asymmetry {
            ", no asymmetric scale"
        } else {
            ""
        }
    );
    println!();
    println!("| scenario | calflash (model) | calflash (device) | PX4 cubic | device / PX4 |");
    println!("|---|---:|---:|---:|---:|");
    for s in px4::scenarios() {
        let mut sum = [0.0f64; 3];
        for seed in 1..=seeds {
            match px4::run(&s, seed, &dir, told) {
                Ok(e) => {
                    for (a, v) in sum.iter_mut().zip([e.model, e.device, e.px4]) {
                        *a += v * v;
                    }
                }
                Err(e) => {
                    eprintln!("{} seed {seed}: {e}", s.name);
                    std::process::exit(1);
                }
            }
        }
        let rms = sum.map(|v| (v / seeds as f64).sqrt() * 1e3);
        println!(
            "| {} | {:.3} | {:.3} | {:.3} | {:.2} |",
            s.name,
            rms[0],
            rms[1],
            rms[2],
            rms[1] / rms[2]
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
