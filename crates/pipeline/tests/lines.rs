//! Flight lines of the RIEGL VQ-880-G topo-bathymetric snippet (cBLUE's test data), every point
//! source id 0: the passes are counted apart with numpy on the GPS-time gaps and must agree.

use lidarqa_pipeline::{LineOptions, read_lines};
use std::process::Command;

/// numpy: sort the GPS times and count the runs between gaps longer than `gap` s; also the
/// largest gap, s.
const COUNT: &str = "
import sys, laspy, numpy as np
t = np.sort(np.asarray(laspy.read(sys.argv[1]).gps_time))
d = np.diff(t)
print(int((d > float(sys.argv[2])).sum()) + 1, float(d.max()))
";

#[test]
fn the_vq880g_snippet_is_one_pass_as_numpy_counts_it() {
    let Some(dir) = lidarqa_testkit::realdata("cblue_vq880g") else {
        return;
    };
    let las = dir.join("las_snippet_fl.las");
    let lines = read_lines(&[&las], &LineOptions::default()).unwrap();
    // Independently: numpy on the GPS-time gaps (5 s, the default).
    let want = lidarqa_testkit::python("the numpy count of the snippet's passes").map(|py| {
        let out = Command::new(py)
            .args(["-c", COUNT, las.to_str().unwrap(), "5.0"])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let s = String::from_utf8(out.stdout).unwrap();
        let mut it = s.split_whitespace();
        let n: usize = it.next().unwrap().parse().unwrap();
        let gap: f64 = it.next().unwrap().parse().unwrap();
        (n, gap)
    });
    // The snippet spans 3.3 s of one pass of the elliptical scanner (the forward and the backward
    // look of the ellipse both cover the 20 m strip); its largest GPS-time gap is 0.48 s.
    assert_eq!(lines.lines.len(), 1, "{:?}", lines.reasons);
    if let Some((n, gap)) = want {
        assert_eq!(lines.lines.len(), n);
        assert!((gap - 0.477).abs() < 0.01, "{gap}");
    }
    let l = &lines.lines[0];
    assert_eq!(l.id, "0");
    assert_eq!(l.points.len(), 56_382);
    assert!(lines.reasons[0].starts_with("point source id 0 on these points (no line id): 1 line"));
    assert!(
        lines
            .warnings
            .iter()
            .any(|w| w.code == "no_point_source_id")
    );
    // A gap threshold under its largest gap splits it, as numpy does.
    let split = read_lines(&[&las], &LineOptions {
            max_gap_s: 0.2,
            ..LineOptions::default()
        }).unwrap();
    assert_eq!(split.lines.len(), 2);
    assert_eq!(split.lines[1].points.len(), 1);
    assert!(split.warnings.iter().any(|w| w.code == "line_split"));
}
