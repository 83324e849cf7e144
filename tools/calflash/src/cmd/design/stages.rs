//! `calflash design evaluate --stage-one ITEMS`: a two-stage plan against one stage's.
//!
//! Stage one puts each sensor alone through ITEMS and fits its own polynomial (bias, scale
//! factor, g-squared, cubic, odd-quadratic and asymmetry: `output ~ 1 + input + input^2 +
//! input^3 + input:abs(input) + abs(input)`); stage two puts the assembled unit through the
//! first `--plan` and, with the bias and scale factor held from stage one, fits each axis'
//! misalignment (`~ 0 + the two cross inputs`). One stage fits every term of each axis at once
//! on each further `--plan` (the `triad-nonlinear` preset with the asymmetry term). Per axis:
//! the prediction variance over the operating region (in output-noise units, one reading per
//! observation) of each, the collinearity of each fit (largest VIF, condition number), and the
//! ratio of the RMS prediction errors at equal total observations. With several `--temps`,
//! stage one and one stage run at each, stage two once: the plans are evaluated at one
//! temperature and the totals count them so. Stage one's error reaching stage two's
//! misalignment through the readings is left out (a second-order effect), and so is a model's
//! bias: a one-stage model without the asymmetry term (the triad workflow's) is biased by it,
//! which only the Monte Carlo of `tests/two_stage.rs` shows.

use crate::cmd::Failure;
use crate::design::criteria::{self, Criteria};
use crate::design::points::{self, Points, Unit};
use crate::design::space;
use crate::formula::{self, Formula};

use super::EvaluateArgs;

use crate::design::stages::STAGE_ONE_MODEL as STAGE_ONE;

fn largest_vif(c: &Criteria) -> f64 {
    c.vif.iter().flatten().copied().fold(0.0, f64::max)
}

fn quad(phi: &[f64], c: &nalgebra::DMatrix<f64>) -> f64 {
    (0..phi.len())
        .flat_map(|a| (0..phi.len()).map(move |b| (a, b)))
        .map(|(a, b)| phi[a] * c[(a, b)] * phi[b])
        .sum()
}

fn evaluated(x: &nalgebra::DMatrix<f64>, what: &str) -> Result<Criteria, Failure> {
    criteria::evaluate(x, x, true).map_err(|d| {
        format!(
            "{what}: the model is not estimable on this plan (column {} depends on the others)",
            d.column + 1
        )
        .into()
    })
}

