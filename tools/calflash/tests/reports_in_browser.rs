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
  // A figure's words: each inside its figure, none over another, none under 11 px as drawn.
  document.querySelectorAll('svg').forEach((svg, k) => {
    const box = svg.getBoundingClientRect();
    const drawn = svg.viewBox && svg.viewBox.baseVal && svg.viewBox.baseVal.width > 0 ? box.width / svg.viewBox.baseVal.width : 1;
    const words = [...svg.querySelectorAll('text')]
      .filter((t) => (t.textContent || '').trim() !== '')
      .map((t) => [t, t.getBoundingClientRect()]);
    const fig = 'figure ' + (k + 1) + ' "' + ((words[0] && words[0][0].textContent) || '').trim().slice(0, 30) + '"';
    for (const [t, r] of words) {
      const px = parseFloat(getComputedStyle(t).fontSize) * drawn;
      if (px < 10.95) {
        bad.push(fig + ': text "' + t.textContent.trim().slice(0, 40) + '" drawn at ' + px.toFixed(1) + ' px');
      }
      if (r.left < box.left - 1 || r.right > box.right + 1 || r.top < box.top - 1 || r.bottom > box.bottom + 1) {
        bad.push(fig + ': text "' + t.textContent.trim() + '" is cut by the figure\'s edge');
      }
    }
    for (let i = 0; i < words.length; i++) {
      for (let j = i + 1; j < words.length; j++) {
        const [a, ra] = words[i];
        const [b, rb] = words[j];
        const w = Math.min(ra.right, rb.right) - Math.max(ra.left, rb.left);
        const h = Math.min(ra.bottom, rb.bottom) - Math.max(ra.top, rb.top);
        if (w > 1 && h > 2) {
          bad.push(fig + ': "' + a.textContent.trim() + '" overlaps "' + b.textContent.trim() + '"');
        }
      }
    }
  });
  const out = document.createElement('pre');
  out.id = 'calflash-layout';
  out.textContent = 'window ' + width + ' px, page ' + document.documentElement.scrollHeight + ' px\n' + bad.join('\n');
  document.body.appendChild(out);
});
</script>"#;

/// How the browser is started: headless, alone (no network of its own), without scroll bars.
const BROWSER: [&str; 10] = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
    "--virtual-time-budget=5000",
];

/// The typeface the reports name (DejaVu Sans, Debian's `fonts-dejavu-core`): without it the
/// browser lays them out in whatever font the machine prefers, and what fits differs.
const REPORT_FONT: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

/// Debian's Chromium with the reports' typeface, or `None` with a notice (an error when
/// `SPINCAL_REQUIRE_CHROMIUM=1`).
fn chromium(test: &str) -> Option<PathBuf> {
    let path = PathBuf::from("/usr/bin/chromium");
    let missing = [
        (path.as_path(), "chromium"),
        (Path::new(REPORT_FONT), "fonts-dejavu-core"),
    ]
    .into_iter()
    .filter(|(p, _)| !p.is_file())
    .map(|(_, package)| package)
    .collect::<Vec<_>>()
    .join(" ");
    if missing.is_empty() {
        return Some(path);
    }
    assert!(
        std::env::var("SPINCAL_REQUIRE_CHROMIUM").as_deref() != Ok("1"),
        "Chromium and the reports' typeface are required (SPINCAL_REQUIRE_CHROMIUM=1) but Debian's {missing} is not installed"
    );
    println!(
        "SKIPPED {test}: Debian's {missing} is not installed (apt-get install -y {missing}; `cargo xtask test` does it as root)"
    );
    None
}

/// The tallest a report may be at 1280 px (issue 68: the thermal IMU page was 29,580 px).
const TALLEST_PX: u32 = 12_000;

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
        .args(BROWSER)
        .args(["--window-size=1280,1000", "--dump-dom"])
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
    let first = lines.next().unwrap_or_default();
    let height = first
        .strip_prefix("window 1280 px, page ")
        .and_then(|h| h.strip_suffix(" px"))
        .and_then(|h| h.parse().ok())
        .unwrap_or_else(|| panic!("{}: the check said {found}", report.display()));
    if let Some(dir) = std::env::var_os("REPORT_SCREENSHOTS") {
        eprintln!(
            "{}: page {height} px at 1280 px",
            report.file_name().unwrap().to_string_lossy()
        );
        screenshot(browser, report, height, Path::new(&dir));
    }
    let mut faults: Vec<String> = lines.map(str::to_string).collect();
    if height > TALLEST_PX {
        faults.push(format!(
            "the page is {height} px tall (at most {TALLEST_PX})"
        ));
    }
    faults
}

