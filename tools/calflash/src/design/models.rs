//! The models a plan is designed for: any formula, or a sensor preset expanded to one formula
//! per output (the three axes of a triad share their points but not all their terms).

use super::Error;
use crate::columns as col;
use crate::formula::{self, Formula};

/// The presets, for messages.
pub const PRESETS: &str = "single (IEEE 1293 single axis: 1 + input + input^2 + input^3 + input:abs(input)), \
triad (per axis: 1 + x + y + z inputs), triad-nonlinear (+ own^2 + own^3 + own:abs(own)), \
gyro-gsens (gyro triad + f_x + f_y + f_z), \
accel-lever (accelerometer triad + lever_ix + lever_iy + lever_iz, the spin-rig model)";

/// One model to design for.
#[derive(Debug, Clone)]
pub struct Block {
    /// What it is (`x`, `y`, `z` for a triad's axes, else the response).
    pub label: String,
    /// The formula.
    pub formula: Formula,
}

/// Expands `model` (a formula, `~ ...` without a response, or a preset) for a unit whose
/// triad inputs are the rates (`gyro`) or the specific forces.
///
/// # Errors
/// A formula that does not parse, naming where.
pub fn blocks(model: &str, gyro: bool) -> Result<Vec<Block>, Error> {
    let inputs = if gyro { col::W } else { col::F };
    let triad = |extra: &dyn Fn(usize) -> String| -> Result<Vec<Block>, Error> {
        (0..3)
            .map(|i| {
                let text = format!(
                    "out_{} ~ 1 + {} + {} + {}{}",
                    ["x", "y", "z"][i],
                    inputs[0],
                    inputs[1],
                    inputs[2],
                    extra(i)
                );
                Ok(Block {
                    label: ["x", "y", "z"][i].to_string(),
                    formula: formula::parse(&text)?,
                })
            })
            .collect()
    };
    match model.trim() {
        "single" => {
            let f = formula::parse("output ~ 1 + input + input^2 + input^3 + input:abs(input)")?;
            Ok(vec![Block {
                label: "output".into(),
                formula: f,
            }])
        }
        "triad" => triad(&|_| String::new()),
        "triad-nonlinear" => triad(&|i| format!(" + {0}^2 + {0}^3 + {0}:abs({0})", inputs[i])),
        "accel-lever" => {
            if gyro {
                return Err(Error::PresetForOtherSensor {
                    preset: "accel-lever",
                    what: "lever-arm",
                    sensor: "an accelerometer triad (--sensor accel or imu)",
                });
            }
            triad(&|i| {
                let a = ["x", "y", "z"][i];
                format!(" + lever_{a}x + lever_{a}y + lever_{a}z")
            })
        }
        "gyro-gsens" => {
            if !gyro {
                return Err(Error::PresetForOtherSensor {
                    preset: "gyro-gsens",
                    what: "g-sensitivity",
                    sensor: "a gyro triad (--sensor gyro)",
                });
            }
            triad(&|_| format!(" + {} + {} + {}", col::F[0], col::F[1], col::F[2]))
        }
        text => {
            let full = if text.starts_with('~') {
                format!("response {text}")
            } else {
                text.to_string()
            };
            let f = formula::parse(&full).map_err(|source| Error::Model {
                source,
                presets: PRESETS,
            })?;
            Ok(vec![Block {
                label: f.response.clone(),
                formula: f,
            }])
        }
    }
}

/// The variables the blocks read (no responses), in order of appearance.
#[must_use]
pub fn variables(blocks: &[Block]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for b in blocks {
        for v in b.formula.columns().into_iter().skip(1) {
            if !out.contains(&v) {
                out.push(v);
            }
        }
    }
    out
}

/// True when a block has lever-arm terms (`lever_ik`, the spin-rig model).
#[must_use]
pub fn has_lever(blocks: &[Block]) -> bool {
    blocks.iter().any(|b| {
        b.formula
            .terms
            .iter()
            .any(|t| t.name().starts_with("lever_"))
    })
}

/// The lever-arm components a plan's rates and angular accelerations estimate
/// (`sensor::lever::estimable`), and the blocks without the others.
#[must_use]
pub fn lever_blocks(blocks: &[Block], pts: &super::points::Points) -> (Vec<Block>, [[bool; 3]; 3]) {
    let motion = (0..pts.rows.len()).map(|r| {
        (
            col::W.map(|n| pts.value(r, n)),
            col::DW.map(|n| pts.value(r, n)),
        )
    });
    let estimable = crate::sensor::lever::estimable(motion);
    let reduced = blocks
        .iter()
        .map(|b| {
            let mut f = b.formula.clone();
            for (i, row) in estimable.iter().enumerate() {
                for (k, ok) in row.iter().enumerate() {
                    let name = crate::sensor::lever::column(i, k);
                    if !ok && f.terms.iter().any(|t| t.name() == name) {
                        f = f.without(&name);
                    }
                }
            }
            Block {
                label: b.label.clone(),
                formula: f,
            }
        })
        .collect();
    (reduced, estimable)
}