/// Runs the comparison.
///
/// # Errors
/// A plan that cannot be read or does not estimate its model; a sensor that is not a triad.
pub(super) fn run(a: &EvaluateArgs, stage_one: &[String]) -> Result<(), Failure> {
    let gyro = match a.model.sensor {
        crate::cmd::values::SensorKind::Accel | crate::cmd::values::SensorKind::Imu => false,
        crate::cmd::values::SensorKind::Gyro => true,
        _ => {
            return Err("--stage-one: two stages are compared for a triad (--sensor accel or gyro), whose axes are calibrated alone first".into());
        }
    };
    let [unit_plan, one_stage @ ..] = a.plan.as_slice() else {
        return Err("--stage-one: give the assembled unit's plan as the first --plan".into());
    };
    if one_stage.is_empty() {
        return Err("--stage-one: give one-stage plans to compare as further --plan".into());
    }
    if a.json.is_some() || a.report.is_some() || a.curve.is_some() {
        return Err("--stage-one: the comparison is printed; --json, --report and --curve are for one-stage plans".into());
    }
    let space = a.model.space()?;
    // Stage one runs at every temperature, stage two once: each plan is evaluated at one
    // temperature, the totals count stage one and one stage `t` times.
    let t = a.model.temps.len();
    let (temps, volts) = (&a.model.temps[..1], &a.model.volts);
    let single = if gyro {
        Unit::SingleGyro
    } else {
        Unit::SingleAccel
    };
    let one = points::from_items(stage_one, temps, volts, 1, single)?;
    let load = |spec: &str| -> Result<Points, Failure> {
        let items: Vec<String> = spec.split(',').map(|s| s.trim().to_string()).collect();
        Ok(points::from_items(&items, temps, volts, 1, Unit::Triad)?)
    };
    let unit = load(unit_plan)?;
    let others: Vec<(String, Points)> = one_stage
        .iter()
        .map(|s| load(s).map(|p| (s.clone(), p)))
        .collect::<Result<_, _>>()?;
    let inputs = if gyro {
        ["w_x", "w_y", "w_z"]
    } else {
        ["f_x", "f_y", "f_z"]
    };
    let vars: Vec<String> = crate::columns::F
        .iter()
        .chain(&crate::columns::W)
        .map(|s| s.to_string())
        .collect();
    let region = if space.region.is_empty() {
        space::union(
            std::iter::once(&unit).chain(others.iter().map(|(_, p)| p)),
            &vars,
        )
    } else {
        space::grids(&space.region)?
    };
    let f1 = formula::parse(STAGE_ONE)?;
    let c1 = evaluated(&one.model_rows(&f1), "stage one")?;
    let (n1, n2) = (one.rows.len(), unit.rows.len());
    println!(
        "calflash design evaluate: two stages against one, {} triad, over {} points of the operating region (variances in output-noise units, one reading per observation)",
        if gyro { "a gyro" } else { "an accelerometer" },
        region.rows.len()
    );
    println!(
        "  stage one: {} ({n1} observations per sensor at each of {t} temperature(s)), model {STAGE_ONE}: largest VIF {:.1}, condition number {:.3e}",
        stage_one.join(","),
        largest_vif(&c1),
        c1.condition_number
    );
    println!("  stage two: {unit_plan} ({n2} observations, once)");
    for i in 0..3 {
        let cross: Vec<&str> = (0..3).filter(|j| *j != i).map(|j| inputs[j]).collect();
        let f2 = formula::parse(&format!("y ~ 0 + {} + {}", cross[0], cross[1]))?;
        let c2 = evaluated(
            &unit.model_rows(&f2),
            &format!("stage two, axis {}", inputs[i]),
        )?;
        // Each region point through both stages' models: stage one's at the axis' own input,
        // stage two's at the cross inputs.
        let along = Points {
            names: vec!["input".into()],
            rows: (0..region.rows.len())
                .map(|r| vec![region.value(r, inputs[i])])
                .collect(),
        };
        let (x1, x2) = (along.model_rows(&f1), region.model_rows(&f2));
        let row = |x: &nalgebra::DMatrix<f64>, r: usize| -> Vec<f64> {
            x.row(r).iter().copied().collect()
        };
        let two: f64 = (0..region.rows.len())
            .map(|r| {
                quad(&row(&x1, r), &c1.unscaled_covariance)
                    + quad(&row(&x2, r), &c2.unscaled_covariance)
            })
            .sum::<f64>()
            / region.rows.len() as f64;
        let n_two = t * n1 + n2;
        println!(
            "  axis {}: two stages: mean prediction variance {two:.4e} ({n_two} observations per sensor); stage two's misalignment fit: largest VIF {:.1}, condition number {:.3e}",
            inputs[i],
            largest_vif(&c2),
            c2.condition_number
        );
        for (name, pts) in &others {
            let sensed = inputs[i];
            let fo = onestage_formula(i, inputs, sensed)?;
            let x = pts.model_rows(&fo);
            let reg = region.model_rows(&fo);
            let c = criteria::evaluate(&x, &reg, true).map_err(|d| {
                format!(
                    "one stage {name}, axis {}: {}",
                    inputs[i],
                    fo.explain_rank_deficiency(
                        &space::to_table(pts, &fo),
                        d.column,
                        &d.combination
                    )
                )
            })?;
            let n = pts.rows.len();
            // The I criterion is n times the mean prediction variance; at equal totals one
            // stage has n_two / t observations at each temperature.
            let ratio = (two * n_two as f64 / (c.i * t as f64)).sqrt();
            println!(
                "    one stage {name} ({n} observations at each temperature): mean prediction variance {:.4e}, largest VIF {:.1}, condition number {:.3e}; RMS error of two stages against one at equal totals: {ratio:.3} (these models' variance alone; the calibrated comparison below is the error to expect)",
                c.i / n as f64,
                largest_vif(&c),
                c.condition_number
            );
        }
    }
    calibrated_comparison(a, &space, stage_one, unit_plan, one_stage, gyro)
}

