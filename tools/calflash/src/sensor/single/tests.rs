use super::*;

#[test]
fn a_file_or_model_the_workflow_cannot_use_is_a_typed_error() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("nocol.csv");
    std::fs::write(&file, "angle,output\n1,2\n2,4\n3,6\n").unwrap();
    let e = calibrate(&Options::new(&file, "U-1"), Quantity::Acceleration).unwrap_err();
    assert!(
        matches!(
            &e,
            WorkflowError::Single(SingleError::MissingColumn {
                column: "input",
                ..
            })
        ),
        "{e:?}"
    );
    assert!(
        e.to_string().ends_with("the file has: angle, output"),
        "{e}"
    );
    let file = dir.path().join("obs.csv");
    std::fs::write(&file, "input,output\n-1,1\n0,2\n1,3\n2,4\n").unwrap();
    let mut opts = Options::new(&file, "U-1");
    opts.model = Some("output ~ 1".into());
    let e = calibrate(&opts, Quantity::Acceleration).unwrap_err();
    assert!(
        matches!(&e, WorkflowError::Single(SingleError::NoScaleFactor { .. })),
        "{e:?}"
    );
}

#[test]
fn asymmetry_without_inputs_on_both_sides_and_collinear_terms_are_typed_errors() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("obs.csv");
    std::fs::write(
        &file,
        "input,output\n-1,1\n0,2\n1,3.1\n2,3.9\n3,5\n4,6.1\n5,6.9\n6,8\n",
    )
    .unwrap();
    let mut opts = Options::new(&file, "U-1");
    opts.asymmetry = Some(true);
    opts.breakpoint = -0.5;
    let e = calibrate(&opts, Quantity::Acceleration).unwrap_err();
    assert!(
        matches!(
            &e,
            WorkflowError::Single(SingleError::Asymmetry {
                below: 1,
                above: 7,
                ..
            })
        ),
        "{e:?}"
    );
    assert!(e.to_string().contains("each side needs at least 2"), "{e}");
    // Inputs that are never negative make abs(input) the input itself.
    std::fs::write(
        &file,
        (0..8).fold(String::from("input,output\n"), |s, i| {
            s + &format!("{i},{}\n", 1.1 * f64::from(i) + 0.1 * f64::from(i % 3))
        }),
    )
    .unwrap();
    let mut opts = Options::new(&file, "U-1");
    opts.model = Some("output ~ 1 + input + abs(input)".into());
    let e = calibrate(&opts, Quantity::Acceleration).unwrap_err();
    assert!(
        matches!(
            &e,
            WorkflowError::Fit {
                source: crate::stats::FitError::RankDeficient { .. },
                ..
            }
        ),
        "{e:?}"
    );
    assert!(std::error::Error::source(&e).is_some());
}

#[test]
fn outputs_that_leave_nothing_inside_the_rails_are_typed_errors() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("rails.csv");
    let rows = |out: &dyn Fn(i32) -> i32| -> String {
        (0..8).fold(String::from("input,output\n"), |s, i| {
            s + &format!("{i},{}\n", out(i))
        })
    };
    std::fs::write(&file, rows(&|_| 65535)).unwrap();
    let e = calibrate(&Options::new(&file, "U-1"), Quantity::Acceleration).unwrap_err();
    assert!(
        matches!(
            &e,
            WorkflowError::Rails {
                source: crate::sensor::RailsError::Every { .. },
                ..
            }
        ),
        "{e:?}"
    );
    assert!(
        e.to_string().contains("(lines 2, 3, 4, 5, 6, 7, 8, 9)"),
        "{e}"
    );
    // Signed codes read as unsigned: many below zero, none above the top.
    let signed = (0..40).fold(String::from("input,output\n"), |s, i| {
        s + &format!("{i},{}\n", 300 * (i - 20))
    });
    std::fs::write(&file, signed).unwrap();
    let e = calibrate(&Options::new(&file, "U-1"), Quantity::Acceleration).unwrap_err();
    assert!(
        matches!(
            &e,
            WorkflowError::Rails {
                source: crate::sensor::RailsError::OtherFormat { .. },
                ..
            }
        ),
        "{e:?}"
    );
}
