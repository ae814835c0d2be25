//! Criterion benchmarks of the time stepping: the canonical 21×21 ball drop (300 steps, the paper's 6-minute
//! demo), one step of larger grids, and one assembly of the step system (the energy terms' values, gradients and
//! operator blocks, with the contacts found) of the sheet touching the ball. `cargo bench -p flexsurf`;
//! `flexsurf bench` prints the per-stage table.

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

fn assembly(c: &mut Criterion) {
    let mut g = c.benchmark_group("assembly");
    for n in [21, 81] {
        let scene = flexsurf::bench::scene(n, flexsurf::bench::Workload::Touching).expect("embedded scene builds");
        let mut st = Stepper::new(&scene.model, &scene.step_params()).expect("stepper");
        g.bench_function(format!("touching_{n}x{n}"), |b| b.iter(|| st.assemble(&scene.model, &scene.state)));
    }
    g.finish();
}

criterion_group!(benches, ball_drop_300_steps, single_step, assembly);
criterion_main!(benches);
