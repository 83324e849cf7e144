//! The Ferraris session (Ferraris et al. 1995, as imucal takes it): the unit held still on its
//! six faces (each axis up, then down) and turned once about each axis by a known angle, each
//! section annotated by sample. The faces give the accelerometer's full matrix in the box's
//! frame, and the turns the gyro's; both are brought into the accelerometer's frame (the QR
//! factor of the box-frame matrix), then refined on every still pose the recording holds:
//! `|a| = g` at each for the accelerometer's scales and offsets (its cross-axis terms held by
//! the faces, which `|a| = g` on six axis-aligned faces cannot see), and for the gyro the
//! gravity directions across the turns between poses with the known turns (a session cut short
//! may lack some: the rotations between poses then give those axes' scales).

use std::ops::Range;

use nalgebra::{Matrix3, Vector3};

use super::super::gravity::{self, AccelFit};
use super::super::rotation::KnownTurn;
use super::super::statics;
use super::SelfCalError;
use crate::obs::recording::Recording;

/// The section names of imucal's list, in order: faces `x_p, x_a, y_p, y_a, z_p, z_a` (axis up,
/// axis down), turns `x_rot, y_rot, z_rot`.
pub const NAMES: [&str; 9] = [
    "x_p", "x_a", "y_p", "y_a", "z_p", "z_a", "x_rot", "y_rot", "z_rot",
];

/// An annotated session: sample ranges (rows of the recording, from 0) and the turns' angle.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Sections {
    /// The six faces, in the order of [`NAMES`].
    pub faces: [Range<usize>; 6],
    /// The turns about x, y, z: each may be absent (a session cut short), when the rotations
    /// between poses must give that axis' scale.
    pub turns: [Option<Range<usize>>; 3],
    /// The angle of each turn about its axis, degrees (imucal's default: -360).
    pub angle_deg: f64,
}

impl Sections {
    /// Reads imucal's section list (`{"x_p": {"start": 540, "end": 1271}, ...}`) from `text`
    /// (named `file` in errors), for a recording of `rows` samples.
    ///
    /// # Errors
    /// A face missing, a section without a `start` below its `end`, or past the recording.
    pub fn parse(text: &str, file: &str, rows: usize, angle_deg: f64) -> Result<Self, String> {
        let v: serde_json::Value = serde_json::from_str(text)
            .map_err(|e| format!("{file}: line {}, column {}: {e}", e.line(), e.column()))?;
        let range = |name: &str| -> Result<Range<usize>, String> {
            let s = &v[name];
            let n = |k: &str| {
                s[k].as_u64().ok_or_else(|| {
                    format!(
                        "{file}: section {name:?} needs \"{k}\", a sample index (imucal's list: \
                         {{\"x_p\": {{\"start\": 540, \"end\": 1271}}, ...}} for {})",
                        NAMES.join(", ")
                    )
                })
            };
            let (a, b) = (n("start")? as usize, n("end")? as usize);
            if a >= b || b > rows {
                return Err(format!(
                    "{file}: section {name:?} runs {a} to {b}: expected a start below its end, \
                     within the recording's {rows} samples"
                ));
            }
            Ok(a..b)
        };
        let turn = |name: &str| -> Result<Option<Range<usize>>, String> {
            if v.get(name).is_some() {
                range(name).map(Some)
            } else {
                Ok(None)
            }
        };
        Ok(Self {
            faces: [
                range("x_p")?,
                range("x_a")?,
                range("y_p")?,
                range("y_a")?,
                range("z_p")?,
                range("z_a")?,
            ],
            turns: [turn("x_rot")?, turn("y_rot")?, turn("z_rot")?],
            angle_deg,
        })
    }
}

/// The faces' closed form: the accelerometer's matrix and bias in the box's frame (counts per
/// m/s^2 inverted), its QR factors `Q` (the box frame from the accelerometer's) and `U` (upper
/// triangular, the accelerometer's frame), and the bias (counts).
struct Faces {
    q: Matrix3<f64>,
    u: Matrix3<f64>,
    bias: Vector3<f64>,
}

