//! The self-contact pile of `flexsurf bench --workload pile` (`scenes/pile.toml` at N × N nodes, its layer
//! thickness capped at 0.4 of the grid spacing), stepped and checked after every step by the test-side exact
//! triangle–triangle intersection checker (`flexsurf::testing::intersecting_triangles`, independent of the
//! contact code): `cargo run --release -p flexsurf --example pile_check -- N STEPS [EVERY]` prints every EVERY-th
//! step's time, solves, factorisations, contacts and self-contact pairs, and stops at the first intersecting
//! step. Issue 19's 161² pile of 300 steps: `-- 161 300 10`. With `COONS=k`, at every EVERY-th step, the Coons
//! surface with `k` subdivisions is checked (reported when it crosses) and the displayed surface, the Coons
//! surface kept apart as the frames write it (`runner::apart`), too: the run stops if that one crosses.
use flexsurf::integrate::Stepper;
use flexsurf::testing::intersecting_triangles;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |i: usize, default: usize| args.get(i).and_then(|s| s.parse().ok()).unwrap_or(default);
    let (n, steps, every) = (arg(1, 41), arg(2, 60), arg(3, 10).max(1));
    let coons: Option<usize> = std::env::var("COONS").ok().and_then(|v| v.parse().ok());
    let scene = flexsurf::bench::pile(n, true).expect("the pile scene");
    let (model, mut state) = (&scene.model, scene.state.clone());
    let triangles = model.faces().triangles;
    let mut stepper = Stepper::new(model, &scene.step_params()).expect("stepper");
    let (start, mut window, mut check) = (Instant::now(), Instant::now(), 0.0);
    let mut pairs_max = 0;
    for step in 1..=steps {
        let info = match stepper.step(model, &mut state) {
            Ok(info) => info,
            Err(e) => {
                eprintln!("step {step} failed: {e}");
                std::process::exit(1);
            }
        };
        pairs_max = pairs_max.max(info.self_contacts);
        let t = Instant::now();
        let hit = intersecting_triangles(&triangles, &state.x);
        check += t.elapsed().as_secs_f64();
        if let Some((a, b)) = hit {
            eprintln!("step {step}: triangles {a} and {b} intersect");
            std::process::exit(1);
        }
        if step % every == 0 {
            if let Some(k) = coons {
                use flexsurf::runner::fields::coons_mesh;
                let tris = |m: &flexsurf::surface::TriMesh| -> Vec<[usize; 3]> {
                    m.triangles.iter().map(|t| t.map(|v| v as usize)).collect()
                };
                let coons = coons_mesh(&model.panels, &state.x, k);
                if let Some((a, b)) = intersecting_triangles(&tris(&coons), &coons.positions) {
                    println!("step {step}: the Coons surface's triangles {a} and {b} intersect ({k} subdivisions)");
                }
                let t = Instant::now();
                let mut shown = coons.clone();
                let apart = flexsurf::runner::apart::keep_apart(model, &state.x, k, &mut shown);
                let took = t.elapsed().as_secs_f64();
                println!("step {step}: display kept apart in {took:.3} s: {apart:?}");
                if let Some((a, b)) = intersecting_triangles(&tris(&shown), &shown.positions) {
                    println!("step {step}: DISPLAY triangles {a} and {b} intersect ({k} subdivisions)");
                    std::process::exit(1);
                }
            }
            let c = stepper.counters;
            println!(
                "step {step:4}  {:7.2} s a step (last {every})  contacts {:6}  self-contact pairs {:6}  solves {:6}  \
                 factorisations {:6}  split {:?}",
                window.elapsed().as_secs_f64() / every as f64,
                info.contacts,
                info.self_contacts,
                c.solves,
                c.factorizations,
                stepper.split
            );
            window = Instant::now();
        }
    }
    let c = stepper.counters;
    println!(
        "{n}x{n}: {steps} steps in {:.1} s ({:.1} s of them the intersection checks), no intersecting step; solves {}, \
         factorisations {}, re-solves {}, corrections {}, self-contact {:.1} s, at most {pairs_max} self-contact pairs",
        start.elapsed().as_secs_f64(),
        check,
        c.solves,
        c.factorizations,
        c.resolves,
        c.corrections,
        c.self_contact
    );
}
