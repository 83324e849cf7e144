use super::*;

fn written(name: &str, text: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join(name);
    std::fs::write(&file, text).unwrap();
    (dir, file)
}

#[test]
fn a_file_or_plan_the_triad_workflow_cannot_use_is_a_typed_error() {
    let (_dir, file) = written("nogyro.csv", "f_x,f_y,f_z,a_x,a_y,a_z\n0,0,9.8,1,2,3\n");
    let e = calibrate(&Options::new(&file, "U-1"), Kind::Gyro, false).unwrap_err();
    match &e {
        WorkflowError::Triad {
            source: TriadError::MissingColumns { missing, .. },
            ..
        } => assert_eq!(missing, &["w_x", "w_y", "w_z", "g_x", "g_y", "g_z"]),
        other => panic!("{other:?}"),
    }
    assert!(e.to_string().contains("missing the columns w_x"), "{e}");

    // Six positions that never turn the unit about y's input: f_y is always zero.
    let mut text = String::from("f_x,f_y,f_z,a_x,a_y,a_z\n");
    for (fx, fz) in [
        (9.8, 0.0),
        (-9.8, 0.0),
        (0.0, 9.8),
        (0.0, -9.8),
        (6.9, 6.9),
        (-6.9, 6.9),
    ] {
        for k in 0..3 {
            let n = f64::from(k) * 0.01;
            text += &format!(
                "{fx},0,{fz},{},{},{}\n",
                32768.0 + 1000.0 * fx + n,
                32768.0 + n,
                32768.0 + 1000.0 * fz - n
            );
        }
    }
    let (_dir, file) = written("flat.csv", &text);
    let e = calibrate(&Options::new(&file, "U-1"), Kind::Accel, false).unwrap_err();
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
    assert!(
        e.to_string().ends_with(
            "a_x at the single table point: f_y is not observable: it is 0 for every observation"
        ),
        "{e}"
    );

    // A still ramp's pose has no known heading: the error names the recording.
    let mut opts = Options::new(&file, "U-1");
    opts.still_ramp = Some("still.csv".into());
    opts.earth = Some(crate::earth::Station::new(45.0, 0.0).unwrap());
    let e = calibrate(&opts, Kind::Accel, false).unwrap_err();
    assert!(
        matches!(
            &e,
            WorkflowError::Triad {
                path,
                source: TriadError::StillRampWithLatitude,
            } if path == std::path::Path::new("still.csv")
        ),
        "{e:?}"
    );
}
