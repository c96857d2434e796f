//! Issue #21: `calibrate` no longer holds every strip whole. The automatic tie search runs tile
//! by tile on strips cut to each tile's reach, and the adjustment reads strips cut to its ties'
//! neighbourhoods. Both cuts must change nothing: on a simulated four-strip survey the ties are
//! those `auto_ties` finds on the whole strips, and tiles of 40 000 points (dozens of them) give
//! the same calibration as one tile.

use crate::binary;
use binary::{simulate_scenario, small_demo_scenario};

use lidarqa_calib::{AutoTieOptions, VtpmOptions, auto_ties};
use lidarqa_pipeline::{
    CalibrateJob, CalibrateStep, TieSource, TpuContext, TpuOptions, VTPM_NEIGHBOURS,
    calibrate_strips, load_all,
};
use std::path::PathBuf;

#[test]
fn cut_strips_give_the_whole_strips_ties_and_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let small = small_demo_scenario();
    let sim = simulate_scenario(d, &small);
    let strips: Vec<PathBuf> = (1..=4)
        .map(|i| sim.join(format!("strip_{i:03}.laz")))
        .collect();
    let ctx = TpuContext::from_files(
        &sim.join("sensor.toml"),
        &sim.join("sbet.out"),
        None,
        TpuOptions::default(),
    )
    .unwrap();
    let steps = std::sync::Mutex::new(Vec::new());
    let run = |tile_points: u64| {
        steps.lock().unwrap().clear();
        calibrate_strips(&CalibrateJob {
            strips: &strips,
            context: &ctx,
            ties: TieSource::Automatic,
            control: Some(&sim.join("control.csv")),
            method: lidarqa_calib::Method::Vtpm,
            options: lidarqa_calib::CalibrationOptions::default(),
            radius_given: false,
            weighting: None,
            tile_points,
            lines: lidarqa_pipeline::LineOptions::default(),
            progress: lidarqa_pipeline::Progress::new(&|step| steps.lock().unwrap().push(step)),
        })
        .unwrap()
    };
    let one = run(u64::MAX);
    let many = run(40_000);
    assert_eq!(one.to_document(), many.to_document());

    // The progress bar's steps: every point of the first pass once, then the ties, then the
    // adjustment.
    let steps = steps.into_inner().unwrap();
    let in_files: u64 = strips
        .iter()
        .map(|p| {
            lidarqa_io::LasReader::from_path(p)
                .unwrap()
                .info()
                .point_count
        })
        .sum();
    let reads = steps.len() - 2;
    let read: u64 = steps[..reads]
        .iter()
        .map(|s| match s {
            CalibrateStep::Read(n) => *n,
            other => panic!("{other:?} before the first pass ended"),
        })
        .sum();
    assert_eq!(read, in_files);
    assert_eq!(
        steps[reads..],
        [CalibrateStep::Ties, CalibrateStep::Adjustment]
    );

    // The ties of the whole strips, found as before the cut (same radius rule).
    let (_, _, loaded) = load_all(&strips, &ctx).unwrap();
    let whole: Vec<lidarqa_calib::Strip> = loaded.into_iter().map(|l| l.strip).collect();
    let total: usize = whole.iter().map(|s| s.points.len()).sum();
    let sparsest = whole
        .iter()
        .filter_map(|s| s.radius_for_neighbours_m(VTPM_NEIGHBOURS))
        .fold(0.0f64, f64::max);
    let vtpm = VtpmOptions {
        radius_m: sparsest.max(VtpmOptions::default().radius_m),
        ..VtpmOptions::default()
    };
    let ties = auto_ties(
        &whole,
        &ctx.sensor().mounting,
        &AutoTieOptions {
            vtpm,
            ..AutoTieOptions::default()
        },
    )
    .unwrap();
    assert!(ties.len() >= 6, "only {} ties", ties.len());
    let mut found: Vec<&str> = ties.iter().map(|t| t.id.as_str()).collect();
    let mut used: Vec<&str> = many
        .calibration
        .ties
        .iter()
        .map(|t| t.id.as_str())
        .filter(|id| id.starts_with('a'))
        .collect();
    found.sort_unstable();
    used.sort_unstable();
    assert_eq!(found, used);
    // The tiles really cut: at 40 000 points a tile holds a small part of the survey.
    assert!(total > 400_000, "{total} points");
}
