//! The parallel assembly of the elastic terms gives the same bits whatever the number of threads: each kernel
//! on its own (one thread runs the plain serial loop, more threads the batched parallel one), and a whole
//! ball drop with contact.

use flexsurf::energy::{bending::Bending, membrane::Membrane, terzopoulos, Operator, Sink};
use flexsurf::grid::Grid;
use flexsurf::integrate::Stepper;
use flexsurf::material::{Calibration, Stiffness};
use flexsurf::math::{Mat3, Vec3};
use flexsurf::sparse::{BlockMatrix, BlockPattern};
use flexsurf::testing::{cotton, perturbed};

const THREADS: [usize; 3] = [1, 2, 5];

fn with_threads<T: Send>(k: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new().num_threads(k).build().unwrap().install(f)
}

fn vec_bits(v: &[Vec3]) -> Vec<[u64; 3]> {
    v.iter().map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]).collect()
}

fn mat_bits(m: &[Mat3]) -> Vec<[u64; 9]> {
    m.iter().map(|b| b.to_cols_array().map(f64::to_bits)).collect()
}

/// Energy, gradient and blocks (as bits) of one evaluation, with the gradient and/or an operator when asked.
type Bits = (u64, Option<Vec<[u64; 3]>>, Option<Vec<[u64; 9]>>);

fn evaluate(
    pattern: &BlockPattern,
    n: usize,
    grad: bool,
    op: Option<Operator>,
    eval: &(dyn Fn(&mut Sink) -> f64 + Sync),
) -> Bits {
    // A non-zero start, so that the additions into the sink are exercised, not just copies.
    let mut g = vec![Vec3::splat(0.1); n];
    let mut h = BlockMatrix::zeros(pattern);
    h.blocks.iter_mut().for_each(|b| *b = Mat3::from_diagonal(Vec3::splat(0.3)));
    let e = {
        let mut sink =
            Sink { grad: grad.then_some(&mut g[..]), hess: op.map(|op| (&mut h, op)), energy: 0.0, journal: None };
        eval(&mut sink)
    };
    (e.to_bits(), grad.then(|| vec_bits(&g)), op.map(|_| mat_bits(&h.blocks)))
}

/// Every combination of gradient and operator under 1, 2 and 5 threads gives the same bits.
fn check_kernel(name: &str, pattern: &BlockPattern, n: usize, eval: &(dyn Fn(&mut Sink) -> f64 + Sync)) {
    let ops =
        [None, Some(Operator::Exact), Some(Operator::Projected), Some(Operator::Reflected), Some(Operator::Secant)];
    for grad in [false, true] {
        for op in ops {
            let runs: Vec<Bits> =
                THREADS.iter().map(|&k| with_threads(k, || evaluate(pattern, n, grad, op, eval))).collect();
            for (k, r) in THREADS.iter().zip(&runs).skip(1) {
                assert!(*r == runs[0], "{name}, gradient {grad}, operator {op:?}: {k} threads differ from one");
            }
        }
    }
}

/// A wrinkled, stretched state of a `n × n` sheet (large enough for the parallel path, in several batches),
/// its rest shape and the cotton stiffness.
fn configuration(n: usize) -> (Grid, Vec<Vec3>, Vec<Vec3>, Stiffness) {
    let grid = Grid::sheet(n, n, 1.0, 1.0).unwrap();
    let rest = grid.flat_positions(0.0);
    let stretched: Vec<Vec3> = rest.iter().map(|p| Vec3::new(p.x * 1.02, p.y * 0.97, 0.0)).collect();
    let x = perturbed(&stretched, 0.3 / n as f64, 11);
    (grid, rest, x, cotton(Calibration::Kes))
}

#[test]
fn kernels_give_the_same_bits_for_any_thread_count() {
    let (grid, rest, x, s) = configuration(91);
    let n = grid.len();
    // Aligned warp (4- and 5-node supports) and a bias cut (the cells' twist couples 9 nodes).
    for warp in [0.0, 0.4] {
        let mut membrane = Membrane::with_warp_angle(&grid, &rest, &s, warp);
        let mut bending = Bending::with_warp_angle(&grid, &rest, &s, warp);
        let pattern = BlockPattern::from_pairs(n, membrane.pairs().into_iter().chain(bending.pairs()));
        membrane.bind(&pattern);
        bending.bind(&pattern);
        check_kernel(&format!("membrane, warp {warp}"), &pattern, n, &|sink| membrane.evaluate(&x, sink));
        check_kernel(&format!("bending, warp {warp}"), &pattern, n, &|sink| bending.evaluate(&x, sink));
        check_kernel(&format!("terzopoulos, warp {warp}"), &pattern, n, &|sink| {
            terzopoulos::bending(&bending, &x, sink)
        });
    }
}

#[test]
fn ball_drop_gives_the_same_bits_for_any_thread_count() {
    let n = 61;
    let steps = 24;
    let runs: Vec<(Vec<[u64; 3]>, usize)> = THREADS
        .iter()
        .map(|&k| {
            with_threads(k, || {
                let scene = flexsurf::bench::ball_drop(n).unwrap();
                let mut state = scene.state.clone();
                // Start touching: the sheet is released 5 cm above the ball.
                for p in state.x.iter_mut().chain(state.x_prev.iter_mut()) {
                    p.z -= 0.045;
                }
                let mut stepper = Stepper::new(&scene.model, &scene.step_params()).unwrap();
                let mut contacts = 0;
                for _ in 0..steps {
                    contacts = contacts.max(stepper.step(&scene.model, &mut state).unwrap().contacts);
                }
                (vec_bits(&state.x), contacts)
            })
        })
        .collect();
    assert!(runs[0].1 > 0, "the sheet should touch the ball");
    for (k, r) in THREADS.iter().zip(&runs).skip(1) {
        assert!(r.0 == runs[0].0, "{k} threads: final positions differ from one thread's");
    }
}

/// The self-contact pile (`scenes/pile.toml` at 13², its layers falling onto each other) on one and two threads:
/// the same bits after 60 steps (the broad phase's candidates and the closest points are computed in
/// parallel), with self-contact records active and their cost counted.
#[test]
fn a_pile_with_self_contact_is_the_same_on_any_thread_count() {
    let runs: Vec<(Vec<[u64; 3]>, usize, f64)> = [1, 2]
        .iter()
        .map(|&k| {
            with_threads(k, || {
                let scene = flexsurf::bench::pile(13, true).unwrap();
                let mut state = scene.state.clone();
                let mut stepper = Stepper::new(&scene.model, &scene.step_params()).unwrap();
                for _ in 0..60 {
                    stepper.step(&scene.model, &mut state).unwrap();
                }
                let c = stepper.counters;
                (vec_bits(&state.x), c.self_contact_pairs, c.self_contact)
            })
        })
        .collect();
    assert!(runs[0].1 > 0 && runs[0].2 > 0.0, "the pile should touch itself: {} records, {} s", runs[0].1, runs[0].2);
    assert!(runs[1].0 == runs[0].0, "2 threads: final positions differ from one thread's");
    assert_eq!(runs[1].1, runs[0].1, "2 threads: other self-contact records");
}
