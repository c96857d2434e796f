//! Same seed ⇒ identical output with 1 and 2 threads; another seed ⇒ different output; the
//! streamed files (`simulate_to_dir`) are byte for byte those of the in-memory survey.

mod common;

use lidarqa_sim::{
    Error, PointSink, PointTruth, Scenario, SimOptions, SimPoint, Survey, simulate,
    simulate_streaming, simulate_to_dir, write_survey,
};
use std::path::Path;

fn run(scenario: &Scenario, threads: usize) -> Survey {
    let options = SimOptions {
        keep_truth: true,
        chunk_pulses: 5000,
        ..SimOptions::default()
    };
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| simulate(scenario, &options))
        .unwrap()
}

#[test]
fn same_seed_same_points_whatever_the_thread_count() {
    let mut f = common::quiet_demo(&[([-60.0, 0.0], [60.0, 0.0]), ([0.0, 60.0], [0.0, -60.0])]);
    f.errors.random = true;
    f.errors.random_mounting = true;
    let scenario = Scenario::from_file(f).unwrap();
    let one = run(&scenario, 1);
    let two = run(&scenario, 2);
    assert!(one.point_count() > 100_000);
    assert_eq!(one.strips.len(), 2);
    for (a, b) in one.strips.iter().zip(&two.strips) {
        assert!(a.points == b.points, "strip {}: points differ", a.id);
        assert!(a.truth == b.truth && a.trajectory == b.trajectory);
    }
    assert_eq!(one.control, two.control);
    assert_eq!(
        serde_json::to_string(&one.truth).unwrap(),
        serde_json::to_string(&two.truth).unwrap()
    );
    let other = run(&scenario.clone().with_seed(scenario.seed() + 1), 2);
    assert!(other.strips[0].points != one.strips[0].points);
}

#[test]
fn streamed_files_are_those_of_the_survey_in_memory() {
    let mut f = common::quiet_demo(&[([-60.0, 0.0], [60.0, 0.0]), ([0.0, 60.0], [0.0, -60.0])]);
    f.errors.random = true;
    let scenario = Scenario::from_file(f).unwrap();
    // Small chunks, so each strip streams in several windows.
    let options = SimOptions {
        keep_truth: true,
        chunk_pulses: 3000,
        ..SimOptions::default()
    };
    let memory = tempfile::tempdir().unwrap();
    let streamed = tempfile::tempdir().unwrap();
    let survey = simulate(&scenario, &options).unwrap();
    let written = write_survey(memory.path(), &scenario, &survey, true, &[]).unwrap();
    let (summary, paths) =
        simulate_to_dir(streamed.path(), &scenario, &options, true, &[]).unwrap();
    assert_eq!(summary.point_count(), survey.point_count());
    assert!(summary.strips.iter().all(|s| s.points.is_empty()));
    assert_eq!(written.len(), paths.len());
    for (a, b) in written.iter().zip(&paths) {
        assert_eq!(a.file_name(), b.file_name());
        let same = std::fs::read(a).unwrap() == std::fs::read(b).unwrap();
        assert!(same, "{}: the streamed file differs", b.display());
    }
}

/// A sink that fails on its `fail_at`-th call.
struct Failing {
    calls: usize,
    fail_at: usize,
}

impl PointSink for Failing {
    fn points(&mut self, _: usize, _: &[SimPoint], _: &[PointTruth]) -> lidarqa_sim::Result<()> {
        self.calls += 1;
        if self.calls == self.fail_at {
            return Err(Error::Parse("the sink is full".into()));
        }
        Ok(())
    }

    fn end_strip(&mut self, _: usize) -> lidarqa_sim::Result<()> {
        Ok(())
    }
}

#[test]
fn a_failing_sink_stops_the_run_with_its_error() {
    let scenario = Scenario::from_file(common::quiet_demo(&[([-60.0, 0.0], [60.0, 0.0])])).unwrap();
    let options = SimOptions {
        keep_truth: false,
        chunk_pulses: 3000,
        ..SimOptions::default()
    };
    let mut sink = Failing {
        calls: 0,
        fail_at: 3,
    };
    let e = simulate_streaming(&scenario, &options, &mut sink).unwrap_err();
    assert!(e.to_string().contains("the sink is full"), "{e}");
    assert_eq!(sink.calls, 3, "no call after the failure");
    // An output that is an input is refused before anything is computed or written.
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("strip_001.laz");
    std::fs::write(&input, b"not a strip").unwrap();
    let inputs: [&Path; 1] = [&input];
    assert!(simulate_to_dir(dir.path(), &scenario, &options, true, &inputs).is_err());
    assert_eq!(std::fs::read(&input).unwrap(), b"not a strip");
}
