//! Every HTML report as a test engineer reads it: rendered by a real headless browser (Debian's
//! Chromium; `cargo xtask test` installs it when missing and it can, and then requires it) in a
//! window 1280 px wide, with nothing wider than the page and nothing clipped. Skipped with a
//! notice where Chromium is not installed.

mod common;
#[path = "common/lot_history.rs"]
mod lot_history;

use std::path::{Path, PathBuf};
use std::process::Command;

use calflash::sim::recording::Tumble;
use common::calflash;

/// Run in the page once it has loaded: every element that reaches beyond the window's width
/// or clips its content sideways, written into `<pre id="calflash-layout">`.
const CHECK: &str = r#"<script>
window.addEventListener('load', () => {
  const width = document.documentElement.clientWidth;
  const bad = [];
  const name = (e) => {
    const text = (e.textContent || '').trim().slice(0, 40).replace(/\s+/g, ' ');
    return e.tagName.toLowerCase() + (e.className && typeof e.className === 'string' ? '.' + e.className : '') + ' "' + text + '"';
  };
  if (document.documentElement.scrollWidth > width + 1) {
    bad.push('the page is ' + document.documentElement.scrollWidth + ' px wide');
  }
  for (const e of document.body.querySelectorAll('*')) {
    const r = e.getBoundingClientRect();
    if (r.width > 0 && r.right > width + 1) {
      bad.push(name(e) + ' reaches ' + Math.round(r.right) + ' px');
    }
    const s = getComputedStyle(e);
    if (e instanceof HTMLElement && e.clientWidth > 0 && e.scrollWidth > e.clientWidth + 1) {
      const what = ['hidden', 'clip'].includes(s.overflowX) ? ' clips ' : s.overflowX === 'visible' ? ' spills ' : ' scrolls ';
      bad.push(name(e) + what + (e.scrollWidth - e.clientWidth) + ' px of its content');
    }
  }
  const out = document.createElement('pre');
  out.id = 'calflash-layout';
  out.textContent = 'window ' + width + ' px\n' + bad.join('\n');
  document.body.appendChild(out);
});
</script>"#;

/// Debian's Chromium, or `None` with a notice (an error when `SPINCAL_REQUIRE_CHROMIUM=1`).
fn chromium(test: &str) -> Option<PathBuf> {
    let path = PathBuf::from("/usr/bin/chromium");
    if path.is_file() {
        return Some(path);
    }
    assert!(
        std::env::var("SPINCAL_REQUIRE_CHROMIUM").as_deref() != Ok("1"),
        "Chromium is required (SPINCAL_REQUIRE_CHROMIUM=1) but /usr/bin/chromium is not installed"
    );
    println!(
        "SKIPPED {test}: Chromium is not installed (Debian: apt-get install -y chromium; `cargo xtask test` does it as root)"
    );
    None
}

/// What the browser found wrong with the layout of `report` at 1280 px: empty when nothing.
fn layout_faults(browser: &Path, report: &Path) -> Vec<String> {
    let html = std::fs::read_to_string(report).unwrap();
    assert!(html.contains("</body>"), "{}: no </body>", report.display());
    let checked = report.with_extension("checked.html");
    std::fs::write(
        &checked,
        html.replacen("</body>", &format!("{CHECK}</body>"), 1),
    )
    .unwrap();
    let profile = tempfile::tempdir().unwrap();
    let out = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
            "--window-size=1280,1000",
            "--virtual-time-budget=5000",
            "--dump-dom",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .arg(format!("file://{}", checked.display()))
        .output()
        .unwrap();
    let dom = String::from_utf8_lossy(&out.stdout);
    let found = dom
        .split_once("<pre id=\"calflash-layout\">")
        .and_then(|(_, rest)| rest.split_once("</pre>"))
        .map(|(text, _)| text.to_string())
        .unwrap_or_else(|| {
            panic!(
                "{}: the browser did not run the check: {}",
                report.display(),
                String::from_utf8_lossy(&out.stderr)
            )
        });
    let mut lines = found.lines();
    assert_eq!(lines.next(), Some("window 1280 px"), "{found}");
    lines.map(str::to_string).collect()
}