/// With `REPORT_SCREENSHOTS=DIR`: the whole page as the browser draws it at 1280 px, as
/// `DIR/<report>.png` (for a person to look at; the test judges the layout, not the picture).
fn screenshot(browser: &Path, report: &Path, height: u32, dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    // `out/index.html` as `out_index`; a report in the test's own directory by its name.
    let file = report.file_name().unwrap().to_string_lossy();
    let name = match report.parent().and_then(Path::file_name) {
        Some(p) if !p.to_string_lossy().starts_with(".tmp") => {
            format!("{}_{file}", p.to_string_lossy())
        }
        _ => file.to_string(),
    };
    let png = std::path::absolute(dir.join(name).with_extension("png")).unwrap();
    let profile = tempfile::tempdir().unwrap();
    let out = Command::new(browser)
        .args(BROWSER)
        .arg(format!("--window-size=1280,{}", height.clamp(200, 16_000)))
        .arg(format!("--screenshot={}", png.display()))
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .arg(format!("file://{}", report.display()))
        .output()
        .unwrap();
    assert!(
        png.is_file(),
        "{}: no screenshot: {}",
        report.display(),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Writes every kind of report into `d`; their paths.
fn reports(d: &Path, pdf: bool) -> Vec<PathBuf> {
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data");
    let example = |f: &str| examples.join(f).display().to_string();
    // With `pdf`, each command that writes a report prints it too (`--pdf`).
    let run = |args: &[&str]| {
        let mut args = args.to_vec();
        if pdf && args.iter().any(|a| *a == "--report" || *a == "--reports") {
            args.push("--pdf");
        }
        let (code, out, err) = calflash(d, &args);
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
    // An IMU tumbled and turned while the chamber ramps (thermal.md): six outputs' models
    // continuous in temperature, the longest page.
    run(&[
        "simulate",
        "--sensor",
        "imu",
        "--plan",
        "tumble:24",
        "--plan",
        "rate:-10:10:5",
        "--repeat",
        "8",
        "--ramp=-40:70",
        "--uneven",
        "--temp-step",
        "1",
        "-o",
        "imu-ramp.csv",
    ]);
    run(&[
        "calibrate",
        "imu-ramp.csv",
        "--sensor",
        "imu",
        "--serial",
        "R-2",
        "--report",
        "imu-ramp.html",
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
    common::simulate_rig(d, &round, &[]);
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
        "--blob",
        "round.blob",
        "--no-db",
    ]);
    // Its correction held against a simulated flight's truth, and the flight checked against
    // GNSS and the barometer.
    run(&[
        "simulate",
        "--sensor",
        "imu",
        "--truth",
        &round,
        "--flight",
        "shell:seconds=2",
        "-o",
        "shell2.csv",
    ]);
    run(&[
        "apply",
        "--blob",
        "round.blob",
        "shell2.csv",
        "--time-column",
        "t",
        "--reference",
        "-o",
        "shell2_si.csv",
        "--report",
        "accuracy.html",
    ]);
    run(&[
        "simulate",
        "--sensor",
        "imu",
        "--truth",
        &round,
        "--flight",
        "shell:lat=39.4,lon=-8.3,azimuth=60,rest=2,seconds=12",
        "--sample-rate",
        "2000",
        "-o",
        "s.csv",
        "--gnss",
        "g.csv",
        "--baro",
        "b.csv",
        "--launch-shift",
        "ax=0.4",
    ]);
    run(&[
        "flight",
        "s.csv",
        "--blob",
        "round.blob",
        "--gnss",
        "g.csv",
        "--baro",
        "b.csv",
        "--report",
        "flight.html",
        "--no-db",
    ]);
    // A calibration judged over the mission: an IMU's accelerometers and gyros.
    run(&[
        "calibrate",
        &imu,
        "--sensor",
        "imu",
        "--serial",
        "IMU-M-1",
        "--mission",
        "shell2.csv",
        "--report",
        "mission.html",
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
    // Noise from a still recording, and the unit's health at rest against it.
    run(&[
        "simulate",
        "--sensor",
        "imu",
        "--still",
        "600",
        "--bias-walk",
        "0.05,0.02",
        "-o",
        "still.csv",
    ]);
    run(&[
        "allan",
        "still.csv",
        "--scale",
        "412,900",
        "--json",
        "noise.json",
        "--report",
        "allan.html",
        "--kalibr",
        "imu.yaml",
    ]);
    run(&[
        "simulate",
        "--sensor",
        "imu",
        "--plan",
        "tumble:24",
        "--plan",
        "rate:-6:6:7",
        "-o",
        "bench.csv",
    ]);
    run(&[
        "calibrate",
        "bench.csv",
        "--sensor",
        "imu",
        "--serial",
        "IMU-H-1",
        "--blob",
        "h.blob",
        "--noise-terms",
        "noise.json,noise.json",
        "--ageing",
        "30d",
        "--gravity",
        "9.80:9.82",
        "--no-db",
    ]);
    run(&[
        "simulate",
        "--sensor",
        "imu",
        "--rest",
        "h.blob",
        "--shift",
        "0,0,0,12,0,0",
        "-o",
        "shock.csv",
    ]);
    run(&[
        "health",
        "shock.csv",
        "--blob",
        "h.blob",
        "--report",
        "health.html",
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
    REPORTS.iter().map(|f| d.join(f)).collect()
}

/// Every report the test writes, in the directory it writes them.
const REPORTS: [&str; 14] = [
    "imu.html",
    "imu-ramp.html",
    "single.html",
    "thermal.html",
    "round.html",
    "accuracy.html",
    "flight.html",
    "mission.html",
    "selfcal.html",
    "allan.html",
    "health.html",
    "design.html",
    "lot.html",
    "out/index.html",
];

#[test]
fn every_report_fits_a_1280_px_window() {
    let dir = tempfile::tempdir().unwrap();
    let browser = chromium("every_report_fits_a_1280_px_window");
    // Issue 68: each report prints as an A4 PDF a person signs and files: `--pdf` on the
    // command that writes it.
    let written = reports(dir.path(), browser.is_some());
    what_a_reader_finds(dir.path());
    let Some(browser) = browser else {
        return;
    };
    // The batch's own pages too, not only its index.
    let mut printed = written.clone();
    printed.extend(["out/ACC-B-1.html", "out/ACC-B-2.html"].map(|f| dir.path().join(f)));
    // And `calflash pdf` of a page already written, to a name of its own.
    let (code, out, err) = calflash(dir.path(), &["pdf", "imu.html", "-o", "imu-again.pdf"]);
    assert_eq!(code, 0, "{out}{err}");
    printed.push(dir.path().join("imu-again.html"));
    for report in &printed {
        let pdf = std::fs::read(report.with_extension("pdf"))
            .unwrap_or_else(|e| panic!("{}: no PDF: {e}", report.display()));
        let text = String::from_utf8_lossy(&pdf);
        assert!(pdf.starts_with(b"%PDF"), "{}", report.display());
        let pages = text.matches("/Type /Page\n").count()
            + text.matches("/Type /Page\r").count()
            + text.matches("/Type /Page ").count()
            + text.matches("/Type /Page/").count()
            + text.matches("/Type /Page>").count();
        let a4 = text.contains("/MediaBox [0 0 594.95996 841.91998]")
            || text.contains("/MediaBox [0 0 595 842]");
        assert!(
            a4,
            "{}: not A4 ({})",
            report.display(),
            text.split("/MediaBox")
                .nth(1)
                .unwrap_or("no MediaBox")
                .chars()
                .take(40)
                .collect::<String>()
        );
        assert!(pages >= 1, "{}: no page", report.display());
    }
    let mut faults = Vec::new();
    for report in written {
        for f in layout_faults(&browser, &report) {
            faults.push(format!(
                "{}: {f}",
                report.file_name().unwrap().to_string_lossy()
            ));
        }
    }
    assert!(faults.is_empty(), "{}", faults.join("\n"));
}

/// What the reports say beside their layout (read without a browser): the answer in a box
/// before the first section, no terminal text pasted, the spin rig's lever arms and residuals
/// against the spin rate, one unit per figure, contents on long pages, a control chart's units
/// out of control named, Allan's slope lines and Kalibr's file.
fn what_a_reader_finds(d: &Path) {
    let page = |f: &str| std::fs::read_to_string(d.join(f)).unwrap();
    for f in REPORTS {
        let html = page(f);
        // Issue 68: every page says where it comes from (when, which calflash and commit,
        // station, operator, command, each input's and the blob's SHA-256), sealed.
        let made = calflash::report::provenance::read(&html)
            .unwrap_or_else(|e| panic!("{f}: no provenance a reviewer can check: {e}"));
        assert!(
            html.contains("<section id=\"provenance\">") && !made.command.is_empty(),
            "{f}: the provenance block is not on the page"
        );
        assert!(
            !made.station.is_empty() && !made.git_commit.is_empty(),
            "{f}"
        );
        let verdict = html.find("<p class=\"verdict ");
        let first_section = html.find("<h2").unwrap_or(html.len());
        assert!(
            verdict.is_some_and(|v| v < first_section),
            "{f}: no verdict box before its first section"
        );
        // A pre block is for a file's text (Kalibr's imu.yaml), never a table or the
        // terminal's summary.
        for block in html.split("<pre").skip(1) {
            let text = block.split("</pre>").next().unwrap_or("");
            assert!(
                !text.contains(" | ")
                    && !text.contains("calflash:")
                    && !text.contains("unit ")
                    && !text.contains("±"),
                "{f}: a pre block holds terminal text or a table: {}",
                &text[..text.len().min(200)]
            );
        }
    }
    // Issue 68: the accuracy page names the bytes it judged (the blob's SHA-256 in its body,
    // not only in the provenance) and draws each error with the 1-sigma the blob stated.
    let accuracy = page("accuracy.html");
    let blob = std::fs::read(d.join("round.blob")).unwrap();
    let sha: String = {
        use sha2::Digest as _;
        sha2::Sha256::digest(&blob)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect()
    };
    let body = accuracy
        .split("<section id=\"provenance\">")
        .next()
        .unwrap();
    assert!(
        body.contains("<b>The calibration:</b> unit ") && body.contains(&sha),
        "accuracy.html: the blob's identity is not in the page's body"
    );
    let figures: Vec<&str> = body.split("<svg").skip(1).collect();
    assert!(!figures.is_empty());
    for fig in figures {
        assert!(
            fig.contains("stated 1-sigma") && fig.contains("<polygon"),
            "accuracy.html: an error figure without the stated 1-sigma's band"
        );
    }
    // Issue 68: selfcal's coefficients in a datasheet's units beside its matrices.
    let selfcal = page("selfcal.html");
    let eng = selfcal
        .split("<h2>In engineering units</h2>")
        .nth(1)
        .and_then(|t| t.split("</table>").next())
        .expect("selfcal.html: no table in engineering units");
    for unit in ["mrad", "offset (mg)", "gyro bias (deg/h)"] {
        assert!(eng.contains(unit), "selfcal.html: {unit} missing: {eng}");
    }
    assert!(
        eng.contains(" counts") || eng.contains(" ppm"),
        "selfcal.html: no scale factor in counts per g or ppm: {eng}"
    );
    // Residuals in the input's unit (over the scale factor), not in the converter's counts.
    for f in [
        "imu.html",
        "round.html",
        "single.html",
        "thermal.html",
        "mission.html",
    ] {
        assert!(
            !page(f).contains("residual (counts)"),
            "{f}: residuals in counts"
        );
    }
    assert!(page("imu.html").contains("residual (m/s^2)"));
    assert!(page("round.html").contains("residual (rad/s)"));
    let round = page("round.html");
    assert!(round.contains("<h2>Under rotation</h2>"), "round.html");
    assert!(round.contains("<th>r_x (mm)</th>") && round.contains(" &#177; "));
    assert!(round.contains("Accelerometer residuals against the spin rate"));
    assert!(round.contains("Gyro residuals against the spin rate"));
    assert!(round.contains("<nav class=\"contents\">"));
    // An IMU judged over its mission: its accelerometers and its gyros in figures of their own.
    let mission = page("mission.html");
    assert!(mission.contains("predicted 1-sigma error, m/s^2"));
    assert!(mission.contains("predicted 1-sigma error, rad/s"));
    // Plotters' own tick labels wrote each number its own way ("-2.77556e-17" beside "0.001"):
    // no figure label is a number with a five-decimal mantissa.
    for f in [
        "imu.html",
        "round.html",
        "flight.html",
        "thermal.html",
        "mission.html",
    ] {
        let html = page(f);
        let labels = html
            .split("<text")
            .skip(1)
            .filter_map(|t| t.split_once('>').and_then(|(_, r)| r.split_once("</text>")))
            .map(|(label, _)| label.trim());
        for label in labels {
            let long_mantissa = label.parse::<f64>().is_ok()
                && label
                    .split_once('e')
                    .is_some_and(|(m, _)| m.split_once('.').is_some_and(|(_, d)| d.len() >= 5));
            assert!(!long_mantissa, "{f}: a tick label {label}");
        }
    }
    // The flight's report: its verdict in a box, its facts and terms in tables (no terminal
    // text pasted), its figures saying which pass they are drawn from.
    let flight = page("flight.html");
    assert!(flight.contains("<p class=\"verdict "), "flight.html");
    assert!(!flight.contains("<pre"), "flight.html holds a pre block");
    assert!(flight.contains("<h2>The filter's fit and its inputs</h2>\n<table>"));
    assert!(flight.contains("<table class=\"terms\">"), "flight.html");
    assert!(
        flight.contains(
            "<p>Drawn from the pass with the calibration's prior, the pass the table reports"
        ) || flight.contains("<p>Drawn from the flight alone"),
        "flight.html"
    );
    // Each observed term after the launch in a figure of its own, in its unit, between the
    // calibration's 1-sigma; the terms not observed named, not drawn as flat priors.
    assert!(flight.contains("accel bias x: its shift from the calibration after the launch"));
    assert!(flight.contains("shift, m/s^2") && flight.contains("shift, rad/s"));
    assert!(
        flight.contains("the calibration&#39;s 1-sigma")
            || flight.contains("the calibration's 1-sigma")
    );
    assert!(flight.contains("<p>Not drawn: "), "flight.html");
    let not_drawn = flight
        .split("<p>Not drawn: ")
        .nth(1)
        .and_then(|t| t.split("</p>").next())
        .unwrap_or_default();
    assert!(
        not_drawn.contains("accel scale y") && !flight.contains("accel scale y: its shift"),
        "an unobserved term drawn; not drawn: {not_drawn}"
    );
    let lot = page("lot.html");
    assert!(lot.contains("point(s) out of control: LOT-R-"), "lot.html");
    assert!(!lot.contains(">plotted<"), "lot.html");
    let allan = page("allan.html");
    assert_eq!(allan.matches("slope -1/2: N = ").count(), 6);
    assert!(allan.contains("Kalibr imu.yaml"));
    assert!(page("health.html").contains("<h1>Health of unit IMU-H-1 at rest</h1>"));
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
    // In the reports' own typeface and size, and far past each limit: a title of 40 characters
    // at 16 px is over 300 px in DejaVu Sans (and over 250 px in any common typeface) in a
    // figure of 200 px, centred, so it passes both edges.
    std::fs::write(
        &page,
        "<!doctype html><html><body style=\"font-family:'DejaVu Sans',sans-serif;font-size:16px\">\
         <table style=\"width:1600px\"><tr><td>wide</td></tr></table>\
         <div style=\"width:200px;overflow:hidden;white-space:nowrap\">a line far longer than two \
         hundred pixels can hold, clipped at its edge</div>\
         <svg width=\"200\" height=\"60\" font-family=\"DejaVu Sans, sans-serif\" font-size=\"16\">\
         <text x=\"100\" y=\"20\" text-anchor=\"middle\">a title far too long for its figure, really</text>\
         <text x=\"10\" y=\"50\">0.001</text><text x=\"30\" y=\"50\">8.00000e-4</text></svg></body></html>",
    )
    .unwrap();
    let faults = layout_faults(&browser, &page);
    assert!(
        faults.iter().any(|f| f.starts_with("the page is")),
        "{faults:?}"
    );
    assert!(faults.iter().any(|f| f.contains("reaches")), "{faults:?}");
    assert!(faults.iter().any(|f| f.contains("clips")), "{faults:?}");
    assert!(
        faults
            .iter()
            .any(|f| f.contains("\"a title far too long for its figure, really\" is cut")),
        "{faults:?}"
    );
    assert!(
        faults
            .iter()
            .any(|f| f.contains("\"0.001\" overlaps \"8.00000e-4\"")),
        "{faults:?}"
    );
}
