//! Same seed ⇒ identical output with 1 and 2 threads; another seed ⇒ different output.

mod common;

use lidarqa_sim::{Scenario, SimOptions, Survey, simulate};

fn run(scenario: &Scenario, threads: usize) -> Survey {
    let options = SimOptions {
        keep_truth: true,
        chunk_pulses: 5000,
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