/// Both plans through simulated units and the calibrations themselves
/// ([`crate::design::stages`]): each plan's stated error over the operating range, the ratio as
/// given and at equal cost, and which plan wins.
fn calibrated_comparison(
    a: &EvaluateArgs,
    space: &space::Space,
    stage_one: &[String],
    unit_plan: &str,
    one_stage: &[String],
    gyro: bool,
) -> Result<(), Failure> {
    use crate::design::stages::{self, Costs, Plans};
    let temps = &a.model.temps;
    let plan = |items: &[String], temps: &[f64], single: bool| {
        crate::sim::plan::plan(items, temps, &[3.3], 1, single)
            .map_err(|e| Failure::from(e.to_string()))
    };
    let split =
        |spec: &str| -> Vec<String> { spec.split(',').map(|s| s.trim().to_string()).collect() };
    let other = other_stage_one(gyro, &a.stage_one_other);
    let (accel_items, gyro_items): (&[String], &[String]) = if gyro {
        (&other, stage_one)
    } else {
        (stage_one, &other)
    };
    let costs = Costs {
        stage_one: a.cost_stage_one,
        unit: a.cost_unit,
    };
    println!(
        "  calibrated: {UNITS} simulated units (our simulator's sensors: 400 counts per m/s^2, 900 per rad/s, 2 counts of noise, with the terms both models carry) through both plans, each calibration made as `calibrate` makes it; its stated 1-sigma over the range below (the operating range, or the mission's moments the plans reach with --mission). Stage one: accelerometers {}, gyros {}; costs an observation: a sensor on its fixture {}, the unit {}",
        accel_items.join(","),
        gyro_items.join(","),
        costs.stage_one,
        costs.unit
    );
    let (accel_one, gyro_one) = (
        plan(accel_items, temps, true)?,
        plan(gyro_items, temps, true)?,
    );
    let unit = plan(&split(unit_plan), &temps[..1], false)?;
    for name in one_stage {
        let p = Plans {
            accel_one: accel_one.clone(),
            gyro_one: gyro_one.clone(),
            unit: unit.clone(),
            one_stage: plan(&split(name), temps, false)?,
        };
        let range = match &space.mission {
            Some(profile) => stages::mission_range(profile, &p, temps),
            None => stages::operating_range(&p, temps),
        }
        .map_err(|e| Failure::from(e.to_string()))?;
        println!("    one stage {name}: over {}", range.what);
        let pred = stages::predict(&p, &range, UNITS).map_err(|e| Failure::from(e.to_string()))?;
        let (c2, c1) = costs.of(&p);
        for (family, f, unit) in [("accelerometers", 0, "m/s^2"), ("gyros", 1, "rad/s")] {
            let ratio = pred.ratio()[f];
            let equal = costs.at_equal_cost(&p, ratio);
            let winner = if equal < 1.0 {
                "two stages win"
            } else {
                "one stage wins"
            };
            println!(
                "    one stage {name}, {family}: two stages {:.3e} {unit}, one stage {:.3e} (two/one {ratio:.3}); cost a unit {} against {}; at equal cost two/one {equal:.3}: {winner}",
                pred.two[f],
                pred.one[f],
                crate::report::terminal::num(c2),
                crate::report::terminal::num(c1)
            );
        }
    }
    Ok(())
}

/// The other family's stage one: `given`, or by default the gyros on a rate table (+-8 rad/s,
/// four times, and still) or the accelerometers on a dividing head (56 angles).
pub(super) fn other_stage_one(gyro: bool, given: &[String]) -> Vec<String> {
    if !given.is_empty() {
        return given.to_vec();
    }
    if gyro {
        return vec!["head:56".into()];
    }
    let rate = "rate:-8:8:9".to_string();
    vec![
        rate.clone(),
        rate.clone(),
        rate.clone(),
        rate,
        "rate:0:0:20".into(),
    ]
}

/// Simulated units in the calibrated comparison.
pub(super) const UNITS: u64 = 24;

/// One stage's model of axis `i`: bias, the three inputs, and the own-axis g-squared, cubic,
/// odd-quadratic and asymmetry terms (on the own input: misalignment is small).
fn onestage_formula(i: usize, inputs: [&str; 3], own: &str) -> Result<Formula, Failure> {
    Ok(formula::parse(&format!(
        "y ~ 1 + {} + {} + {} + {own}^2 + {own}^3 + {own}:abs({own}) + abs({own})",
        inputs[0], inputs[1], inputs[2]
    ))
    .map_err(|e| format!("axis {i}: {e}"))?)
}
