//! `calflash simulate --stages DIR`: two stages from one truth. Each of the six sensors goes
//! through its stage-one plan on its own fixture (`DIR/a_x.csv` ... `DIR/g_z.csv`, single-axis
//! observations at `--temps`); the unit they are assembled into goes through `--plan` at
//! `--assembly-temp` (`-o`).

use std::path::Path;

use super::SimulateArgs;
use crate::cmd::Failure;
use crate::files::Staged;
use crate::sensor::stages::one::OUTPUTS;
use crate::sim::plan;
use crate::sim::stages::AssembledTruth;

/// The accelerometers' stage-one plan when `--stage-one-plan` gives none: a dividing head of
/// 56 angles.
pub const DEFAULT_ACCEL_STAGE_ONE: [&str; 1] = ["head:56"];
/// The gyros': 41 rates from -8 to 8 rad/s and 15 at rest.
pub const DEFAULT_GYRO_STAGE_ONE: [&str; 2] = ["rate:-8:8:41", "rate:0:0:15"];

/// `--assembly-shift`: `OUTPUT=RELATIVE` pairs, the scale factors assembly changes.
fn shifts(items: &[String]) -> Result<[f64; 6], Failure> {
    let mut out = [0.0; 6];
    for item in items {
        let (name, value) = item.split_once('=').ok_or_else(|| {
            format!("--assembly-shift `{item}`: OUTPUT=RELATIVE is expected, e.g. a_y=7.5e-4")
        })?;
        let k = OUTPUTS
            .iter()
            .position(|o| *o == name.trim())
            .ok_or_else(|| {
                format!(
                    "--assembly-shift `{item}`: `{name}` is not an output ({})",
                    OUTPUTS.join(", ")
                )
            })?;
        let v: f64 = value
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite() && v.abs() < 0.5)
            .ok_or_else(|| {
                format!("--assembly-shift `{item}`: `{value}` is not a relative change below 0.5")
            })?;
        out[k] = v;
    }
    Ok(out)
}

/// Runs `simulate --stages DIR`.
///
/// # Errors
/// A plan, a truth or a shift that cannot be read; a file that cannot be written.
pub fn run(args: &SimulateArgs, dir: &Path) -> Result<(), Failure> {
    // Stage one's six files are outputs too: none may be -o, --write-truth or --truth.
    let files: Vec<(String, std::path::PathBuf)> = OUTPUTS
        .iter()
        .map(|o| {
            (
                format!("--stages (its {o}.csv)"),
                dir.join(format!("{o}.csv")),
            )
        })
        .collect();
    let mut paths = crate::files::Paths::new().input("--truth", args.truth.as_deref());
    for (what, path) in &files {
        paths = paths.created(what, Some(path));
    }
    paths
        .created("-o", Some(&args.output))
        .created("--write-truth", args.write_truth.as_deref())
        .check()?;
    let mut truth = match &args.truth {
        Some(p) => {
            let text = crate::files::read_json_text(p, "an assembled unit's truth")?;
            serde_json::from_str::<AssembledTruth>(&text)
                .map_err(|e| format!("{}:{}:{}: {e}", p.display(), e.line(), e.column()))?
        }
        None => AssembledTruth::draw(args.seed),
    };
    if truth.sensors.len() != 6 {
        return Err(format!(
            "--truth: an assembled unit has six sensors (a_x a_y a_z g_x g_y g_z); this one has {}",
            truth.sensors.len()
        )
        .into());
    }
    for (k, s) in shifts(&args.assembly_shift)?.iter().enumerate() {
        if *s != 0.0 {
            truth.scale_change[k] = *s;
        }
    }
    let items = |default: &[&str]| -> Vec<String> {
        if args.stage_one_plan.is_empty() {
            default.iter().map(|s| s.to_string()).collect()
        } else {
            args.stage_one_plan.clone()
        }
    };
    let plans = [
        plan::plan(
            &items(&DEFAULT_ACCEL_STAGE_ONE),
            &args.temps,
            &args.volts,
            args.repeat,
            true,
        )?,
        plan::plan(
            &items(&DEFAULT_GYRO_STAGE_ONE),
            &args.temps,
            &args.volts,
            args.repeat,
            true,
        )?,
    ];
    let two = plan::plan(
        &args.plan,
        &[args.assembly_temp],
        &args.volts,
        args.repeat,
        false,
    )?;
    if dir.exists() && !dir.is_dir() {
        return Err(format!(
            "--stages {}: that is a file; give the directory the six stage-one files go into (it is made when missing)",
            dir.display()
        )
        .into());
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| format!("--stages {}: cannot make the directory: {e}", dir.display()))?;
    let mut staged = Staged::new();
    let mut said = Vec::new();
    for (k, output) in OUTPUTS.iter().enumerate() {
        let one = &plans[usize::from(k >= 3)];
        let mut obs = truth.stage_one(k, one, args.seed.wrapping_mul(10).wrapping_add(k as u64));
        obs.saturate(args.codes);
        let path = dir.join(format!("{output}.csv"));
        staged.write(&path, |w| obs.write_csv(w))?;
        said.push(format!(
            "  stage one, {output}: {} observations in {}",
            obs.rows.len(),
            path.display()
        ));
    }
    let mut obs = truth.stage_two(&two, args.seed.wrapping_add(7));
    let saturated = obs.saturate(args.codes);
    staged.write(&args.output, |w| obs.write_csv(w))?;
    if let Some(p) = &args.write_truth {
        let json = serde_json::to_string_pretty(&truth)?;
        staged.write(p, |w| w.write_all(json.as_bytes()))?;
    }
    staged.commit()?;
    println!("calflash simulate: two stages of one assembled unit");
    for line in said {
        println!("{line}");
    }
    println!(
        "  stage two, the assembled unit at {} C: {} observations in {}",
        args.assembly_temp,
        obs.rows.len(),
        args.output.display()
    );
    if saturated > 0 {
        println!("  {saturated} output(s) of the unit saturated at the converter's rails");
    }
    Ok(())
}
