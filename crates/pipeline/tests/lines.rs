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
    let split = read_lines(
        &[&las],
        &LineOptions {
            max_gap_s: 0.2,
            ..LineOptions::default()
        },
    )
    .unwrap();
    assert_eq!(split.lines.len(), 2);
    assert_eq!(split.lines[1].points.len(), 1);
    assert!(split.warnings.iter().any(|w| w.code == "line_split"));
}

/// numpy: ARMO's lines, counted on the GPS-time gaps (> `gap` s) and, apart, on the jumps of
/// the stored sensor position (> 5 m between consecutive points in `frameNo` order); prints
/// both counts and the points of each line by time.
const ARMO: &str = "
import sys, laspy, numpy as np
l = laspy.read(sys.argv[1])
t = np.asarray(l.gps_time)
ts = np.sort(t)
cuts = ts[:-1][np.diff(ts) > float(sys.argv[2])]
by_time = len(cuts) + 1
o = np.lexsort((np.arange(len(t)), np.asarray(l['frameNo'])))
s = np.column_stack([l['SensorX'], l['SensorY'], l['SensorZ']])[o]
by_jump = int((np.linalg.norm(np.diff(s, axis=0), axis=1) > 5.0).sum()) + 1
edges = np.concatenate([[-np.inf], cuts, [np.inf]])
counts = [int(((t > a) & (t <= b)).sum()) for a, b in zip(edges[:-1], edges[1:])]
print(by_time, by_jump, *counts)
";

/// ARMO's UAV samples: two opposite lines in one file with one point source id (1), GPS time in
/// whole seconds, the sensor pose stored with every point. Both are two lines, as numpy counts
/// them on the time gaps and on the sensor position jumps; the points of each agree.
#[test]
fn armo_files_hold_two_lines_each_as_numpy_counts_them() {
    let Some(dir) = lidarqa_testkit::realdata("armo_uav") else {
        return;
    };
    for (name, points, gap) in [
        ("Car.adc.laz", [31_237, 40_988], "32.0 s"),
        ("Tent.adc.laz", [84_242, 21_978], "185.0 s"),
    ] {
        let las = dir.join(name);
        let lines = read_lines(&[&las], &LineOptions::default()).unwrap();
        let ids: Vec<&str> = lines.lines.iter().map(|l| l.id.as_str()).collect();
        assert_eq!(ids, ["1-1", "1-2"], "{name}: {:?}", lines.reasons);
        let got: Vec<usize> = lines.lines.iter().map(|l| l.points.len()).collect();
        assert_eq!(got, points, "{name}");
        let reason = &lines.reasons[0];
        assert!(
            reason.starts_with(&format!(
                "point source id 1: 2 lines, split at a GPS-time gap of {gap}"
            )) && reason.contains("GPS time is coarse")
                && reason.contains("frame counter"),
            "{name}: {reason}"
        );
        // The same lines when only each point's line is kept (calibrate's index).
        let index = lidarqa_pipeline::line_index(&[&las], &LineOptions::default(), None).unwrap();
        let counts: Vec<usize> = index.lines.iter().map(|l| l.points as usize).collect();
        assert_eq!(counts, points, "{name}");
        let first = index.of_point[0].iter().filter(|l| **l == 0).count();
        assert_eq!(first, points[0]);
        if let Some(py) = lidarqa_testkit::python("the numpy count of ARMO's lines") {
            let out = Command::new(py)
                .args(["-c", ARMO, las.to_str().unwrap(), "5.0"])
                .output()
                .unwrap();
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            let v: Vec<usize> = String::from_utf8(out.stdout)
                .unwrap()
                .split_whitespace()
                .map(|x| x.parse().unwrap())
                .collect();
            assert_eq!(v, [2, 2, points[0], points[1]], "{name}");
        }
    }
}