fn faces(rec: &Recording, s: &Sections, g: f64) -> Option<Faces> {
    let m: Vec<Vector3<f64>> = s
        .faces
        .iter()
        .map(|r| Vector3::from(statics::mean(&rec.acc, r)))
        .collect();
    // raw = A f + b: the column of A for axis i is (up - down) / 2g.
    let a = Matrix3::from_columns(&[
        (m[0] - m[1]) / (2.0 * g),
        (m[2] - m[3]) / (2.0 * g),
        (m[4] - m[5]) / (2.0 * g),
    ]);
    let bias = m.iter().sum::<Vector3<f64>>() / 6.0;
    let boxed = a.try_inverse()?;
    let qr = boxed.qr();
    let (mut q, mut u) = (qr.q(), qr.r());
    // Positive scales: flip the signs of a row of U and the column of Q together.
    for i in 0..3 {
        if u[(i, i)] < 0.0 {
            u.row_mut(i).neg_mut();
            q.column_mut(i).neg_mut();
        }
    }
    Some(Faces { q, u, bias })
}

/// How much a cross-axis term of the faces' matrix weighs against `|a| - g` at a pose: a
/// change `d` shows at a face as a force error of `g d` across it.
fn cross_weight(g: f64) -> f64 {
    g
}

/// The accelerometer of a Ferraris session: the faces' matrix in the accelerometer's frame,
/// then its scales and offsets fitted to `|a| = g` at the poses `means` (the faces' cross-axis
/// terms held); the box frame's rotation `Q` from the accelerometer's.
///
/// # Errors
/// Faces that do not span three axes, or a fit that does not converge.
pub(super) fn accel(
    rec: &Recording,
    s: &Sections,
    means: &[[f64; 3]],
    g: f64,
) -> Result<(AccelFit, Matrix3<f64>), SelfCalError> {
    let source = rec.source.as_str();
    let f = faces(rec, s, g).ok_or_else(|| SelfCalError::Faces {
        file: source.into(),
        why: "their matrix is singular".into(),
    })?;
    let center: [f64; 3] = std::array::from_fn(|j| f.bias[j].round());
    let o = -(f.u * (f.bias - Vector3::from(center)));
    let start = [
        f.u[(0, 0)],
        f.u[(0, 1)],
        f.u[(0, 2)],
        f.u[(1, 1)],
        f.u[(1, 2)],
        f.u[(2, 2)],
        o[0],
        o[1],
        o[2],
    ];
    let fit = gravity::fit_held_cross(means, g, center, &start, cross_weight(g))
        .map_err(super::fit_err(source, "accelerometer"))?;
    Ok((fit, f.q))
}

/// The three turns as the gyro fit takes them: the gyro's counts less `bias` over each, and the
/// rotation vector it must integrate to in the accelerometer's frame (`angle` about the box's
/// axis, `Q^T e_i`).
pub(super) fn known_turns(
    rec: &Recording,
    s: &Sections,
    q: &Matrix3<f64>,
    bias: [f64; 3],
) -> Vec<KnownTurn> {
    let angle = s.angle_deg.to_radians();
    s.turns
        .iter()
        .enumerate()
        .filter_map(|(i, r)| r.as_ref().map(|r| (i, r)))
        .map(|(i, r)| {
            let axis = q.transpose() * Vector3::ith(i, 1.0);
            KnownTurn {
                dt: rec.t[r.clone()].windows(2).map(|w| w[1] - w[0]).collect(),
                x: rec.gyro[r.clone()]
                    .iter()
                    .map(|x| std::array::from_fn(|j| x[j] - bias[j]))
                    .collect(),
                angle: (axis * angle).into(),
            }
        })
        .collect()
}