/// Writes every kind of report into `d`; their paths.
fn reports(d: &Path) -> Vec<PathBuf> {
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data");
    let example = |f: &str| examples.join(f).display().to_string();
    let run = |args: &[&str]| {
        let (code, out, err) = calflash(d, args);
        assert!(code == 0 || code == 3, "{args:?}: {out}{err}");
    };
    // A bench IMU and a single axis.
    let imu = example("imu_bench.csv");
    run(&[
        "calibrate",
        &imu,
        "--sensor",
        "imu",
        "--serial",
        "IMU-R-1",
        "--report",
        "imu.html",
        "--no-db",
    ]);
    let single = example("single_accel.csv");
    run(&[
        "calibrate",
        &single,
        "--sensor",
        "single-accel",
        "--serial",
        "ACC-R-1",
        "--report",
        "single.html",
        "--no-db",
    ]);
    // A thermal calibration over a chamber's temperatures.
    run(&[
        "simulate",
        "--sensor",
        "single-accel",
        "--plan",
        "head:36",
        "--temps=-40,25,85",
        "--seed",
        "3",
        "-o",
        "thermal.csv",
    ]);
    run(&[
        "calibrate",
        "thermal.csv",
        "--sensor",
        "single-accel",
        "--serial",
        "ACC-T-1",
        "--report",
        "thermal.html",
        "--no-db",
    ]);
    // The spinning round from its spin rig.
    let round = example("spinning_round.truth.json");
    run(&[
        "simulate",
        "--sensor",
        "imu",
        "--truth",
        &round,
        "--plan",
        "tumble:24",
        "--plan",
        "rate:-1900:1900:9",
        "--plan",
        "diagonal:-1900:1900:9",
        "--plan",
        "centrifuge:1:1500:6",
        "-o",
        "rig.csv",
    ]);
    run(&[
        "calibrate",
        "rig.csv",
        "--sensor",
        "imu",
        "--nonlinear",
        "--serial",
        "ROUND-1",
        "--report",
        "round.html",
        "--no-db",
    ]);
    // Without equipment: a simulated hand tumble.
    common::write_recording(&Tumble::default().record(), d);
    run(&[
        "selfcal",
        "acc.txt",
        "gyro.txt",
        "--g",
        "9.81",
        "--serial",
        "SIM-R-1",
        "--report",
        "selfcal.html",
        "--no-db",
    ]);
    // A design, a lot, and a batch's index.
    run(&[
        "design",
        "evaluate",
        "--model",
        "single",
        "--plan",
        "head:12",
        "--plan",
        "head:36",
        "--temps=-40,25,85",
        "--report",
        "design.html",
    ]);
    lot_history::write(
        &d.join("lot.sqlite"),
        "LOT-R-",
        200,
        1_795_478_400,
        3,
        |i, b, _| {
            if i % 40 == 3 {
                b[1] += 500.0;
            }
        },
    );
    run(&[
        "lot",
        "LOT-R-",
        "--db",
        "lot.sqlite",
        "--chart",
        "ax:1",
        "--chart",
        "ay:input",
        "--report",
        "lot.html",
    ]);
    std::fs::create_dir_all(d.join("batch")).unwrap();
    std::fs::create_dir_all(d.join("out")).unwrap();
    std::fs::copy(
        examples.join("single_accel.csv"),
        d.join("batch/ACC-B-1.csv"),
    )
    .unwrap();
    std::fs::copy(d.join("thermal.csv"), d.join("batch/ACC-B-2.csv")).unwrap();
    run(&[
        "calibrate",
        "batch",
        "--sensor",
        "single-accel",
        "--out-dir",
        "out",
        "--reports",
        "--no-db",
    ]);
    [
        "imu.html",
        "single.html",
        "thermal.html",
        "round.html",
        "selfcal.html",
        "design.html",
        "lot.html",
        "out/index.html",
    ]
    .iter()
    .map(|f| d.join(f))
    .collect()
}

#[test]
fn every_report_fits_a_1280_px_window() {
    let Some(browser) = chromium("every_report_fits_a_1280_px_window") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let mut faults = Vec::new();
    for report in reports(dir.path()) {
        for f in layout_faults(&browser, &report) {
            faults.push(format!(
                "{}: {f}",
                report.file_name().unwrap().to_string_lossy()
            ));
        }
    }
    assert!(faults.is_empty(), "{}", faults.join("\n"));
}

/// The check itself finds what it is there to find: a table wider than the window, and a box
/// that clips its text.
#[test]
fn the_check_finds_a_page_too_wide_and_a_clipped_box() {
    let Some(browser) = chromium("the_check_finds_a_page_too_wide_and_a_clipped_box") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("wide.html");
    std::fs::write(
        &page,
        "<!doctype html><html><body><table style=\"width:1600px\"><tr><td>wide</td></tr></table>\
         <div style=\"width:200px;overflow:hidden;white-space:nowrap\">a line far longer than two \
         hundred pixels can hold, clipped at its edge</div></body></html>",
    )
    .unwrap();
    let faults = layout_faults(&browser, &page);
    assert!(
        faults.iter().any(|f| f.starts_with("the page is")),
        "{faults:?}"
    );
    assert!(faults.iter().any(|f| f.contains("reaches")), "{faults:?}");
    assert!(faults.iter().any(|f| f.contains("clips")), "{faults:?}");
}
