//! Scratch: times faer's numeric Cholesky of the 21² step matrix with simplicial / supernodal choices.
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, CholeskySymbolicParams, SymmetricOrdering};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Par, Side};
use flexsurf::integrate::{StepParams, Stepper};
use std::time::Instant;

fn main() {
    let n: usize = std::env::args().nth(1).and_then(|v| v.parse().ok()).unwrap_or(21);
    let scene = flexsurf::bench::scene(n, flexsurf::bench::Workload::Touching).unwrap();
    let mut stepper = Stepper::new(&scene.model, &StepParams { ..scene.step_params() }).unwrap();
    stepper.assemble(&scene.model, &scene.state);
    let pattern = scene.model.potential.pattern();
    let (col_ptr, row_idx, src) = pattern.csc_upper();
    let a = stepper.matrix();
    let values: Vec<f64> = src.iter().map(|&(blk, e)| a.blocks[blk as usize].to_cols_array()[e as usize]).collect();
    let dim = 3 * pattern.nodes();
    for (name, th) in [
        ("auto", SupernodalThreshold::AUTO),
        ("simplicial", SupernodalThreshold::FORCE_SIMPLICIAL),
        ("supernodal", SupernodalThreshold::FORCE_SUPERNODAL),
    ] {
        let sym = SymbolicSparseColMatRef::new_checked(dim, dim, &col_ptr, None, &row_idx);
        let params = CholeskySymbolicParams { supernodal_flop_ratio_threshold: th, ..Default::default() };
        let symbolic = factorize_symbolic_cholesky(sym, Side::Upper, SymmetricOrdering::Amd, params).unwrap();
        let req = StackReq::any_of(&[symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())]);
        let mut mem = MemBuffer::new(req);
        let mut l = vec![0.0; symbolic.len_val()];
        let mat = SparseColMatRef::new(sym, &values);
        let mut times = Vec::new();
        for _ in 0..50 {
            let t = Instant::now();
            symbolic
                .factorize_numeric_llt::<f64>(
                    &mut l,
                    mat,
                    Side::Upper,
                    LltRegularization::default(),
                    Par::Seq,
                    MemStack::new(&mut mem),
                    Default::default(),
                )
                .unwrap();
            times.push(t.elapsed().as_secs_f64());
        }
        times.sort_by(f64::total_cmp);
        println!("{n}: {name}: nnz(L) {} median {:.3} ms", symbolic.len_val(), 1e3 * times[25]);
    }
}