/// The gyro's closed form: each turn's integrated counts are its column in the box frame over
/// the angle; inverted and brought into the accelerometer's frame. `None` without all three
/// turns.
pub(super) fn gyro_start(
    turns: &[KnownTurn],
    angle_deg: f64,
    q: &Matrix3<f64>,
) -> Option<[[f64; 3]; 3]> {
    if turns.len() != 3 {
        return None;
    }
    let angle = angle_deg.to_radians();
    let col = |t: &KnownTurn| -> Vector3<f64> {
        let sum =
            t.x.windows(2)
                .zip(&t.dt)
                .fold(Vector3::zeros(), |s, (w, dt)| {
                    s + (Vector3::from(w[0]) + Vector3::from(w[1])) * (0.5 * dt)
                });
        sum / angle
    };
    let a = Matrix3::from_columns(&[col(&turns[0]), col(&turns[1]), col(&turns[2])]);
    let m = q.transpose() * a.try_inverse()?;
    Some(std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)])))
}

/// The poses for the gyro's gravity directions when the still test found too few for an
/// accelerometer fit of its own: the six faces.
#[must_use]
pub(super) fn face_poses(s: &Sections) -> Vec<Range<usize>> {
    let mut p = s.faces.to_vec();
    p.sort_by_key(|r| r.start);
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    /// imucal's list is read; a missing section or one past the recording is named.
    #[test]
    fn the_section_list_is_read_and_its_faults_named() {
        let list = r#"{"x_p":{"start":540,"end":1271},"x_a":{"start":1620,"end":2361},
            "y_p":{"start":2814,"end":3298},"y_a":{"start":3740,"end":4152},
            "z_p":{"start":4522,"end":4975},"z_a":{"start":5376,"end":5983},
            "x_rot":{"start":6770,"end":7093},"y_rot":{"start":8081,"end":8405},
            "z_rot":{"start":9205,"end":9512}}"#;
        let s = Sections::parse(list, "l.json", 10_376, -360.0).unwrap();
        assert_eq!(s.faces[0], 540..1271);
        assert_eq!(s.turns[2], Some(9205..9512));
        let cut = Sections::parse(
            &list.replace(r#""z_rot":{"start":9205,"end":9512}"#, r#""z":0"#),
            "l.json",
            9000,
            -360.0,
        )
        .unwrap();
        assert_eq!(cut.turns[2], None);
        let err = Sections::parse(list, "l.json", 9000, -360.0).unwrap_err();
        assert!(err.contains("section \"z_rot\" runs 9205 to 9512"), "{err}");
        let err =
            Sections::parse(&list.replace("y_a", "y_down"), "l.json", 10_376, -360.0).unwrap_err();
        assert!(err.contains("section \"y_a\" needs \"start\""), "{err}");
        let err = Sections::parse("{", "l.json", 10, -360.0).unwrap_err();
        assert!(err.starts_with("l.json: line 1, column 1"), "{err}");
    }

    /// Three turns of -360 deg about the box's axes, seen through a known gyro matrix, give
    /// that matrix back from the closed form; with the box turned from the accelerometer's
    /// frame, the matrix comes back in the accelerometer's frame.
    #[test]
    fn the_turns_closed_form_gives_the_gyro_matrix() {
        let m = Matrix3::new(1.02, 0.01, -0.004, 0.003, 0.97, 0.008, -0.006, 0.002, 1.01);
        let inv = m.try_inverse().unwrap();
        let q = nalgebra::Rotation3::from_euler_angles(0.01, -0.02, 0.015).into_inner();
        let angle = -360f64.to_radians();
        let turns: Vec<KnownTurn> = (0..3)
            .map(|i| {
                // 300 samples at 100 Hz about the box's axis i, in the accelerometer's frame.
                let w = q.transpose() * Vector3::ith(i, angle / 2.99);
                let x = inv * w;
                KnownTurn {
                    dt: vec![0.01; 299],
                    x: vec![x.into(); 300],
                    angle: (q.transpose() * Vector3::ith(i, angle)).into(),
                }
            })
            .collect();
        let got = gyro_start(&turns, -360.0, &q).unwrap();
        assert!(gyro_start(&turns[..2], -360.0, &q).is_none());
        for i in 0..3 {
            for j in 0..3 {
                assert!((got[i][j] - m[(i, j)]).abs() < 1e-12, "{got:?}");
            }
        }
    }
}
