//! Criterion benchmarks of the time stepping: the canonical 21×21 ball drop (300 steps, the paper's 6-minute
//! demo) and one step of larger grids. `cargo bench -p flexsurf`; `flexsurf bench` prints the per-stage table.

use criterion::{criterion_group, criterion_main, Criterion};
use flexsurf::bench::ball_drop;
use flexsurf::integrate::Stepper;

fn ball_drop_300_steps(c: &mut Criterion) {
    let scene = ball_drop(21).expect("embedded scene builds");
    let mut g = c.benchmark_group("ball_drop");
    g.sample_size(10);
    g.bench_function("21x21_300_steps", |b| {
        b.iter(|| {
            let mut state = scene.state.clone();
            let mut st = Stepper::new(&scene.model, &scene.step_params()).expect("stepper");
            for _ in 0..300 {
                st.step(&scene.model, &mut state).expect("stable step");
            }
            state
        })
    });
    g.finish();
}

fn single_step(c: &mut Criterion) {
    let mut g = c.benchmark_group("step");
    g.sample_size(10);
    for n in [21, 41, 81] {
        let scene = ball_drop(n).expect("embedded scene builds");
        // Time a step in the middle of the drape (after the impact).
        let mut state = scene.state.clone();
        let mut st = Stepper::new(&scene.model, &scene.step_params()).expect("stepper");
        for _ in 0..30 {
            st.step(&scene.model, &mut state).expect("stable step");
        }
        g.bench_function(format!("{n}x{n}"), |b| {
            b.iter(|| {
                let mut s = state.clone();
                st.step(&scene.model, &mut s).expect("stable step");
                s
            })
        });
    }
    g.finish();
}

criterion_group!(benches, ball_drop_300_steps, single_step);
criterion_main!(benches);
